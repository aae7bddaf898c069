#!/usr/bin/env bash
# Installs Debian's chromium where it is missing: the browser tests/e2e/test_live_viewer.py loads the
# live web viewer in (headless). .ci/run runs it before the suite; a developer may run it once.
#
# Debian's package (no browser download of a driver's own), without the recommended extras: 25
# packages, about 100 MB fetched; measured here 18-23 s with the package lists present. The lists are
# refreshed (apt-get update) only when the package cannot be found in them. Without root or
# apt-get it installs nothing and says so: the test then fails in CI (CI set) and skips elsewhere.
set -euo pipefail
if command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1; then
  exit 0
fi
if [ "$(id -u)" != 0 ] || ! command -v apt-get >/dev/null 2>&1; then
  echo "install_chromium: no chromium here, and no apt-get as root to install Debian's: the live viewer's browser test cannot run" >&2
  exit 0
fi
export DEBIAN_FRONTEND=noninteractive
start=$(date +%s)
apt() { apt-get -q -y -o DPkg::Lock::Timeout=300 "$@" >/dev/null; }
if ! apt install --no-install-recommends chromium 2>/dev/null; then
  apt update
  apt install --no-install-recommends chromium
fi
echo "install_chromium: installed $(chromium --version 2>/dev/null | head -1) in $(( $(date +%s) - start )) s"
