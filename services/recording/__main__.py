"""``python -m services.recording --out FILE.rrd [--namespace NS] [--connect EP] ...``: the recorder."""
import sys

from services.recording.recorder import RecorderConfig
from services.transport.service import main

sys.exit(main(RecorderConfig))
