#!/usr/bin/env bash
# The scripts' rough edges and scripts/record, on real processes in a private network:
# - every script's -h and --help print its usage and exit 0 and do nothing else: apt-get,
#   cmake, sudo, lcm-logger, ip, ... are stubs on PATH that note being run, and nothing may be
#   noted or written;
# - scripts/replay LOG --private-net replays the 2 s fixture (the arguments survive the re-exec);
# - scripts/record against a lockstep ptz-sim + ptz-detect + ptz-control + ptz-depth run: the
#   default channels (no POINT_CLOUD, no DISPARITY_IMAGE, the 1 Hz preview kept), every frame
#   the simulator published; at the same time a --all --split-mb 1 recording whose files are
#   each within the limit plus one message and together hold every event (their counts per
#   channel equal the processes' own); --private-net with a command; bad input refused;
# - scripts/demo warns when the simulator skips frames it cannot render in time;
# - scripts/demo --head onvif: ptz-sim's ONVIF cameras driven by ptz-driver close the loop
#   (ptz-driver's PTZ_STATE, the cameras' setpoints applied, no head errors); a bad --head refused;
# - scripts/demo --scene markers --private-net: the tagged cube followed with its orientation.
# - scripts/demo --scene people --private-net: the walking person followed.
#   test_scripts.sh SOURCE_DIR BUILD_DIR
set -uo pipefail
src=$1 build=$2
if ! unshare -n true 2>/dev/null; then
  echo "SKIPPED: needs 'unshare -n' (root) for private networks" >&2
  if [ -n "${CI:-}" ] && [ "${PTZ_ALLOW_SKIP:-0}" != 1 ]; then exit 1; fi
  exit 77
fi
# Everything below in a private network with multicast on lo.
if [ -z "${PTZ_IN_NETNS:-}" ]; then
  exec env PTZ_IN_NETNS=1 unshare -n bash -c \
    'ip link set lo up multicast on && ip route add 224.0.0.0/4 dev lo && exec "$0" "$@"' "$0" "$@"
fi
export PTZ_BUILD=$build
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail=0
bad() {
  echo "FAILED: $*"
  fail=1
}

echo "== --help of every script: usage, exit 0, no side effects"
stubs=$work/stubs calls=$work/calls
mkdir -p "$stubs"
: >"$calls"
for tool in apt-get apt dpkg dpkg-query cmake ctest make clang-format clang-14 sudo lcm-logger \
  lcm-logplayer ip unshare nsenter sysctl nft java npm node gnuplot; do
  printf '#!/bin/sh\necho "%s $*" >>"%s"\n' "$tool" "$calls" >"$stubs/$tool"
  chmod +x "$stubs/$tool"
done
scripts=()
for f in "$src"/scripts/*; do
  [ -x "$f" ] && [ -f "$f" ] && scripts+=("$f")
done
[ ${#scripts[@]} -ge 18 ] || bad "only ${#scripts[@]} scripts found in $src/scripts"
for f in "${scripts[@]}"; do
  for flag in -h --help; do
    name="scripts/$(basename "$f") $flag"
    cwd=$work/cwd
    rm -rf "$cwd" && mkdir -p "$cwd/out"
    out=$(cd "$cwd" && PATH="$stubs:$PATH" PTZ_OUT="$cwd/out" PTZ_BUILD="$cwd/build" \
      timeout 20 "$f" "$flag" 2>"$work/err")
    rc=$?
    [ $rc -eq 0 ] || bad "$name exits $rc: $(cat "$work/err")"
    grep -q '[Uu]sage' <<<"$out" || bad "$name prints no usage: $out"
    [ ! -s "$work/err" ] || bad "$name writes to stderr: $(cat "$work/err")"
    [ ! -s "$calls" ] || bad "$name ran: $(cat "$calls")"
    : >"$calls"
    [ -z "$(find "$cwd" -mindepth 1 -not -path "$cwd/out")$(ls -A "$cwd/out")" ] ||
      bad "$name wrote files: $(find "$cwd" -mindepth 1)"
  done
done

echo "== scripts/replay LOG --private-net"
cp "$src/test/fixtures/closed_loop_2s.lcmlog" "$work/fixture.lcmlog"
# A relative path and the flag after it: what the re-exec in the namespace must keep.
out=$(cd "$work" && timeout 120 "$src/scripts/replay" fixture.lcmlog --check --private-net 2>&1)
rc=$?
[ $rc -eq 0 ] || bad "replay --private-net exits $rc: $out"
grep -q "a log file is required" <<<"$out" && bad "replay lost its arguments: $out"
grep -q "replayed 61 frames: 61 poses identical" <<<"$out" || bad "replay: not the fixture's 61 poses: $out"

# count LOG CHANNEL: messages of CHANNEL in LOG (0 when absent).
count() {
  "$build/tools/ptz-log-summary" --log "$1" 2>/dev/null |
    awk -v c="$2" '$1 == c && $2 ~ /^[0-9]+$/ {n = $2} END {print n + 0}'
}
# counter LOG PROCESS WORDS...: the value after WORDS in PROCESS's last status in LOG.
counter() {
  local log=$1 process=$2
  shift 2
  "$build/tools/ptz-log-summary" --log "$log" 2>/dev/null | awk -v p="$process" -v w="$*" '
    /last status/ {q = $1} q == p && index($0, "  " w " ") == 1 {
      n = split(w, a, " "); print $(n + 1) + 0; exit }'
}

echo "== scripts/record: defaults, and --all --split-mb 1 at the same time, on a lockstep run"
cat >"$work/loop.sh" <<'EOF'
#!/usr/bin/env bash
# ptz-detect, ptz-control, ptz-depth (1 Hz preview) and 2 s (sim time) of lockstep ptz-sim.
B=$1 src=$2
"$B/perception/ptz-detect" --config "$src/config/detect_default.yaml" >/dev/null 2>&1 & d=$!
"$B/control/ptz-control" >/dev/null 2>&1 & c=$!
"$B/perception/ptz-depth" --follow-target false --cloud-preview-rate-hz 1 >/dev/null 2>&1 & p=$!
"$B/tools/ptz-wait-for" --timeout-s 30 \
  --channels PROCESS_STATUS_PTZ_DETECT,PROCESS_STATUS_PTZ_CONTROL,PROCESS_STATUS_PTZ_DEPTH >/dev/null
"$B/sim/ptz-sim" --config "$src/config/sim_default.yaml" --clock lockstep --encoding jpeg \
  --duration-s 2 >/dev/null
rc=$?
kill -INT $d $c $p
wait $d $c $p
exit $rc
EOF
chmod +x "$work/loop.sh"
"$src/scripts/record" --out "$work/split" --all --split-mb 1 --quiet \
  --ready-file "$work/split.ready" &
split_pid=$!
until [ -f "$work/split.ready" ]; do
  kill -0 $split_pid 2>/dev/null || { bad "record --split-mb did not start"; break; }
  sleep 0.05 # polling its start-up
done
timeout 120 "$src/scripts/record" --out "$work/rec" -- "$work/loop.sh" "$build" "$src" \
  >"$work/rec.out" 2>&1 || bad "record -- loop.sh failed: $(cat "$work/rec.out")"
kill -TERM $split_pid
wait $split_pid || bad "record --split-mb exits $?"

log=$work/rec/run.lcmlog
published=$(counter "$log" ptz-sim frames_published)
echo "ptz-sim published ${published:-?} frames; recorded $(count "$log" STEREO_FRAME)"
[ "${published:-0}" -ge 55 ] || bad "ptz-sim published ${published:-no} frames (2 s at 30 Hz: 61)"
[ "$(count "$log" STEREO_FRAME)" = "$published" ] ||
  bad "STEREO_FRAME: $(count "$log" STEREO_FRAME) recorded of $published published"
[ "$(count "$log" SIM_TRUTH)" = "$published" ] ||
  bad "SIM_TRUTH: $(count "$log" SIM_TRUTH) recorded of $published"
for c in OBJECT_POSE PTZ_STATE PTZ_SETPOINT PROCESS_STATUS_PTZ_DEPTH POINT_CLOUD_PREVIEW; do
  [ "$(count "$log" "$c")" -gt 0 ] || bad "the default recording lacks $c"
done
clouds=$(counter "$log" ptz-depth out POINT_CLOUD)
[ "${clouds:-0}" -gt 0 ] || bad "ptz-depth published no clouds (its status: ${clouds:-none})"
[ "$(count "$log" POINT_CLOUD)" = 0 ] || bad "the default recording holds POINT_CLOUD"
[ "$(count "$log" DISPARITY_IMAGE)" = 0 ] || bad "the default recording holds DISPARITY_IMAGE"
grep -q "STEREO_FRAME  *$published " "$work/rec.out" ||
  bad "record's own summary lacks the frames: $(cat "$work/rec.out")"

shopt -s nullglob
pieces=("$work"/split/run.lcmlog.*)
echo "split: ${#pieces[@]} files, $(cat "${pieces[@]}" /dev/null | wc -c) bytes"
[ ${#pieces[@]} -ge 3 ] || bad "--split-mb 1 on ~7 MB made ${#pieces[@]} files"
for f in "${pieces[@]}"; do
  # the limit (1 MiB) plus the message that crossed it (a full cloud: ~0.3 MB)
  [ "$(stat -c %s "$f")" -le $((1048576 + 600000)) ] || bad "$f: $(stat -c %s "$f") bytes"
done
# An LCM log is a sequence of events: the pieces end to end are the whole recording (one piece
# alone may hold none of the channels ptz-log-summary needs to read it).
cat "${pieces[@]}" /dev/null >"$work/joined.lcmlog"
total() { count "$work/joined.lcmlog" "$1"; }  # CHANNEL: its messages over all the pieces
[ "$(total STEREO_FRAME)" = "$published" ] ||
  bad "split STEREO_FRAME: $(total STEREO_FRAME) of $published"
[ "$(total POINT_CLOUD)" = "$clouds" ] || bad "split POINT_CLOUD: $(total POINT_CLOUD) of $clouds"
for c in OBJECT_POSE PTZ_SETPOINT POINT_CLOUD_PREVIEW; do
  [ "$(total "$c")" = "$(count "$log" "$c")" ] ||
    bad "split $c: $(total "$c"), the default recording $(count "$log" "$c")"
done

echo "== scripts/record --private-net -- ptz-sim (realtime, 0.5 s)"
out=$(timeout 60 "$src/scripts/record" --private-net --out "$work/pn" --no-frames -- \
  "$build/sim/ptz-sim" --config "$src/config/sim_default.yaml" --encoding jpeg --duration-s 0.5 2>&1)
[ $? -eq 0 ] || bad "record --private-net failed: $out"
pn_published=$(counter "$work/pn/run.lcmlog" ptz-sim frames_published)
[ "${pn_published:-0}" -gt 0 ] || bad "record --private-net: no status of ptz-sim: $out"
[ "$(count "$work/pn/run.lcmlog" STEREO_FRAME)" = 0 ] || bad "--no-frames recorded STEREO_FRAME"
[ "$(count "$work/pn/run.lcmlog" SIM_TRUTH)" = "${pn_published:-x}" ] ||
  bad "record --private-net: SIM_TRUTH $(count "$work/pn/run.lcmlog" SIM_TRUTH) of $pn_published"

echo "== scripts/record: bad input refused, with the reason"
expect() {  # CODE PATTERN ARGS...: record ARGS exits CODE saying PATTERN on stderr
  local code=$1 pattern=$2
  shift 2
  local err rc
  err=$(timeout 20 "$src/scripts/record" "$@" 2>&1 >/dev/null)
  rc=$?
  [ $rc -eq "$code" ] || bad "record $*: exit $rc, not $code ($err)"
  grep -q -- "$pattern" <<<"$err" || bad "record $*: no '$pattern' in: $err"
}
expect 2 "not a valid regular expression" --out "$work/x" --channels '(bad'
expect 2 "not a valid regular expression" --out "$work/x" --exclude 'a['
expect 2 "--all records every channel" --out "$work/x" --all --exclude STEREO_FRAME
expect 2 "--split-mb must be" --out "$work/x" --split-mb 0
expect 2 "--duration must be" --out "$work/x" --duration soon
expect 2 "needs a COMMAND" --out "$work/x" --private-net
expect 2 "unknown argument" --out "$work/x" --bogus
expect 1 "already exists" --out "$work/rec" --duration 0.1
expect 1 "no process 999999999" --out "$work/x" --net-of 999999999
[ ! -e "$work/x" ] || bad "a refused record wrote $work/x"

echo "== scripts/demo says when the simulator cannot render at --rate"
# 1080p at 120 Hz: more than two cores render (about 22 ms a frame on both); the demo must warn
# with the count summary.json holds, and that count must be the simulator's own.
out=$(timeout 200 "$src/scripts/demo" --no-build --duration 4 --resolution 1080p --rate 120 \
  --out "$work/demo" 2>&1)
rc=$?
[ $rc -eq 0 ] || bad "demo at 1080p/120 Hz exits $rc: $(tail -5 <<<"$out")"
skipped=$(sed -n 's/^ *"frames_skipped_late": \([0-9]*\).*/\1/p' "$work/demo/summary.json")
[ "${skipped:-0}" -gt 0 ] || bad "demo at 1080p/120 Hz: no frame skipped late in summary.json"
grep -q "WARNING: ptz-sim skipped ${skipped:-x} frames late" <<<"$out" ||
  bad "demo at 1080p/120 Hz skipped ${skipped:-?} frames without saying so: $(tail -5 <<<"$out")"

echo "== scripts/demo --head onvif: ptz-driver drives ptz-sim's ONVIF cameras"
out=$("$src/scripts/demo" --no-build --head pelco 2>&1)
rc=$?
[ $rc -eq 2 ] && grep -q "head must be sim, visca or onvif" <<<"$out" ||
  bad "demo --head pelco: exit $rc, not refused: $(tail -3 <<<"$out")"
out=$(timeout 200 "$src/scripts/demo" --no-build --duration 5 --head onvif --out "$work/demo-onvif" \
  2>&1)
rc=$?
[ $rc -eq 0 ] || bad "demo --head onvif exits $rc: $(tail -5 <<<"$out")"
summary=$("$build/tools/ptz-log-summary" --log "$work/demo-onvif/run.lcmlog" 2>/dev/null)
# counter PROCESS NAME: the value in PROCESS's last status.
counter() {
  awk -v p="$1" -v n="$2" '/last status/ {q = $1} q == p && $1 == n {v = $2} END {print v + 0}' \
    <<<"$summary"
}
states=$(awk '/last status/ {q = $1} q == "ptz-driver" && $1 == "out" && $2 == "PTZ_STATE" {print $3}' \
  <<<"$summary")
[ "${states:-0}" -gt 50 ] || bad "demo --head onvif: ptz-driver published ${states:-no} PTZ_STATE"
[ "$(counter ptz-sim onvif_setpoints_applied)" -gt 20 ] ||
  bad "demo --head onvif: $(counter ptz-sim onvif_setpoints_applied) ONVIF setpoints applied"
[ "$(counter ptz-driver head_errors)" -eq 0 ] ||
  bad "demo --head onvif: $(counter ptz-driver head_errors) head errors"
[ "$(counter ptz-sim onvif_auth_refused)" -eq 0 ] || bad "demo --head onvif: requests refused"
centring=$(sed -n 's/^ *"centering_rms_px": \([0-9.]*\).*/\1/p' "$work/demo-onvif/summary.json")
awk -v c="${centring:-99}" 'BEGIN {exit !(c < 10)}' ||
  bad "demo --head onvif: centring ${centring:-?} px RMS"
echo "demo --head onvif: ${states:-0} PTZ_STATE from ptz-driver, centring ${centring:-?} px RMS"

echo "== scripts/demo --scene markers: the tagged cube followed by its tags, its whole orientation"
out=$("$src/scripts/demo" --no-build --scene balloons 2>&1)
rc=$?
[ $rc -eq 2 ] && grep -q "scene must be default, markers or people" <<<"$out" ||
  bad "demo --scene balloons: exit $rc, not refused: $(tail -3 <<<"$out")"
# --private-net: the scene must survive the script's re-exec into its namespace.
out=$(timeout 200 "$src/scripts/demo" --no-build --duration 5 --scene markers --private-net \
  --out "$work/demo-markers" 2>&1)
rc=$?
[ $rc -eq 0 ] || bad "demo --scene markers exits $rc: $(tail -5 <<<"$out")"
samples=$(sed -n 's/^ *"orientation_samples": \([0-9]*\).*/\1/p' "$work/demo-markers/summary.json")
orientation=$(sed -n 's/^ *"orientation_error_rms_deg": \([0-9.]*\).*/\1/p' \
  "$work/demo-markers/summary.json")
[ "${samples:-0}" -gt 60 ] || bad "demo --scene markers: ${samples:-no} orientation samples"
awk -v o="${orientation:-99}" 'BEGIN {exit !(o < 2)}' ||
  bad "demo --scene markers: orientation ${orientation:-?} deg RMS"
echo "demo --scene markers: ${samples:-0} poses with the cube's orientation, ${orientation:-?} deg RMS"

echo "== scripts/demo --scene people: the walking person found by HOG and followed"
# At 15 Hz: the demo's processes take more than one core at 30 Hz (the figure's rendering, HOG),
# and this test shares the machine with another; frames ptz-detect had no time for count as lost.
out=$(timeout 200 "$src/scripts/demo" --no-build --duration 5 --rate 15 --scene people \
  --private-net --out "$work/demo-people" 2>&1)
rc=$?
[ $rc -eq 0 ] || bad "demo --scene people exits $rc: $(tail -5 <<<"$out")"
error=$(sed -n 's/^ *"position_error_rms_pct_of_range": \([0-9.]*\).*/\1/p' \
  "$work/demo-people/summary.json")
lost=$(sed -n 's/^ *"target_lost_s": \([0-9.]*\).*/\1/p' "$work/demo-people/summary.json")
awk -v e="${error:-99}" 'BEGIN {exit !(e < 8)}' ||
  bad "demo --scene people: position error ${error:-?} % of range"
awk -v l="${lost:-99}" 'BEGIN {exit !(l < 2)}' || bad "demo --scene people: target lost ${lost:-?} s"
echo "demo --scene people: the person at ${error:-?} % of range RMS, lost ${lost:-?} s"

[ $fail -eq 0 ] && echo "PASSED"
exit $fail
