"""``python -m services.model [--skill NAME] [--checkpoint FILE] [--namespace NS] [--connect EP] ...``."""
import sys

from services.model.service import ModelConfig
from services.transport.service import main

sys.exit(main(ModelConfig))
