"""``acnmp up`` in one process, ``acnmp query info`` with no arguments in 20 others (issue 12, discovery).

Starts ``acnmp up --workers 0 --train-steps 20`` (the default skill e1, briefly trained) with its own
runtime directory, then runs ``acnmp query info --skill e1`` as a fresh process ``--n`` times in a
row, as a user in another terminal would. Reported: how many answered (exit 0 and the skill's
description), and each command's wall time (p50/max, seconds: mostly the interpreter's start).

    python benchmarks/performance/bench_discovery.py [--n 20] [--out benchmarks/results/bench_discovery.json]
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks._results import benchmark_args, provenance, save_result  # noqa: E402


def main() -> int:
    args = benchmark_args(__doc__, "bench_discovery", None, n=(20, "`acnmp query info` processes run one after the other"))
    prov = provenance()
    tmp = Path(tempfile.mkdtemp(prefix="acnmp-bench-discovery-"))
    env = dict(os.environ, PYTHONPATH=str(ROOT), RERUN_ANALYTICS="0", ACNMP_RUNTIME_DIR=str(tmp / "run"))
    env.pop("ACNMP_CONNECT", None)
    up = subprocess.Popen([sys.executable, "-m", "clients.cli", "up", "--workers", "0", "--train-steps", "20",
                           "--state-dir", str(tmp / "state")], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True)
    try:
        for line in up.stdout:
            if "deployment is up" in line:
                break
        else:
            raise RuntimeError("acnmp up did not come up")
        answered, walls, failures = 0, [], []
        for _ in range(args.n):
            t = time.perf_counter()
            out = subprocess.run([sys.executable, "-m", "clients.cli", "query", "info", "--skill", "e1"],
                                 cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
            walls.append(time.perf_counter() - t)
            if out.returncode == 0 and out.stdout.startswith("skill e1 version"):
                answered += 1
            else:
                failures.append(out.stderr.strip().splitlines()[-1:] or [f"exit {out.returncode}"])
        up.send_signal(signal.SIGINT)
        rest, _ = up.communicate(timeout=60)
    finally:
        if up.poll() is None:
            up.kill()
            up.wait()
    result = {"provenance": prov, "n": args.n, "answered": answered, "failures": failures,
              "up_exit_code": up.returncode, "stopped_line": next((ln for ln in rest.splitlines()
                                                                   if ln.startswith("deployment stopped")), None),
              "wall_s": {"p50": float(np.median(walls)), "max": float(np.max(walls))},
              "headline": f"acnmp query info with no arguments: {answered}/{args.n} answered"}
    save_result(result, args.out)
    return 0 if answered == args.n else 1


if __name__ == "__main__":
    sys.exit(main())
