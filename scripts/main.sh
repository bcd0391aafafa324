#!/usr/bin/env bash
# The README's first quick-start command: set up, build, run the main job.
#
# The main job shows the system end to end as far as it is built (README,
# "Quick start"): the skin model, an LED library measured on the virtual lab
# through the real drivers, the D65' mix solved from it, and the daemon's
# standard capture session over its socket API, ending in chromophore maps and
# a report (chromod's on-line estimator) whose place and headline numbers it prints.
#
#   scripts/main.sh [--two-5mp | --small]
#
# --two-5mp: the session on two 5-MP cameras (scripts/lab-two-5mp-cameras.json,
# issue 21 part 5), then where its time went (scripts/session_split.py);
# the default: every camera metered on its lit region and mapped into
# results/<camera>/ (docs/maps.md, "Several cameras");
# --small: the built-in lab's one 640x480 camera (a quicker look).
set -euo pipefail
cd "$(dirname "$0")/.."
lab=two-5mp
case "${1:-}" in
  "") ;;
  --small) lab=small ;;
  --two-5mp) lab=two-5mp ;;
  *) echo "main.sh: unknown option '$1' (usage: scripts/main.sh [--two-5mp | --small])" >&2; exit 2 ;;
esac
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

if [[ $lab == two-5mp ]]; then
  echo "== 4. the standard capture session on two 5-MP cameras through chromod, estimated on line into maps and a report"
  scripts/demo-session.sh --config scripts/lab-two-5mp-cameras.json "$CHROMO_HOME/sessions" | tee "$CHROMO_HOME/main-session.log"
  id=$(sed -n 's/^session \([^ ]*\) started$/\1/p' "$CHROMO_HOME/main-session.log")
  echo "== 5. where the session's time went"
  scripts/session_split.py "$CHROMO_HOME/sessions/$id"
else
  echo "== 4. the standard capture session through chromod (one 640x480 camera), estimated on line into maps and a report"
  scripts/demo-session.sh "$CHROMO_HOME/sessions"
fi
