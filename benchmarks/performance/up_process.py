"""An ``acnmp up`` deployment in a process of its own, for the benchmarks that measure its processes
from outside (bench_acl.py, bench_model_memory.py): authenticated, no workers, skill e1 trained for
20 steps, its state in a temporary directory."""
from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import tempfile
import uuid
from pathlib import Path
from typing import Iterator

ROOT = Path(__file__).resolve().parents[2]


@contextlib.contextmanager
def up_process(prefix: str, env_extra: dict | None = None) -> Iterator:
    """Run ``acnmp up`` (namespace ``<prefix>-<random>``) until the block ends (SIGTERM); yields its
    run file (services/transport/runfile.py: namespace, pid, credentials, each child's pid) once
    it says the deployment is up."""
    from services.transport.runfile import find

    ns = f"{prefix}-{uuid.uuid4().hex[:6]}"
    with tempfile.TemporaryDirectory(prefix=f"{prefix}-up-") as tmp:
        env = dict(os.environ, PYTHONPATH=str(ROOT), RERUN_ANALYTICS="0", **(env_extra or {}))
        up = subprocess.Popen([sys.executable, "-m", "clients.cli", "up", "-n", ns, "--workers", "0", "--train-steps",
                               "20", "--state-dir", f"{tmp}/state"], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True)
        try:
            for line in up.stdout:
                if "deployment is up" in line:
                    break
            yield find(ns)
        finally:
            up.terminate()
            up.wait(timeout=60)


def rss(pid: int) -> int:
    """The resident set of process ``pid`` now, bytes."""
    import psutil

    return psutil.Process(pid).memory_info().rss
