#!/usr/bin/env bash
# Tools no one here wrote, pointed at chromo-sim's simulators on loopback:
#   arv-tool-0.8         reads and writes the camera's features through its GenICam description
#   arv-test-0.8         Aravis' own conformance checks (with its GenApi 1.1 schema validation)
#   arv-camera-test-0.8  streams (small sensor, no packet socket, lost packets resent): every frame completes
#   mbpoll               Modbus TCP master: the LED controller's documented registers (docs/protocols/led-modbus.md)
# Skipped (exit 77) when a tool is missing (scripts/setup.sh installs them).
#   third_party_tools_test.sh CHROMO_SIM
set -euo pipefail
sim=$1
for tool in arv-tool-0.8 arv-test-0.8 arv-camera-test-0.8 mbpoll; do
  command -v "$tool" >/dev/null || { echo "SKIP: $tool not installed (scripts/setup.sh)"; exit 77; }
done
work=$(mktemp -d /tmp/chromo-tools-XXXXXX)
serial="TOOLS-$$"
sim_pid=""
cleanup() {
  [[ -n $sim_pid ]] && { kill "$sim_pid" 2>/dev/null || true; wait "$sim_pid" 2>/dev/null || true; }
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*"; [[ -f $work/out ]] && cat "$work/out"; exit 1; }
t() { timeout -s KILL 60 "$@"; }

# start_sim LOSS: a chromo-sim whose stream drops LOSS of its packets on first
# transmission; sets sim_pid, address and port.
start_sim() {
  "$sim" --sensor-width 64 --sensor-height 48 --scene-size 32 --camera-serial "$serial" --packet-loss "$1" \
    >"$work/sim.log" 2>&1 &
  sim_pid=$!
  for _ in $(seq 200); do grep -q "chromo-sim: running" "$work/sim.log" && break; sleep 0.1; done
  address=$(sed -n 's/^camera cam0: GigE Vision on \(127\.[0-9.]*\):3956.*/\1/p' "$work/sim.log")
  port=$(sed -n 's/^led controller: Modbus TCP on 127\.0\.0\.1:\([0-9]*\) .*/\1/p' "$work/sim.log")
  [[ -n $address && -n $port ]] || { cat "$work/sim.log"; fail "chromo-sim did not start"; }
}
stop_sim() { kill "$sim_pid"; wait "$sim_pid" 2>/dev/null || true; sim_pid=""; }
# A clean link for arv-tool, arv-test and mbpoll (arv-test's acquisitions do
# not wait for resends); 10% loss for arv-camera-test below.
start_sim 0
echo "camera $address, Modbus TCP port $port"

# arv-tool-0.8: features read, written and read back through the GenICam description.
t arv-tool-0.8 -a "$address" control DeviceSerialNumber SensorWidth SensorHeight PixelFormat >"$work/out" 2>&1 || fail "arv-tool read"
grep -qx "DeviceSerialNumber = $serial" "$work/out" || fail "serial"
grep -q "^SensorWidth = 64" "$work/out" && grep -q "^SensorHeight = 48" "$work/out" || fail "sensor size"
t arv-tool-0.8 -a "$address" control Width=32 Gain=3.5 PixelFormat=BayerRG12 ExposureTime=2500 >/dev/null 2>&1 || fail "arv-tool write"
t arv-tool-0.8 -a "$address" control Width Gain PixelFormat ExposureTime PayloadSize >"$work/out" 2>&1 || fail "arv-tool read back"
grep -q "^Width = 32 " "$work/out" || fail "Width not written"
grep -q "^Gain = 3.5 dB" "$work/out" || fail "Gain not written"
grep -qx "PixelFormat = BayerRG12" "$work/out" || fail "PixelFormat not written"
grep -q "^ExposureTime = 2500 " "$work/out" || fail "ExposureTime not written"
grep -q "^PayloadSize = 3072" "$work/out" || fail "PayloadSize is not 32 x 48 x 2"
t arv-tool-0.8 -a "$address" control Width=32 PixelFormat=Mono8 >/dev/null 2>&1 || fail "arv-tool restore"
# The simulator answers broadcast discovery from loopback peers (docs/protocols/gige-vision.md).
t arv-tool-0.8 >"$work/out" 2>&1 || true
grep -q -- "-$serial ($address)" "$work/out" || fail "arv-tool-0.8 does not discover the simulator"

# arv-test-0.8: every conformance check of Aravis on this device, with the
# device's own facts (sensor, its chunk). Its Genicam:Schema check is left out
# (IGNORED): arv-test 0.8.26 validates a "Schema=1.1" description against the
# GenApi 1.0 schema (it loads GenApiSchema_Version_1_0.xsd for both), so every
# 1.1 description fails there; the description is validated below against the
# GenApi 1.1 schema Aravis ships, with xmllint.
printf '[Chromosphere:CHROMO-SIM-CAM]\nSensorSize=64;48\nChunksSupport=true\nChunkList=TriggerCount\n' \
  >"$work/arv-test.cfg"
t arv-test-0.8 -n "*-$serial" -c "$work/arv-test.cfg" >"$work/out" 2>&1 || fail "arv-test-0.8 exited $?"
sed -i 's/\x1b\[[0-9;]*m//g' "$work/out"
[[ $(grep -c "^Testing 'Chromosphere:CHROMO-SIM-CAM'" "$work/out") == 1 ]] || fail "arv-test-0.8 did not test the simulator"
grep -q "^Genicam:Schema  *IGNORED" "$work/out" || fail "Genicam:Schema not ignored"
if grep -v "^Genicam:Schema" "$work/out" | grep -Eq "FAILURE|IGNORED"; then fail "arv-test-0.8 conformance"; fi
echo "arv-test-0.8: $(grep -c SUCCESS "$work/out") checks SUCCESS"
# The GenICam description against GenApi 1.1 (the XSD inside arv-test-0.8).
if command -v xmllint >/dev/null; then
  t arv-tool-0.8 -a "$address" genicam >"$work/genicam.raw" 2>&1 || fail "arv-tool genicam"
  /usr/bin/python3 - "$work" "$(command -v arv-test-0.8)" <<'PY' || fail "no GenApi 1.1 schema in arv-test-0.8"
import sys
work, tool = sys.argv[1], sys.argv[2]
raw = open(work + "/genicam.raw", "rb").read()
end = raw.index(b"</RegisterDescription>") + len(b"</RegisterDescription>")
open(work + "/genicam.xml", "wb").write(raw[:end] + b"\n")
binary = open(tool, "rb").read()
namespace = binary.index(b'targetNamespace="http://www.genicam.org/GenApi/Version_1_1"')
start = binary.rindex(b"<xs:schema", 0, namespace)
open(work + "/GenApiSchema_Version_1_1.xsd", "wb").write(binary[start:binary.index(b"</xs:schema>", namespace) + 12])
PY
  xmllint --noout --schema "$work/GenApiSchema_Version_1_1.xsd" "$work/genicam.xml" >"$work/out" 2>&1 ||
    fail "the GenICam description does not validate against GenApi 1.1"
  echo "GenICam description: valid GenApi 1.1"
fi

# mbpoll: identity (input registers), a state applied through the staging block, the output coil.
mb() { t mbpoll -m tcp -a 1 -p "$port" -1 -0 "$@" 127.0.0.1; }
# mbw OPTIONS -- VALUES: mbpoll takes the values to write after the host.
mbw() {
  local options=()
  while [[ $1 != -- ]]; do options+=("$1"); shift; done
  shift
  t mbpoll -m tcp -a 1 -p "$port" -1 -0 "${options[@]}" 127.0.0.1 "$@"
}
mb -t 3 -r 0 -c 10 >"$work/out" 2>&1 || fail "mbpoll identity"
grep -q "^\[0\]:[[:space:]]*1$" "$work/out" || fail "protocol version is not 1"
grep -q "^\[3\]:[[:space:]]*64$" "$work/out" || fail "sequence capacity is not 64"
mb -t 3:hex -r 16 -c 8 >"$work/out" 2>&1 || fail "mbpoll serial"
[[ $(sed -n 's/^\[[0-9]*\]:[[:space:]]*0x\([0-9A-F]*\)$/\1/p' "$work/out" | tr -d '\n' | xxd -r -p | tr -d '\0') == SIM-LED-0001 ]] ||
  fail "serial number registers"
mb -t 4 -r 10 -c 1 >"$work/out" 2>&1 || fail "mbpoll sequence number"
sequence=$(( ($(sed -n 's/^\[10\]:[[:space:]]*\([0-9]*\).*/\1/p' "$work/out") + 1) % 65536 ))
[[ $sequence == 0 ]] && sequence=1
# One FC 16 write: W57..B, zone all, PWM keep, APPLY_STATE, the new sequence number.
mbw -t 4 -r 0 -- 1000 2000 3000 4000 5000 6000 65535 0 0 1 "$sequence" >"$work/out" 2>&1 || fail "mbpoll write"
mb -t 3 -r 32 -c 13 >"$work/out" 2>&1 || fail "mbpoll applied state"
for pair in 32:1000 33:2000 34:3000 35:4000 36:5000 37:6000 41:$sequence 44:0; do
  grep -q "^\[${pair%%:*}\]:[[:space:]]*${pair#*:}\b" "$work/out" || fail "input register ${pair%%:*} is not ${pair#*:}"
done
mbw -t 0 -r 0 -- 1 >/dev/null 2>&1 || fail "mbpoll coil write"
mb -t 0 -r 0 -c 1 >"$work/out" 2>&1 || fail "mbpoll coil read"
grep -q "^\[0\]:[[:space:]]*1$" "$work/out" || fail "output enable coil"
# An unknown command is refused with result code 1 and changes nothing.
mbw -t 4 -r 0 -- 7 7 7 7 7 7 65535 0 0 99 $(( sequence % 65535 + 1 )) >/dev/null 2>&1 || fail "mbpoll write"
mb -t 3 -r 32 -c 13 >"$work/out" 2>&1 || fail "mbpoll result"
grep -q "^\[44\]:[[:space:]]*1$" "$work/out" || fail "unknown command not result 1"
grep -q "^\[32\]:[[:space:]]*1000$" "$work/out" || fail "a refused command changed the state"
echo "mbpoll: identity, state, coil and a refused command as documented"
# arv-camera-test-0.8: 3 s of streaming at 10 Hz from a camera that drops 10% of its
# packets on first transmission: they are resent and every frame completes.
# Resends allowed for every packet of a frame (--packet-request-ratio 2: Aravis'
# default gives up on a frame of 5 packets after the first request).
stop_sim
start_sim 0.1
t arv-camera-test-0.8 -n "$address" --no-packet-socket --packet-request-ratio=2.0 -f 10 --duration=3 >"$work/out" 2>&1 || fail "arv-camera-test-0.8 exited $?"
value() { sed -n "s/^$1 *= \([0-9]*\)$/\1/p" "$work/out"; }
completed=$(value n_completed_buffers) resent=$(value n_resent_packets)
[[ ${completed:-0} -ge 20 ]] || fail "only ${completed:-0} frames completed"
for counter in n_failures n_timeouts n_missing_frames n_underruns n_missing_packets; do
  [[ $(value $counter) == 0 ]] || fail "$counter = $(value $counter)"
done
[[ ${resent:-0} -gt 0 ]] || fail "no packet was resent at 10% loss"
echo "arv-camera-test-0.8: $completed frames complete, $resent packets resent"

echo PASS
