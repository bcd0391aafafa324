#!/usr/bin/env bash
# The README's second quick-start command: set up, build, run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
ctest --preset release -j2 "$@"
