#!/usr/bin/env bash
# The README's first quick-start command: set up, build, run the main job.
#
# The main job shows the system end to end as far as it is built (README,
# "Quick start"): the skin model, an LED library measured on the virtual lab
# through the real drivers, the D65' mix solved from it, and the daemon's
# standard capture session over its socket API, ending in chromophore maps and
# a report (chromod's on-line estimator) whose place and headline numbers it prints.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
bin=build/release/bin
export CHROMO_HOME=${CHROMO_HOME:-$PWD/demo-home}

echo "== 1. the skin model (Cm 0.05, Ch 0.03, βm 0.7, Che 0.01) under D65"
"$bin/chromo" model --cm 0.05 --ch 0.03 --bm 0.7 --che 0.01 --illuminant d65 | tail -4

echo "== 2. LED library measured on the virtual lab (Modbus TCP + USB2000+ protocol)"
"$bin/chromo" leds measure

echo "== 3. D65' from the measured library (camera objective, chromaticity held)"
"$bin/chromo" leds solve --target d65 --objective camera --hold-chromaticity

echo "== 4. the standard capture session through chromod, estimated on line into maps and a report"
scripts/demo-session.sh "$CHROMO_HOME/sessions"
