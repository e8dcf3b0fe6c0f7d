#!/usr/bin/env bash
# The install on its own (README: Install): `cmake --install` into a scratch prefix (DESTDIR: a
# prefix moved from where it was configured); the installed scripts find the installed programs
# and configs (demo and replay run from the prefix, in a private network namespace); configs
# find the files they name from their own folder; a user's CMake project (find_package) and a
# pkg-config build link the libraries and print known answers; `cpack -G DEB` makes a package
# whose Depends resolve on this Debian, and its demo runs from a scratch root.
#   test_install.sh SOURCE_DIR BUILD_DIR
set -uo pipefail
src=$1 build=$2
if ! unshare -n true 2>/dev/null; then
  echo "SKIPPED: needs 'unshare -n' (root) for the demo's private network" >&2
  if [ -n "${CI:-}" ] && [ "${PTZ_ALLOW_SKIP:-0}" != 1 ]; then exit 1; fi
  exit 77
fi
tmp=$(mktemp -d /tmp/ptz_install.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail=0
bad() {
  echo "FAILED: $*"
  fail=1
}
# field NAME FILE: a number of a run's summary.json.
field() { sed -n "s/^ *\"$1\": \\([0-9.]*\\),\\{0,1\\}$/\\1/p" "$2"; }
# demo_ran WHAT PREFIX: PREFIX/bin/ptzstereo-demo for 4 s from a folder of its own: frames
# published and answered by poses, no path of the source tree or build dir in what it wrote.
# Sets summary (its summary.json).
summary=""
demo_ran() {
  local what=$1 prefix=$2 run=$tmp/run-$1
  mkdir -p "$run"
  if ! (cd "$run" && env -u PTZ_BUILD "$prefix/bin/ptzstereo-demo" --private-net --duration 4 \
    >"$run/demo.out" 2>&1); then
    bad "$what: ptzstereo-demo failed: $(tail -n 20 "$run/demo.out")"
    return 1
  fi
  summary=$(ls "$run"/out/demo-*/summary.json 2>/dev/null | head -1)
  [ -n "$summary" ] || { bad "$what: no out/demo-*/summary.json in the run's folder"; return 1; }
  local published processed
  published=$(field frames_published "$summary")
  processed=$(field frames_processed "$summary")
  echo "$what: demo published ${published:-?} frames, ${processed:-?} answered by poses"
  awk -v p="$published" -v q="$processed" 'BEGIN { exit !(p >= 60 && q >= 0.9 * p) }' ||
    bad "$what: frames_published $published, frames_processed $processed (want >= 60, >= 90 %)"
  grep -rlF -e "$src/" -e "$build/" "$run"/out --include='*.log' --include='*.json' --include='*.out' \
    "$run/demo.out" && bad "$what: the run names the source tree or build dir"
  return 0
}

# 1. cmake --install, then the tree moved (DESTDIR): nothing may depend on the configured prefix.
DESTDIR=$tmp/stage cmake --install "$build" --prefix /opt/ptzstereo >"$tmp/install.log" 2>&1 ||
  bad "cmake --install: $(tail "$tmp/install.log")"
p=$tmp/stage/opt/ptzstereo
for f in bin/ptz-sim bin/ptz-driver bin/ptzstereo-demo bin/ptzstereo-replay bin/ptzstereo-lcm-spy \
  share/ptzstereo/scripts/demo share/ptzstereo/scripts/common.sh \
  share/ptzstereo/scripts/supervise share/ptzstereo/config/driver_visca_ip.yaml \
  share/ptzstereo/config/visca/sony_srg300.yaml share/java/ptzstereo_lcmtypes.jar \
  lib/cmake/ptzstereo/ptzstereoConfig.cmake lib/cmake/ptzstereo/ptzstereoConfigVersion.cmake \
  lib/pkgconfig/ptzstereo.pc include/ptzstereo/common/rig.hpp include/ptzstereo/ptz_setpoint_t.hpp \
  lib/libptz_core.a lib/libptz_transport.a; do
  [ -e "$p/$f" ] || bad "not installed: $f"
done
for f in test format fuzz bench install-deps; do
  [ -e "$p/share/ptzstereo/scripts/$f" ] && bad "developer script installed: $f"
done
grep -rlF -e "$src" -e "$build" "$p/lib/cmake" "$p/lib/pkgconfig" "$p/share/ptzstereo/scripts" &&
  bad "the installed package files name the source tree or build dir"
# The scripts' one resolution: programs and the types jar of the install.
got=$(bash -c 'source "$1/share/ptzstereo/scripts/common.sh"; ptz_bin ptz-sim; echo "$PTZ_TYPES_JAR"' \
  _ "$p" 2>&1)
[ "$got" = "$p/bin/ptz-sim"$'\n'"$p/share/java/ptzstereo_lcmtypes.jar" ] ||
  bad "installed common.sh resolves: $got"

# 2. Configs find the files they name from their own folder, from any directory.
cd / || exit 1
out=$("$p/bin/ptz-driver" --config "$p/share/ptzstereo/config/driver_visca_serial.yaml" \
  --left-serial-device "$tmp/no-such-tty" --lcm-url memq:// 2>&1)
rc=$?
# The model file loaded; the next thing, the serial port, is what fails.
{ [ $rc -eq 2 ] && grep -q "left_serial_device" <<<"$out" && ! grep -q visca_model <<<"$out"; } ||
  bad "installed driver_visca_serial.yaml from /: exit $rc: $out"
mkdir -p "$tmp/cfg"
cp "$p/share/ptzstereo/config/driver_pelco_d.yaml" "$tmp/cfg/driver.yaml"
out=$("$p/bin/ptz-driver" --config "$tmp/cfg/driver.yaml" --lcm-url memq:// 2>&1)
rc=$?
want="config file '$tmp/cfg/driver.yaml': parameter 'pelco_model' = 'pelco_d/generic.yaml': '$tmp/cfg/pelco_d/generic.yaml' does not exist"
{ [ $rc -eq 2 ] && grep -qF "$want" <<<"$out"; } || bad "a missing model file: exit $rc: $out"
cd "$tmp" || exit 1

# 3. The installed scripts: the demo, then its log replayed through a fresh ptz-detect (every
# frame answered).
if demo_ran install "$p"; then
  log=$(dirname "$summary")/run.lcmlog
  out=$("$p/bin/ptzstereo-replay" "$log" --private-net 2>&1)
  rc=$?
  { [ $rc -eq 0 ] && grep -q " 0 frames unanswered" <<<"$out"; } ||
    bad "ptzstereo-replay on the demo's log: exit $rc: $(tail -n 5 <<<"$out")"
fi

# 4. A user's project against the install only: CMake (find_package) and pkg-config.
expected=$'baseline_m 0.300\npixel 370.936 240.502\nsetpoint_bytes 80\nreceived_pan_rad 0.25\njpeg 64x48'
cp -r "$src/test/deploy/external_project" "$tmp/user"
if cmake -S "$tmp/user" -B "$tmp/user-build" -DCMAKE_PREFIX_PATH="$p" >"$tmp/user.log" 2>&1 &&
  cmake --build "$tmp/user-build" >>"$tmp/user.log" 2>&1; then
  got=$("$tmp/user-build/ptzstereo_user" 2>&1)
  [ "$got" = "$expected" ] || bad "find_package project printed: $got"
else
  bad "the find_package project did not build: $(tail -n 30 "$tmp/user.log")"
fi
# shellcheck disable=SC2086 # flags: words
if flags=$(PKG_CONFIG_PATH=$p/lib/pkgconfig pkg-config --cflags --libs ptzstereo 2>&1) &&
  g++ -std=c++17 -o "$tmp/user-pc" "$tmp/user/main.cpp" $flags 2>"$tmp/user-pc.log"; then
  got=$("$tmp/user-pc" 2>&1)
  [ "$got" = "$expected" ] || bad "pkg-config build printed: $got"
else
  bad "the pkg-config build failed: $flags $(tail -n 30 "$tmp/user-pc.log")"
fi
echo "user project (find_package, pkg-config): known answers checked"

# 5. The Debian package.
if ! (cd "$tmp" && cpack -G DEB -B "$tmp/pkg" --config "$build/CPackConfig.cmake" \
  >"$tmp/cpack.log" 2>&1); then
  bad "cpack -G DEB: $(tail -n 30 "$tmp/cpack.log")"
else
  deb=$(ls "$tmp"/pkg/ptzstereo_*.deb)
  prefix=$(sed -n 's/^CMAKE_INSTALL_PREFIX:PATH=//p' "$build/CMakeCache.txt")
  info=$(dpkg-deb -I "$deb")
  depends=$(sed -n 's/^ Depends: //p' <<<"$info")
  for d in liblcm1 libopencv-core406 liblcm-bin iproute2; do
    grep -q "\\b$d\\b" <<<"$depends" || bad "Depends lacks $d: $depends"
  done
  dpkg-deb -f "$deb" Package Version | grep -q "^Version: $(sed -n 's/^CMAKE_PROJECT_VERSION:STATIC=//p' "$build/CMakeCache.txt")" ||
    bad "package version: $(dpkg-deb -f "$deb" Version)"
  grep -q "/etc/ptzstereo/driver.yaml" <(dpkg-deb --ctrl-tarfile "$deb" | tar -xO ./conffiles) ||
    bad "/etc/ptzstereo/driver.yaml is not a conffile"
  contents=$(dpkg-deb -c "$deb")
  for f in bin/ptz-sim bin/ptzstereo-demo share/ptzstereo/scripts/demo \
    share/ptzstereo/config/sim_default.yaml lib/cmake/ptzstereo/ptzstereoConfig.cmake \
    lib/pkgconfig/ptzstereo.pc; do
    grep -q " \\.$prefix/$f\$" <<<"$contents" || bad "the package lacks $prefix/$f"
  done
  # Every dependency is known to apt here (nothing to fetch when all are installed).
  apt-get install --simulate --no-install-recommends "$deb" >"$tmp/apt.log" 2>&1 ||
    bad "apt-get install --simulate: $(tail -n 20 "$tmp/apt.log")"
  dpkg-deb -x "$deb" "$tmp/root"
  demo_ran deb "$tmp/root$prefix"
  # Its libraries, unstripped: the user's program against the package's pkg-config file.
  pc_dir=$(dirname "$(find "$tmp/root" -name ptzstereo.pc)")
  # shellcheck disable=SC2086 # flags: words
  if flags=$(PKG_CONFIG_PATH=$pc_dir pkg-config --cflags --libs ptzstereo 2>&1) &&
    g++ -std=c++17 -o "$tmp/user-deb" "$tmp/user/main.cpp" $flags 2>"$tmp/user-deb.log"; then
    got=$("$tmp/user-deb" 2>&1)
    [ "$got" = "$expected" ] || bad "the package's libraries: the user's program printed: $got"
  else
    bad "the user's program against the package: $flags $(tail -n 30 "$tmp/user-deb.log")"
  fi
  echo "package $(basename "$deb"): Depends: $depends"
fi

[ $fail -eq 0 ] && echo "PASSED: install, scripts from the prefix, configs, user project, package"
exit $fail
