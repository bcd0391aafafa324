#!/usr/bin/env bash
# The Python package as a researcher installs it: a fresh --system-site-packages
# virtual environment on Debian's python3, `pip install --no-build-isolation`
# of clients/python offline (stubs generated at build time from proto/), then
# against a live chromod on the virtual lab: python_client_test.py; the API
# reference page checked against the code.
#   python_package_test.sh CHROMOD EXR_DUMP SOURCE_DIR WORK
set -euo pipefail
chromod=$1 exr_dump=$2 source=$3 work=$4
rm -rf "$work"
mkdir -p "$work/src"
# A copy of the package beside proto/, as in the repository: pip builds in
# the tree it is given, and a test run never writes into the source tree.
cp -r "$source/clients" "$source/proto" "$work/src/"
rm -rf "$work/src/clients/python/build" "$work/src/clients/python/"*.egg-info
/usr/bin/python3 -m venv --system-site-packages "$work/venv"
(cd "$work/src" && "$work/venv/bin/pip" install --no-build-isolation --no-index --quiet ./clients/python)
python=$work/venv/bin/python

echo "{\"maps_dir\": \"$work/maps\"}" >"$work/chromod.json"
"$chromod" --config "$work/chromod.json" --socket "$work/s.sock" --sessions-dir "$work/sessions" \
  >"$work/chromod.log" 2>&1 &
daemon_pid=$!
cleanup() { kill -9 "$daemon_pid" 2>/dev/null || true; wait "$daemon_pid" 2>/dev/null || true; }
trap cleanup EXIT
for _ in $(seq 300); do [[ -S "$work/s.sock" ]] && break; sleep 0.1; done
fail() { echo "FAIL: $*"; cat "$work/out" 2>/dev/null || true; exit 1; }

# From a folder of its own: the package is the installed one, not a source tree.
cd "$work"
# A session of the virtual lab for the client's tests.
cat >"$work/run.py" <<'PY'
import sys
import chromosphere
with chromosphere.Client(sys.argv[1]) as client:
    run = client.run_session("python package test")
    print(f"session {run.id}: {run.state}, {run.frames_stored} frames")
PY
timeout -s KILL 300 "$python" "$work/run.py" "unix:$work/s.sock" >"$work/out" 2>&1 || fail "the session exited $?"
session=$(sed -n 's/^session \([^:]*\): succeeded.*/\1/p' "$work/out" | head -1)
[[ -n "$session" ]] || fail "no session id"
timeout -s KILL 300 "$python" "$source/tests/clients/python_client_test.py" "$work/s.sock" "$session" "$exr_dump" "$chromod" "$work"
"$python" "$source/clients/python/tools/api_reference.py" --check "$source/docs/python-api.md"
echo "python package: installed, client tests passed"
