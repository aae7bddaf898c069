"""``python -m services.learner [--state-dir DIR] [--namespace NS] [--connect EP] ...``."""
import sys

from services.learner.service import LearnerConfig
from services.transport.service import main

sys.exit(main(LearnerConfig))
