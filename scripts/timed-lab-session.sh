#!/usr/bin/env bash
# One standard session on chromod's virtual lab from a configuration file,
# timed: how long the lab took to start (its scene prepared, the camera
# simulators listening: until chromod's socket answers), then the session's
# timeline from its journal (`chromo session show`: capture, derived data and
# maps after the last frame) and, from the journal's records
# (scripts/session_split.py), how the capture splits into the steps' own time
# (settle + exposure per frame), the white steps' metering and the rest
# (rendering the frames in the camera simulators, sending and storing them),
# and the derived data and maps after the last frame.
#
#   scripts/timed-lab-session.sh CONFIG.json [SESSIONS_DIR]
#
# E.g. scripts/timed-lab-session.sh scripts/lab-two-5mp-cameras.json (two 5-MP
# BayerRG12 cameras, issue 21 part 5). Assumes a build in build/release.
# Stops the daemon it started on exit.
set -euo pipefail
cd "$(dirname "$0")/.."
config=${1:?usage: scripts/timed-lab-session.sh CONFIG.json [SESSIONS_DIR]}
sessions=${2:-timed-sessions}
bin=build/release/bin
mkdir -p "$sessions"
run_dir=$(mktemp -d "$sessions/.chromod-run-XXXXXX")
socket="$run_dir/chromod.sock"
export CHROMO_DAEMON="unix:$socket"

started_ns=$(date +%s%N)
CHROMO_RUNTIME_DIR="$run_dir" "$bin/chromod" --config "$config" --socket "$socket" --sessions-dir "$sessions" \
  >"$run_dir/chromod.log" 2>&1 &
daemon_pid=$!
trap 'kill "$daemon_pid" 2>/dev/null; wait "$daemon_pid" 2>/dev/null || true; rm -rf "$run_dir"' EXIT
until "$bin/chromo" status >/dev/null 2>&1; do
  kill -0 "$daemon_pid" 2>/dev/null || { cat "$run_dir/chromod.log" >&2; exit 1; }
  sleep 0.05
done
ready_ns=$(date +%s%N)
echo "lab preparation (chromod start until its socket answers: scene, simulators, drivers): $(( (ready_ns - started_ns) / 1000000 )) ms"
grep -m3 "camera simulator\|virtual lab" "$run_dir/chromod.log" || true

session_start_ns=$(date +%s%N)
started=$("$bin/chromo" session run --detach --subject "timed session" --exposure-us 10000)
id=$(sed -n 's/^session \([^ ]*\) started$/\1/p' <<<"$started")
[[ -n "$id" ]] || { echo "timed-lab-session: no session id in: $started" >&2; exit 1; }
"$bin/chromo" session watch "$id" >/dev/null || true
done_ns=$(date +%s%N)
"$bin/chromo" session show "$id" | grep -i "timeline\|state" || true
echo "session request to its end (client's clock): $(( (done_ns - session_start_ns) / 1000000 )) ms"
# Where the session's time went, from its records; the lab's preparation apart.
scripts/session_split.py "$sessions/$id" --lab-preparation-s "$(( (ready_ns - started_ns) / 1000000 ))e-3"
echo "session folder: $sessions/$id"
