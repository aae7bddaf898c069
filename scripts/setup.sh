#!/usr/bin/env bash
# Creates .venv (if missing) and installs the project with the CPU build of torch pinned.
# Idempotent: a second run only checks that everything is there.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  "$PY" -m venv .venv
fi
. .venv/bin/activate
export PIP_DISABLE_PIP_VERSION_CHECK=1
# No byte-compiling of every installed module (torch alone: 40 s -> 14 s here); Python compiles
# what is imported, once, on first use.
PIP_FLAGS=(-q --no-compile)
# torch first and pinned: an unpinned torch may pull a multi-GB CUDA build.
python -c "import torch" 2>/dev/null || pip install "${PIP_FLAGS[@]}" "torch==2.13.0"
pip install "${PIP_FLAGS[@]}" -e ".[test,gym]"
