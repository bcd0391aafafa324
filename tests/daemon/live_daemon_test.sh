#!/usr/bin/env bash
# Runs a client against a live chromod (the built-in virtual lab) in a fresh
# folder, and checks what it printed and what the session folder holds.
#   live_daemon_test.sh CHROMOD CHROMO PYTHON_STUBS_DIR SOURCE_DIR python|cli
set -euo pipefail
chromod=$1 chromo=$2 stubs=$3 source=$4 mode=$5
work=$(mktemp -d /tmp/chromo-live-XXXXXX)
echo "{\"maps_dir\": \"$work/maps\"}" >"$work/chromod.json"
"$chromod" --config "$work/chromod.json" --socket "$work/s.sock" --sessions-dir "$work/sessions" >"$work/chromod.log" 2>&1 &
daemon_pid=$!
cleanup() { kill -9 "$daemon_pid" 2>/dev/null || true; wait "$daemon_pid" 2>/dev/null || true; rm -rf "$work"; }
trap cleanup EXIT
# The virtual lab starts first (scene, camera simulator, Aravis discovery).
for _ in $(seq 300); do [[ -S "$work/s.sock" ]] && break; sleep 0.1; done

# Every client call is bounded: a hung daemon fails the test instead of hanging ctest.
t() { timeout -s KILL 60 "$@"; }
fail() { echo "FAIL: $*"; cat "$work/out"; exit 1; }
case "$mode" in
  python)
    CHROMO_PY_STUBS="$stubs" t /usr/bin/python3 "$source/clients/python/run_session_example.py" "unix:$work/s.sock" \
      --subject "ctest" >"$work/out" 2>&1 || fail "example exited $?"
    grep -q "succeeded" "$work/out" || fail "no success reported"
    # The standard plan at the configuration's defaults: 4 frames of the dark and of each
    # of the 3 whites (capture.reference_frames), 1 of each of the 3 subjects.
    grep -q "frames stored: 19" "$work/out" || fail "not 19 frames"
    grep -Eq "^timeline: capture [0-9.]+ s \(subject [0-9.]+ s\), maps [0-9.]+ s after the last frame, total [0-9.]+ s$" "$work/out" ||
      fail "no timeline from the Python client"
    # Subject exposure through the Python client (docs/daemon.md "Subject exposure"): each subject
    # g times its white's exposure, W57 at W57+blue's g; a fill outside (0, 1) refused naming the field.
    CHROMO_PY_STUBS="$stubs" t /usr/bin/python3 -c "
import sys
sys.path.insert(0, '$source/clients/python')
import grpc
from chromosphere_client import Client, state_name
client = Client('unix:$work/s.sock')
final = client.wait(client.start_standard_session(subject='fill', subject_fill=0.85).id)
print('state', state_name(final.state))
exposure = {frame.step: frame.exposure_us for frame in client.session(final.id, include_frames=True).frames}
g = {name: exposure['subject_' + name] / exposure['white_' + name] for name in ('d65', 'w57', 'w57+blue')}
print('longer', all(1.0 < value <= 8.0 for value in g.values()), abs(g['w57'] - g['w57+blue']) < 1e-9)
try:
    client.start_standard_session(subject='bad', subject_fill=1.5)
except grpc.RpcError as error:
    print('refused', error.code().name, error.details().split(':')[0])
" >"$work/out" 2>&1 || fail "subject_fill session exited $?"
    grep -q "^state succeeded$" "$work/out" || fail "the subject-metered session did not succeed"
    grep -q "^longer True True$" "$work/out" || fail "the subjects were not metered longer than their whites"
    grep -q "^refused INVALID_ARGUMENT subject_fill$" "$work/out" || fail "subject_fill 1.5 was not refused naming the field"
    # The Maps service through the Python client (docs/maps.md).
    t "$chromo" make-maps-test-data --out "$work/scene" --width 32 --height 24 >"$work/out" 2>&1 || fail "test data"
    t "$chromo" estimate "$work/scene/MEASUREMENT.json" --out "$work/maps/est" --cache-dir "$work/cache" >"$work/out" 2>&1 ||
      fail "estimate"
    CHROMO_PY_STUBS="$stubs" t /usr/bin/python3 -c "
import sys
sys.path.insert(0, '$source/clients/python')
from chromosphere_client import Client
client = Client('unix:$work/s.sock')
response = client.relight('est/maps.exr', 'W40')
print('relit', response.relit_pixels)
print('out_dir', response.out_dir)
" >"$work/out" 2>&1 || fail "relight exited $?"
    grep -Eq "^relit [1-7][0-9]{2}$" "$work/out" || fail "relight did not relight most of the 32x24 pixels"
    out_dir=$(sed -n 's/^out_dir //p' "$work/out")
    [[ "$out_dir" == products/relight-* && -f "$work/maps/$out_dir/relit.png" ]] || fail "no relit.png in products/"
    # The plan advisor through the Python client (docs/plan-advisor.md): advice, and a bad plan refused naming the field.
    CHROMO_PY_STUBS="$stubs" t /usr/bin/python3 -c "
import sys
sys.path.insert(0, '$source/clients/python')
import grpc
from chromosphere_client import Client
from chromosphere.v1 import planning_pb2
client = Client('unix:$work/s.sock')
response = client.compare_plans(['standard', 'multispectral@4'], skins=8, monte_carlo_draws=1)
for advice in response.plans:
    print('plan', advice.plan, len(advice.channels), round(advice.predicted_delta_e94_mean, 3), advice.fits)
bad = planning_pb2.PlanDescription(name='bad', captures=[planning_pb2.PlannedCapture(name='a', white_fill=0.5)])
try:
    client.compare_plans([bad])
except grpc.RpcError as error:
    print('refused', error.code().name, error.details())
" >"$work/out" 2>&1 || fail "compare_plans exited $?"
    grep -Eq "^plan standard 4 [0-9.]+ 8$" "$work/out" || fail "no advice for the standard plan"
    grep -Eq "^plan multispectral@4 18 [0-9.]+ 8$" "$work/out" || fail "no advice for multispectral@4"
    grep -q "^refused INVALID_ARGUMENT plans\[0\].description.captures\[0\].drive: at least one LED type must be on$" "$work/out" ||
      fail "a bad plan was not refused naming the field"
    # The cameras through the Python client (docs/web.md): list, settings, the preview stream, LEDs.
    CHROMO_PY_STUBS="$stubs" t /usr/bin/python3 -c "
import sys
sys.path.insert(0, '$source/clients/python')
import grpc
from chromosphere_client import Client
client = Client('unix:$work/s.sock')
for camera in client.list_cameras():
    print('camera', camera.name, camera.sensor_width, camera.sensor_height, camera.pixel_format)
print('exposure', client.set_camera_settings('cam0', exposure_us=5000).exposure_us)
print('leds', round(client.set_leds(output_enabled=True, w57=0.5).applied.drive.w57, 3))
frames = list(client.preview('cam0', rate_hz=10, width=160, count=3, timeout=30))
print('preview', len(frames), frames[-1].width, frames[-1].height, len(frames[-1].histogram), frames[-1].exposure_us,
      frames[0].sequence < frames[-1].sequence, len(frames[-1].jpeg) > 100)
try:
    client.set_camera_settings('nosuchcamera', exposure_us=1000)
except grpc.RpcError as error:
    print('refused', error.code().name)
" >"$work/out" 2>&1 || fail "cameras exited $?"
    grep -Eq "^camera cam0 640 480 BayerRG12$" "$work/out" || fail "no camera listed"
    grep -q "^exposure 5000.0$" "$work/out" || fail "exposure not set"
    grep -q "^leds 0.5$" "$work/out" || fail "LEDs not set"
    grep -Eq "^preview 3 160 120 64 5000.0 True True$" "$work/out" || fail "no preview frames"
    grep -Eq "^refused (NOT_FOUND|INVALID_ARGUMENT)$" "$work/out" || fail "an unknown camera was not refused"
    ;;
  cli)
    export CHROMO_DAEMON="unix:$work/s.sock"
    t "$chromo" status >"$work/out" 2>&1 || fail "status exited $?"
    grep -q "cam0.*OK" "$work/out" || fail "camera not OK"
    # chromo doctor (docs/doctor.md): the virtual lab's devices pass; no LED library yet.
    t "$chromo" doctor >"$work/out" 2>&1 || fail "doctor exited $?"
    grep -Eq "^ok +device.cam0 +camera CHROMO-VLAB-CAM" "$work/out" || fail "doctor: cam0"
    grep -Eq "^WARNING +calibration +no LED library" "$work/out" || fail "doctor: no calibration warning"
    grep -q "fix: run a calibration (chromo calibrate)" "$work/out" || fail "doctor: no fix for the calibration"
    set +e
    t "$chromo" doctor --strict >"$work/out" 2>&1; [[ $? == 3 ]] || fail "doctor --strict with a warning not exit 3"
    set -e
    # 2 frames of each subject step, 3 of the dark and of each white: 3·2 + 4·3 = 18.
    t "$chromo" session run --exposure-us 1000 --frames 2 --reference-frames 3 --subject cli >"$work/out" 2>&1 ||
      fail "session run exited $?"
    grep -q "frames: 18 stored" "$work/out" || fail "counters"
    id=$(sed -n 's/^session \([^ ]*\) started$/\1/p' "$work/out")
    t "$chromo" session show "$id" --frames >"$work/out" 2>&1 || fail "show exited $?"
    [[ $(grep -c "completed$" "$work/out") == 7 ]] || fail "not 7 completed steps"
    [[ $(grep -c "^  frame" "$work/out") == 18 ]] || fail "not 18 frames listed"
    # Where the time went, from the journal: every phase of a finished session is known.
    grep -Eq "^timeline capture [0-9.]+ s \(subject [0-9.]+ s\), then derived data [0-9.]+ s and maps [0-9.]+ s after the last frame; total [0-9.]+ s$" "$work/out" ||
      fail "no timeline: $(grep timeline "$work/out")"
    # Before a calibration the daemon has no LED library: the solver says so.
    set +e
    t "$chromo" solve d65 >"$work/out" 2>&1; [[ $? != 0 ]] || fail "solve without a library succeeded"
    grep -qi "no LED library" "$work/out" || fail "solve: no reason given"
    set -e
    t "$chromo" calibrate --levels 0.5 1 --warmup-ms 100 >"$work/out" 2>&1 || fail "calibrate exited $?"
    grep -q "^calibration .* succeeded" "$work/out" || fail "calibration did not succeed"
    grep -q "led-library.json" <(ls "$work/sessions/calibrations/"*/) || fail "no library file"
    t "$chromo" solve d65 >"$work/out" 2>&1 || fail "solve exited $?"
    grep -q "^d65: W57 " "$work/out" || fail "no weights"
    grep -q "camera_de00_mean" "$work/out" || fail "no figures"
    grep -q "library: .*calibrations/.*/led-library.json" "$work/out" || fail "not the measured library"
    t "$chromo" doctor >"$work/out" 2>&1 || fail "doctor exited $?"
    grep -Eq "^ok +calibration +LED library .*led-library.json is 0.0 days old" "$work/out" || fail "doctor: calibration"
    set +e
    t "$chromo" calibrate --levels 0.5 0.4 >"$work/out" 2>&1; [[ $? == 2 ]] || fail "bad ladder not exit 2"
    grep -q "drive_levels\[1\]" "$work/out" || fail "ladder field not named"
    t "$chromo" session show no-such-session >"$work/out" 2>&1; [[ $? == 2 ]] || fail "unknown id not exit 2"
    t "$chromo" led set --blue 7 >"$work/out" 2>&1; [[ $? == 2 ]] || fail "out-of-range level not exit 2"
    grep -q "state.drive.blue" "$work/out" || fail "field not named"
    ;;
esac
echo "ok ($mode)"
