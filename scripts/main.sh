#!/usr/bin/env bash
# The README's first quick-start command: set up, build, run the main job.
#
# Until the daemon exists (issue "The daemon"), the main job evaluates the skin
# model for a typical light skin and prints its albedo spectrum and colour.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
build/release/bin/chromo model --cm 0.05 --ch 0.03 --bm 0.7 --che 0.01 --illuminant d65
