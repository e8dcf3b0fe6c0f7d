#!/usr/bin/env bash
# The systemd units (deploy/systemd): each has what a supervised process needs, systemd-analyze
# verify accepts them all (against the build tree's binaries) and refuses a broken one, and
# `cmake --install --component systemd` puts them and the configs they read in place (an edited
# config kept), configs the programs accept.
#   test_units.sh CHECK_DIR INSTALL_DIR BUILD_DIR
set -uo pipefail
check=$1 installed=$2 build=$3
if ! command -v systemd-analyze >/dev/null; then
  echo "SKIPPED: systemd-analyze is not installed (package systemd): the units are not verified"
  exit 77
fi
fail=0
bad() {
  echo "FAILED: $*"
  fail=1
}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

programs=(ptz-sim ptz-camera ptz-driver ptz-detect ptz-control ptz-depth ptz-health)
for p in "${programs[@]}"; do
  unit=$check/$p.service
  [ -f "$unit" ] || { bad "$unit missing"; continue; }
  for line in Type=notify NotifyAccess=main WatchdogSec=5s Restart=always RestartSec=500ms \
    RestartPreventExitStatus=2 "SyslogIdentifier=$p" PartOf=ptzstereo.target \
    WantedBy=ptzstereo.target "EnvironmentFile=-/etc/ptzstereo/ptzstereo.env"; do
    grep -qxF "$line" "$unit" || bad "$p.service has no line '$line'"
  done
  exec_line=$(grep '^ExecStart=' "$unit")
  exe=${exec_line#ExecStart=}
  exe=${exe%% *}
  [ -x "$exe" ] || bad "$p.service: ExecStart $exe is not an executable"
  [ "$(basename "$exe")" = "$p" ] || bad "$p.service runs $exe"
  grep -q -- "--config /etc/ptzstereo/" <<<"$exec_line" || bad "$p.service: $exec_line"
done
grep -q -- "--watch" "$check/ptz-health.service" || bad "ptz-health.service is not --watch"

out=$(systemd-analyze verify "$check"/*.service "$check/ptzstereo.target" 2>&1)
rc=$?
[ $rc -eq 0 ] && [ -z "$out" ] || bad "systemd-analyze verify (exit $rc): $out"
echo "systemd-analyze verify: ${#programs[@]} services and ptzstereo.target accepted"
# ...and it would notice: a unit whose binary is missing, or with a value it cannot parse.
sed 's#^ExecStart=[^ ]*#ExecStart=/nonexistent/ptz-sim#' "$check/ptz-sim.service" >"$tmp/ptz-sim.service"
systemd-analyze verify "$tmp/ptz-sim.service" >/dev/null 2>&1 && bad "verify accepted a missing binary"
sed 's#^RestartSec=.*#RestartSec=soon#' "$check/ptz-sim.service" >"$tmp/ptz-sim.service"
[ -z "$(systemd-analyze verify "$tmp/ptz-sim.service" 2>&1)" ] && bad "verify said nothing of RestartSec=soon"

# The installed form: the same units with the install prefix's paths, and the configs.
DESTDIR=$tmp/root cmake --install "$build" --component systemd >"$tmp/install.log" 2>&1 ||
  bad "cmake --install --component systemd: $(cat "$tmp/install.log")"
unit_dir=$(find "$tmp/root" -type d -path '*/lib/systemd/system')
etc=$tmp/root/etc/ptzstereo
[ -n "$unit_dir" ] || bad "no lib/systemd/system in the install: $(find "$tmp/root")"
for p in "${programs[@]}"; do
  [ -f "$unit_dir/$p.service" ] || { bad "$p.service not installed"; continue; }
  diff <(grep -v '^ExecStart=\|^WorkingDirectory=' "$check/$p.service") \
    <(grep -v '^ExecStart=\|^WorkingDirectory=' "$unit_dir/$p.service") >/dev/null ||
    bad "installed $p.service differs from the verified one beyond its paths"
  grep -q "^ExecStart=/.*/bin/$p --config /etc/ptzstereo/" "$unit_dir/$p.service" ||
    bad "installed $p.service: $(grep '^ExecStart=' "$unit_dir/$p.service")"
done
[ -f "$unit_dir/ptzstereo.target" ] || bad "ptzstereo.target not installed"
for f in sim.yaml detect.yaml driver.yaml camera.yaml control.yaml depth.yaml health.yaml \
  ptzstereo.env; do
  [ -f "$etc/$f" ] || bad "/etc/ptzstereo/$f not installed"
done
echo "# edited" >>"$etc/control.yaml"
DESTDIR=$tmp/root cmake --install "$build" --component systemd >/dev/null 2>&1
grep -q '^# edited' "$etc/control.yaml" || bad "a new install overwrote an edited config"

# The configs written for the units are accepted by their programs (exit 2 would be a refusal).
"$build/tools/ptz-health" --config "$etc/health.yaml" --lcm-url memq:// --listen-s 0.1 >/dev/null
rc=$?
[ $rc -eq 1 ] || bad "ptz-health --config health.yaml: exit $rc (1 expected: nothing heard)"
for p in control/ptz-control perception/ptz-depth; do
  name=$(basename "$p")
  timeout 3 "$build/$p" --config "$etc/${name#ptz-}.yaml" --lcm-url memq:// >/dev/null 2>&1
  rc=$?
  [ $rc -eq 124 ] || bad "$name --config ${name#ptz-}.yaml exited $rc instead of running"
done

[ $fail -eq 0 ] && echo "PASSED: units, verify, install and configs"
exit $fail
