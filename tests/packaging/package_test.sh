#!/usr/bin/env bash
# Builds the Debian package from the build tree (cpack), checks what it holds
# and declares, resolves its dependencies without installing anything
# (apt-get satisfy --simulate), verifies the service unit, and runs the
# programs from an extracted tree: the extracted chromod runs the virtual lab,
# the extracted chromo talks to it. It never installs the package (that would
# change the host's users, udev and sysctl).
#   package_test.sh BUILD_DIR
set -euo pipefail
build=$1
work=$(mktemp -d /tmp/chromo-package-XXXXXX)
daemon_pid=""
cleanup() {
  [[ -n $daemon_pid ]] && { kill "$daemon_pid" 2>/dev/null || true; wait "$daemon_pid" 2>/dev/null || true; }
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*"; [[ -f $work/out ]] && cat "$work/out"; exit 1; }
t() { timeout -s KILL 120 "$@"; }

start=$(date +%s.%N)
t cpack -G DEB --config "$build/CPackConfig.cmake" -B "$work/cpack" >"$work/out" 2>&1 || fail "cpack"
deb=$(ls "$work"/cpack/chromosphere_*_amd64.deb) || fail "no .deb"
echo "package: $(basename "$deb"), $(du -k "$deb" | cut -f1) KiB, built in $(echo "$(date +%s.%N) - $start" | bc) s"

# Contents.
dpkg-deb -c "$deb" | awk '{print $6}' | sed 's|^\./|/|' >"$work/contents"
for path in /usr/bin/chromod /usr/bin/chromo /usr/bin/chromo-sim \
  /usr/share/chromosphere/web/index.html /usr/share/chromosphere/web/app.js \
  /etc/chromosphere/chromod.json /lib/systemd/system/chromod.service \
  /lib/udev/rules.d/60-chromosphere.rules /usr/lib/sysctl.d/60-chromosphere.conf \
  /usr/share/man/man1/chromo.1.gz /usr/share/man/man8/chromod.8.gz /usr/share/man/man1/chromo-sim.1.gz \
  /usr/share/bash-completion/completions/chromo /usr/share/bash-completion/completions/chromod \
  /usr/share/bash-completion/completions/chromo-sim \
  /usr/share/doc/chromosphere/README.md /usr/share/doc/chromosphere/first-light.md /usr/share/doc/chromosphere/doctor.md; do
  grep -qx "$path" "$work/contents" || fail "the package lacks $path"
done
# Nothing outside the places a package may write.
if grep -vE '^/(usr|etc|lib)(/|$)|^/$' "$work/contents"; then fail "files outside /usr, /etc, /lib"; fi

# Control: dependencies from the linked libraries, conffiles, maintainer scripts.
depends=$(dpkg-deb -f "$deb" Depends)
for library in libaravis-0.8-0 libgrpc++1.51 libmodbus5 libhidapi-hidraw0 libusb-1.0-0 adduser; do
  grep -q "$library" <<<"$depends" || fail "Depends lacks $library: $depends"
done
dpkg-deb -e "$deb" "$work/control"
grep -qx /etc/chromosphere/chromod.json "$work/control/conffiles" || fail "chromod.json is not a conffile"
for script in postinst prerm postrm; do
  [[ -x $work/control/$script ]] || fail "no executable $script"
  sh -n "$work/control/$script" || fail "$script: syntax"
done
grep -q 'purge' "$work/control/postrm" && grep -q 'rm -rf /var/lib/chromosphere' "$work/control/postrm" ||
  fail "postrm does not remove /var/lib/chromosphere on purge"
# apt resolves every dependency on this Debian without installing anything.
t apt-get satisfy --simulate "$depends" >"$work/out" 2>&1 || fail "apt-get satisfy --simulate: dependencies do not resolve"
echo "dependencies resolve: $depends"

# The extracted tree.
root=$work/root
dpkg-deb -x "$deb" "$root"
grep -q 'ATTRS{idVendor}==' "$root/lib/udev/rules.d/60-chromosphere.rules" && fail "default rules name a HID controller"
grep -q 'ATTR{idVendor}=="2457", ATTR{idProduct}=="101e", GROUP="chromosphere", MODE="0660"' \
  "$root/lib/udev/rules.d/60-chromosphere.rules" || fail "no spectrometer rule"
grep -qx 'net.core.rmem_max = 33554432' "$root/usr/lib/sysctl.d/60-chromosphere.conf" || fail "sysctl drop-in"
zcat "$root/usr/share/man/man8/chromod.8.gz" | grep -q -- '--write-host-files' || fail "chromod(8) lacks its options"
zcat "$root/usr/share/man/man1/chromo.1.gz" | grep -q 'doctor' || fail "chromo(1) lacks doctor"

# The HID controller's rule and the buffer come from the configuration.
cat >"$work/lab.json" <<JSON
{"sessions_dir": "$work/sessions", "runtime_dir": "$work/run",
 "devices": [{"name": "sphere", "kind": "led_controller", "backend": "hid", "address": "16C0:05DF"},
             {"name": "cam0", "kind": "camera", "backend": "aravis", "address": "SN1", "settings": {"socket_buffer_bytes": 67108864}}]}
JSON
"$root/usr/bin/chromod" --config "$work/lab.json" --write-host-files "$work/etc" >"$work/out" 2>&1 || fail "write-host-files"
grep -q 'ATTRS{idVendor}=="16c0", ATTRS{idProduct}=="05df", GROUP="chromosphere", MODE="0660"' \
  "$work/etc/udev/rules.d/60-chromosphere.rules" || fail "no HID rule from the configuration"
grep -qx 'net.core.rmem_max = 67108864' "$work/etc/sysctl.d/60-chromosphere.conf" || fail "rmem_max not from the configuration"

# The unit as systemd reads it: verify prints nothing (an unknown key or a
# missing binary is only a message, so any message fails). The binary path is
# the extracted one, since nothing is installed here.
if command -v systemd-analyze >/dev/null; then
  mkdir "$work/units"
  sed "s|ExecStart=/usr/bin/chromod|ExecStart=$root/usr/bin/chromod|" "$root/lib/systemd/system/chromod.service" \
    >"$work/units/chromod.service"
  systemd-analyze verify --man=no "$work/units/chromod.service" >"$work/out" 2>&1 || fail "systemd-analyze verify"
  [[ ! -s $work/out ]] || fail "systemd-analyze verify printed messages"
  echo "systemd-analyze verify: chromod.service clean"
fi

# The extracted chromod runs the virtual lab; the extracted chromo and bash completion talk to it.
cat >"$work/run.json" <<JSON
{"sessions_dir": "$work/sessions", "runtime_dir": "$work/run", "unix_socket": "$work/run/chromod.sock",
 "web_dir": "$root/usr/share/chromosphere/web", "estimation": {"cache_dir": "$work/cache"}, "log_format": "json"}
JSON
"$root/usr/bin/chromod" --config "$work/run.json" >"$work/chromod.log" 2>&1 &
daemon_pid=$!
for _ in $(seq 300); do [[ -S $work/run/chromod.sock ]] && break; sleep 0.1; done
[[ -S $work/run/chromod.sock ]] || { cat "$work/chromod.log"; fail "the extracted chromod did not listen"; }
export CHROMO_DAEMON="unix:$work/run/chromod.sock"
t "$root/usr/bin/chromo" status >"$work/out" 2>&1 || fail "chromo status"
grep -q "cam0.*OK" "$work/out" || fail "the extracted chromod's camera is not OK"
t "$root/usr/bin/chromo" doctor >"$work/out" 2>&1 || fail "chromo doctor exited $?"
grep -Eq "^ok +device.cam0 " "$work/out" || fail "doctor: cam0 not ok"
# Its log is JSON lines (log_format "json", docs/observability.md).
/usr/bin/python3 -c "
import json, sys
lines = [json.loads(line) for line in open('$work/chromod.log')]
assert lines and all(set(l) == {'time', 'level', 'program', 'message'} for l in lines), lines
assert any(l['message'].startswith('listening on unix:') and l['level'] == 'info' for l in lines), lines
" || { cat "$work/chromod.log"; fail "chromod's log is not JSON lines"; }
t "$root/usr/bin/chromo-sim" --help >"$work/out" 2>&1 || fail "chromo-sim --help"
completion=$(bash -c "source '$root/usr/share/bash-completion/completions/chromo'; COMP_WORDS=('$root/usr/bin/chromo' doc); COMP_CWORD=1; _chromosphere_complete; echo \"\${COMPREPLY[*]}\"")
[[ $completion == doctor ]] || fail "completion of 'chromo doc': '$completion'"
echo "PASS"
