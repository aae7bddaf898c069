#!/usr/bin/env bash
# Sets up .venv (CPU torch pinned) and runs the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export RERUN_ANALYTICS=0 PYTHONUNBUFFERED=1
# Turn Rerun analytics off for this user too: the machines are offline.
.venv/bin/rerun analytics disable >/dev/null 2>&1 || true
exec .venv/bin/python -m pytest -q "$@"
