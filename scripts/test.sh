#!/usr/bin/env bash
# Sets up .venv (CPU torch pinned) and runs the tests on every core, one pytest-xdist worker more than the cores.
#
#   bash scripts/test.sh            # the default suite: every test but the slow ones
#   bash scripts/test.sh --fast     # the inner loop: tests/unit without the slow and the heavy tests
#   bash scripts/test.sh --slow     # only the slow tests (minutes each: the pinned regression runs,
#                                   # E3's learning, the datasets' own libraries, which it installs:
#                                   # the extra "datasets"); before a release (docs/RELEASE.md)
#
# Any other argument goes to pytest as it is (paths, -k, -x, ...). A -m EXPR of yours selects among
# the tests that are not slow: the slow ones run only when EXPR names them (tests/selection.py), so
# `-m "not e2e"` never brings them in; the heavy ones (seconds of training each) are listed in
# tests/selection.py. ACNMP_TEST_DRY_RUN=1 prints the pytest command instead.
set -euo pipefail
cd "$(dirname "$0")/.."
args=()
for arg in "$@"; do
  case "$arg" in
    --fast) args+=(tests/unit --fast) ;;
    --slow) args+=(-m slow); export ACNMP_EXTRAS=${ACNMP_EXTRAS:-test,gym,peers,rosbag,datasets} ;;
    *) args+=("$arg") ;;
  esac
done
# worksteal: a worker that runs out of tests takes queued ones from the other (the suite ends with a few
# 20-30 s tests; plain load scheduling could leave one core idle behind them). One pytest worker more
# than the cores: the end-to-end tests wait on their services' start-ups and replies, and a third
# worker fills that time on 2 cores (ACNMP_TEST_WORKERS to choose). nproc without OMP_* (it obeys them).
workers=${ACNMP_TEST_WORKERS:-$(( $(env -u OMP_NUM_THREADS -u OMP_THREAD_LIMIT nproc) + 1 ))}
command=(.venv/bin/python -m pytest -q -n "$workers" --dist worksteal --durations=5 ${args[@]+"${args[@]}"})
if [ "${ACNMP_TEST_DRY_RUN:-}" = 1 ]; then
  printf '%s\n' "${command[@]}"
  exit 0
fi
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
exec "${command[@]}"
