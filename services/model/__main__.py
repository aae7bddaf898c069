"""``python -m services.model [--skill NAME] [--checkpoint FILE] [--namespace NS] [--connect EP] ...``."""
from services.model.service import ModelConfig
from services.transport.lifetime import exit_now
from services.transport.service import main

exit_now(main(ModelConfig))  # everything is closed: skip the slow interpreter teardown
