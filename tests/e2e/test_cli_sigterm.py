"""SIGTERM to an in-process ``acnmp experiment`` (e.g. a job scheduler's or ``timeout``'s stop) unwinds
like Ctrl-C: the process exits with 128 + SIGTERM and its exit handlers run, so the URDF files it
generated are removed instead of left in the temporary directory. Run as a real child process."""
from __future__ import annotations

import glob
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_sigterm_unwinds_an_experiment_and_removes_its_generated_files(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT), RERUN_ANALYTICS="0", TMPDIR=str(tmp_path))
    env.pop("ACNMP_TRACEBACK", None)
    # E4 builds its planar arms' URDFs in a per-process directory (within ~8 s, E2 takes ~19 s to get
    # there) before it trains for minutes
    proc = subprocess.Popen([sys.executable, "-m", "clients.cli", "experiment", "transfer", "--runs", "1"], cwd=ROOT,
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        pattern = os.path.join(str(tmp_path), f"acnmp-urdf-{proc.pid}-*")
        deadline = time.monotonic() + 120
        while not glob.glob(pattern) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.1)  # polls for the directory: the condition the test waits on
        assert glob.glob(pattern), "the experiment never generated its URDF"
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 128 + signal.SIGTERM, err
    assert "Traceback" not in err, err
    assert glob.glob(pattern) == [], "the generated URDF directory was left behind"
