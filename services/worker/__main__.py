"""``python -m services.worker --robot point2d [--id ID] [--namespace NS] [--connect EP] ...``."""
from services.transport.lifetime import exit_now
from services.transport.service import main
from services.worker.service import WorkerConfig

exit_now(main(WorkerConfig))  # everything is closed: skip the slow interpreter teardown
