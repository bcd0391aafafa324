#!/usr/bin/env bash
# A gRPC client that knows nothing of the project (clients/grpc_reflection/)
# against a live chromod on the virtual lab: it lists the services through
# server reflection, describes one, and calls unary methods with JSON; bad
# calls are refused with their reason.
#   grpc_reflection_test.sh CHROMOD SOURCE_DIR
set -euo pipefail
chromod=$1 source=$2
work=$(mktemp -d /tmp/chromo-reflection-XXXXXX)
"$chromod" --socket "$work/s.sock" --sessions-dir "$work/sessions" >"$work/chromod.log" 2>&1 &
daemon_pid=$!
cleanup() { kill "$daemon_pid" 2>/dev/null || true; wait "$daemon_pid" 2>/dev/null || true; rm -rf "$work"; }
trap cleanup EXIT
for _ in $(seq 300); do [[ -S $work/s.sock ]] && break; sleep 0.1; done
fail() { echo "FAIL: $*"; cat "$work/out"; exit 1; }
client() { timeout -s KILL 60 /usr/bin/python3 "$source/clients/grpc_reflection/reflection_client.py" "unix:$work/s.sock" "$@"; }

client list >"$work/out" 2>&1 || fail "list"
for service in chromosphere.v1.DeviceService chromosphere.v1.SessionService chromosphere.v1.MapsService \
  grpc.health.v1.Health grpc.reflection.v1alpha.ServerReflection; do
  grep -qx "$service" "$work/out" || fail "$service not listed"
done
echo "services: $(wc -l <"$work/out")"
client describe chromosphere.v1.SessionService >"$work/out" 2>&1 || fail "describe"
grep -qx "GetSession(chromosphere.v1.GetSessionRequest) returns (chromosphere.v1.SessionDetail)" "$work/out" ||
  fail "GetSession not described"
client describe chromosphere.v1.EventService >"$work/out" 2>&1 || fail "describe streaming"
grep -q "returns (stream chromosphere.v1." "$work/out" || fail "a server stream not described as one"

client call chromosphere.v1.DeviceService/ListDevices >"$work/out" 2>&1 || fail "ListDevices"
/usr/bin/python3 -c "
import json, sys
devices = {d['name']: d for d in json.load(open('$work/out'))['devices']}
assert devices['cam0']['health'] == 'DEVICE_HEALTH_OK', devices['cam0']
assert devices['cam0']['info']['serial'] == 'CHROMO-VLAB-CAM', devices['cam0']
assert sorted(devices) == ['cam0', 'spec0', 'sphere'], sorted(devices)
" || fail "ListDevices answer"
client call chromosphere.v1.SessionService/GetStandardPlan '{}' >"$work/out" 2>&1 || fail "GetStandardPlan"
grep -q '"steps"' "$work/out" || fail "no steps in the standard plan"

# Refused: by the server (exit 1, its status), by the client's schema (exit 2).
set +e
client call chromosphere.v1.SessionService/GetSession '{"id": "no-such"}' >"$work/out" 2>&1; [[ $? == 1 ]] || fail "unknown id not exit 1"
grep -q "NOT_FOUND" "$work/out" || fail "no NOT_FOUND"
client call chromosphere.v1.SessionService/GetSession '{"idd": "x"}' >"$work/out" 2>&1; [[ $? == 2 ]] || fail "unknown field not exit 2"
grep -q 'no field named "idd"' "$work/out" || fail "the field is not named"
client call chromosphere.v1.DeviceService/NoSuch >"$work/out" 2>&1; [[ $? == 2 ]] || fail "unknown method not exit 2"
set -e
echo PASS
