#!/usr/bin/env bash
# The main job: start chromod on the built-in virtual lab, run the method's
# standard session end to end over the socket API (live progress), and print
# where the frames, the derived albedo, the maps and the report are.
#
#   scripts/demo-session.sh [--config FILE] [SESSIONS_DIR]     (default: ./demo-sessions)
#
# --config FILE: chromod's configuration (docs/config.md), e.g. a lab of
# other cameras (scripts/lab-two-5mp-cameras.json: two 5-MP cameras);
# without it chromod runs its built-in virtual lab (one 640x480 camera).
# Assumes a build in build/release (scripts/build.sh). Stops the daemon it
# started on exit.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/release/bin
config_args=()
if [[ ${1:-} == --config ]]; then
  [[ -n ${2:-} ]] || { echo "demo-session: --config needs a FILE" >&2; exit 2; }
  [[ -f $2 ]] || { echo "demo-session: --config $2: no such file" >&2; exit 2; }
  config_args=(--config "$2")
  shift 2
fi
[[ ${1:-} != -* ]] || { echo "demo-session: unknown option '$1' (usage: demo-session.sh [--config FILE] [SESSIONS_DIR])" >&2; exit 2; }
sessions=${1:-demo-sessions}
# The daemon's socket and run files go in a folder of the demo's own (never /tmp).
mkdir -p "$sessions"
run_dir=$(mktemp -d "$sessions/.chromod-run-XXXXXX")
socket="$run_dir/chromod.sock"

CHROMO_RUNTIME_DIR="$run_dir" "$bin/chromod" "${config_args[@]}" --socket "$socket" --sessions-dir "$sessions" &
daemon_pid=$!
trap 'kill "$daemon_pid" 2>/dev/null; wait "$daemon_pid" 2>/dev/null || true; rm -rf "$run_dir"' EXIT
# (A lab of 5-MP cameras prepares its scenes before it listens: up to ~10 s.)
for _ in $(seq 600); do [[ -S "$socket" ]] && break; kill -0 "$daemon_pid" 2>/dev/null || exit 1; sleep 0.1; done

export CHROMO_DAEMON="unix:$socket"
"$bin/chromo" status
# The daemon's own LED library: a calibration run on its spectrometer (the
# sessions' mixes and illuminants come from it; a daemon never takes another's
# library, docs/calibration.md §6). Skipped when it has one already.
if ! "$bin/chromo" solve d65 >/dev/null 2>&1; then
  "$bin/chromo" calibrate
fi
# Started detached for its id, then followed: the progress goes straight to
# stdout (a `| tee /dev/stderr` reopened stderr and, when the job's output
# was redirected to a file, truncated that log).
started=$("$bin/chromo" session run --detach --subject "demo forearm" --exposure-us 10000)
echo "$started"
id=$(sed -n 's/^session \([^ ]*\) started$/\1/p' <<<"$started")
[[ -n "$id" ]] || { echo "demo-session: no session id in: $started" >&2; exit 1; }
"$bin/chromo" session watch "$id"
echo
"$bin/chromo" session show "$id"
echo
# Results: chromod's on-line estimator wrote the maps and the report into the
# session folder; `chromo results` says where, with the headline numbers
# (estimator speed, flag counts, relit ΔE94 against the captured photographs).
# When there are no maps it says why (e.g. a camera without colour).
echo "== results of session $id"
"$bin/chromo" results "$id" || true
echo "derived albedo: $(ls "$sessions/$id"/derived/albedo-*.exr | tr '\n' ' ')"
if [[ -f "$sessions/$id/results/maps.exr" ]]; then
  echo "maps:    $sessions/$id/results/maps.exr (Cm, Ch, Bm, Che, residual, order, flags)"
  echo "report:  $sessions/$id/results/summary.json"
  echo "previews: $(cd "$sessions/$id/results" && ls *.png | tr '\n' ' ')"
fi
