"""``python -m services.learner [--state-dir DIR] [--namespace NS] [--connect EP] ...``."""
from services.learner.service import LearnerConfig
from services.transport.lifetime import exit_now
from services.transport.service import main

exit_now(main(LearnerConfig))  # everything is closed: skip the slow interpreter teardown
