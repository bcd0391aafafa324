#!/usr/bin/env bash
# The Python package as a researcher installs it: a fresh --system-site-packages
# virtual environment on Debian's python3, `pip install --no-build-isolation`
# of clients/python offline (stubs generated at build time from proto/), then
# against a live chromod on the virtual lab: the worked example
# (examples/maps_example.py, headless matplotlib, figures into WORK/figures)
# and python_client_test.py; the API reference page checked against the code.
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
timeout -s KILL 300 "$python" "$source/clients/python/examples/maps_example.py" "unix:$work/s.sock" \
  --out "$work/figures" >"$work/out" 2>&1 || fail "the example exited $?"
cat "$work/out"
grep -Eq "^maps: [0-9]+x[0-9]+, channels Cm, Ch, Bm, Che, residual, order, flags" "$work/out" || fail "no maps line"
grep -Eq "^Cm median in the region: first 0\.[0-9]+, second 0\.[0-9]+" "$work/out" || fail "no comparison"
grep -q "maps from maps.ome.tiff equal to the API's" "$work/out" || fail "open_session differs from the API"
for figure in maps.png relight_a.png compare.png; do
  [[ -s "$work/figures/$figure" ]] || fail "no $figure"
done
session=$(sed -n 's/^session \([^:]*\): succeeded.*/\1/p' "$work/out" | head -1)
[[ -n "$session" ]] || fail "no session id"
timeout -s KILL 300 "$python" "$source/tests/clients/python_client_test.py" "$work/s.sock" "$session" "$exr_dump" "$chromod" "$work"
"$python" "$source/clients/python/tools/api_reference.py" --check "$source/docs/python-api.md"
echo "python package: installed, example and client tests passed"
