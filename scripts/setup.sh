#!/usr/bin/env bash
# Creates .venv (if missing) and installs the project with the CPU build of torch pinned.
# Idempotent: once an install succeeded, a run returns at once while pyproject.toml and this
# script are unchanged (the stamp .venv/.setup-stamp holds their hash; the check by the
# installer alone took 10-30 s here, which every scripts/test.sh paid); ACNMP_SETUP=force checks
# everything again.
#
# The install goes through uv (pinned below; about 15 s here against about 75 s for pip, which
# resolves and unpacks one package at a time), with the indexes, find-links and constraints of
# this machine's pip configuration. If uv cannot be installed or cannot resolve (e.g. no CPU
# build of torch among the find-links), pip does it as before.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
STAMP=.venv/.setup-stamp
# ACNMP_EXTRAS: the extras to install (default test,gym,peers,rosbag; `scripts/test.sh --slow` adds datasets)
EXTRAS=".[${ACNMP_EXTRAS:-test,gym,peers,rosbag}]"
stamp() { { cat pyproject.toml scripts/setup.sh; echo "$EXTRAS"; } | sha256sum | cut -d' ' -f1; }
if [ "${ACNMP_SETUP:-}" != force ] && [ -x .venv/bin/python ] && [ -f "$STAMP" ] && [ "$(cat "$STAMP")" = "$(stamp)" ]; then
  exit 0
fi
rm -f "$STAMP"
if [ ! -x .venv/bin/python ]; then
  "$PY" -m venv .venv
fi
. .venv/bin/activate
export PIP_DISABLE_PIP_VERSION_CHECK=1
# No byte-compiling of every installed module (torch alone: 40 s -> 14 s here); Python compiles
# what is imported, once, on first use.
PIP_FLAGS=(-q --no-compile)

pip_setting() {  # the values of one pip configuration key, split on white space
  python -m pip config get "$1" 2>/dev/null | tr ' ' '\n' | grep -v '^$' || true
}

install_with_uv() {
  python -m pip install "${PIP_FLAGS[@]}" "uv==0.13.8" >/dev/null 2>&1 || return 1
  local args=(--python .venv/bin/python --index-strategy unsafe-best-match)
  local value
  for value in $(pip_setting global.index-url); do args+=(--index-url "$value"); done
  for value in $(pip_setting global.extra-index-url) ${PIP_EXTRA_INDEX_URL:-}; do args+=(--extra-index-url "$value"); done
  for value in $(pip_setting global.find-links) ${PIP_FIND_LINKS:-}; do args+=(--find-links "$value"); done
  for value in $(pip_setting global.constraint) ${PIP_CONSTRAINT:-}; do
    [ -f "$value" ] && args+=(--constraint "$value")
  done
  # the CPU build named exactly: never a multi-GB CUDA build from a default index
  .venv/bin/uv pip install -q "${args[@]}" "torch==2.13.0+cpu" -e "$EXTRAS"
}

if ! install_with_uv; then
  echo "setup: uv could not install the environment; installing with pip" >&2
  # torch first and pinned: an unpinned torch may pull a multi-GB CUDA build.
  python -c "import torch" 2>/dev/null || pip install "${PIP_FLAGS[@]}" "torch==2.13.0"
  pip install "${PIP_FLAGS[@]}" -e "$EXTRAS"
fi
stamp > "$STAMP"
