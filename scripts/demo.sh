#!/usr/bin/env bash
# Sets up .venv and runs the main job: a whole local deployment (recorder, learner, model service,
# workers over zenoh on 127.0.0.1) reproducing E1, leaving results in out/ and a Rerun recording.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
.venv/bin/rerun analytics disable >/dev/null 2>&1 || true
mkdir -p out
# --fresh: its own deployment (a private namespace and state), even while an `acnmp up` runs
.venv/bin/acnmp experiment viapoint --distributed --fresh --workers 2 --record out/e1.rrd \
    --json out/e1.json --plot out/e1.png "$@"
.venv/bin/acnmp replay out/e1.rrd
