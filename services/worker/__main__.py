"""``python -m services.worker --robot point2d [--id ID] [--namespace NS] [--connect EP] ...``."""
import sys

from services.transport.service import main
from services.worker.service import WorkerConfig

sys.exit(main(WorkerConfig))
