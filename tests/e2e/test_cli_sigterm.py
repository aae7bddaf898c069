"""SIGTERM to an in-process ``acnmp experiment`` (e.g. a job scheduler's or ``timeout``'s stop) unwinds
like Ctrl-C: the process exits with 128 + SIGTERM, without a traceback. The URDFs it generated are in
the shared cache, named by content, and nothing of the process is left in the temporary directory
(a per-process URDF directory used to be, whenever exit handlers did not run). Run as a real child
process."""
from __future__ import annotations

import glob
import os
import signal
import subprocess
import sys
import time
from tests.paths import ROOT



def test_sigterm_unwinds_an_experiment_and_removes_its_generated_files(tmp_path):
    cache, tmp = tmp_path / "cache", tmp_path / "tmp"
    tmp.mkdir()
    env = dict(os.environ, PYTHONPATH=str(ROOT), RERUN_ANALYTICS="0", TMPDIR=str(tmp), ACNMP_CACHE=str(cache))
    env.pop("ACNMP_TRACEBACK", None)
    # E4 builds its planar arms' URDFs (within ~8 s; E2 takes ~19 s to get there) before it trains for minutes
    proc = subprocess.Popen([sys.executable, "-m", "clients.cli", "experiment", "transfer", "--seeds", "1"], cwd=ROOT,
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        pattern = str(cache / "urdf" / "planar_arm_*.urdf")
        deadline = time.monotonic() + 120
        while not glob.glob(pattern) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.1)  # polls for the file: the condition the test waits on
        assert glob.glob(pattern), "the experiment never generated its URDF"
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 128 + signal.SIGTERM, err
    assert "Traceback" not in err, err
    assert not [p for p in tmp.iterdir() if p.name.startswith("acnmp-urdf-")], "a URDF directory was left behind"
    assert not glob.glob(str(cache / "urdf" / "*.tmp")), "a half-written URDF was left in the cache"
