"""``python -m services.recording --out FILE.rrd [--namespace NS] [--connect EP] ...``: the recorder."""
from services.recording.recorder import RecorderConfig
from services.transport.lifetime import exit_now
from services.transport.service import main

exit_now(main(RecorderConfig))  # everything is closed: skip the slow interpreter teardown
