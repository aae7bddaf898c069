#!/usr/bin/env bash
# Sets up .venv (CPU torch pinned) and runs the whole test suite, on every core (pytest-xdist).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export RERUN_ANALYTICS=0 PYTHONUNBUFFERED=1
# One torch/BLAS thread per process: the suite's workers and the services they start already fill the
# cores, and oversubscribed threads made small networks several times slower.
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}
# The set-up installs without byte-compiling (torch: 40 s -> 14 s); the first import writes the
# .pyc files, so they must be allowed: with PYTHONDONTWRITEBYTECODE every one of the suite's
# processes would compile torch from source again (measured: the suite 664 s instead of ~390 s).
unset PYTHONDONTWRITEBYTECODE
# Turn Rerun analytics off for this user too: the machines are offline.
.venv/bin/rerun analytics disable >/dev/null 2>&1 || true
# worksteal: a worker that runs out of tests takes queued ones from the other (the suite ends with a few
# 20-30 s tests; plain load scheduling could leave one core idle behind them)
exec .venv/bin/python -m pytest -q -n auto --dist worksteal --durations=5 "$@"
