#!/usr/bin/env bash
# The closed loop on three hosts of a LAN (scripts/demo-hosts: three network namespaces on a
# bridge, each host started by scripts/run-host with check-network's fixes): with the recommended
# layout (frames stay on the camera host), with 1 % and 5 % loss both ways on the camera host's
# link, and with that link down for 3 s.
#   test_several_hosts.sh SOURCE_DIR BUILD_DIR
set -uo pipefail
src=$1 build=$2
if ! unshare -n true 2>/dev/null || ! command -v nft >/dev/null; then
  echo "SKIPPED: needs 'unshare -n' (root) and nft (nftables) for the hosts' networks" >&2
  if [ -n "${CI:-}" ] && [ "${PTZ_ALLOW_SKIP:-0}" != 1 ]; then exit 1; fi
  exit 77
fi
export PTZ_BUILD=$build
work=$(mktemp -d /tmp/ptz_several_hosts.XXXXXX)
fail=0
bad() {
  echo "FAILED: $*"
  fail=1
}
# field NAME FILE: a number of the run's summary.json (null: nan).
field() { sed -n "s/^ *\"$1\": \\(.*\\),\\{0,1\\}$/\\1/p" "$2" | tr -d ',' | sed 's/null/nan/'; }
# below A B: whether number A <= B (nan is not).
below() { awk -v a="$1" -v b="$2" 'BEGIN { exit !(a == a + 0 && a <= b) }'; }
# delivered CHANNEL DIR: the percentage of CHANNEL's messages that reached the other host.
delivered() { awk -v c="$1" '$1 == c {sub("%", "", $5); print $5}' "$2/delivery.txt"; }
run() {  # run NAME DEMO_FLAGS...: one run of the three hosts
  local name=$1
  shift
  echo "== $name: scripts/demo-hosts $*"
  if ! "$src/scripts/demo-hosts" --no-build --out "$work/$name" "$@" >"$work/$name.out" 2>&1; then
    bad "$name: demo-hosts failed"
    tail -n 40 "$work/$name.out"
    return 1
  fi
  sed -n '/^channel  *crossing/,/^camera host cable/p' "$work/$name.out"
  local key
  for key in frames_published frames_not_published frames_processed centering_rms_px \
    target_lost_s; do
    grep -E "\"$key\"" "$work/$name/summary.json" || bad "$name: no $key in the summary"
  done
  return 0
}
pose_rate() {  # the share of frames whose poses reached the control host, percent
  awk '/^poses \(OBJECT_TRACKS\) at the control host:/ {sub("%", "", $7); print $7}' "$1/delivery.txt"
}

# The recommended layout on a clean link: the loop closes, and no frame or cloud crosses.
if run clean --duration 12; then
  d=$work/clean
  c=$(field centering_rms_px "$d/summary.json")
  below "$c" 5 || bad "clean: centring $c px RMS (want <= 5)"
  r=$(pose_rate "$d")
  below 97 "$r" || bad "clean: poses for $r % of the frames at the control host (want >= 97)"
  grep -qE '^(STEREO_FRAME|POINT_CLOUD|DISPARITY_IMAGE) ' "$d/summary.txt" &&
    bad "clean: image data crossed to the control host: $(grep -E '^(STEREO|POINT)' "$d/summary.txt")"
  grep -q "ptz-depth" "$d/summary.txt" || bad "clean: no ptz-depth status crossed"
  s=$(delivered PTZ_SETPOINT "$d")
  below 97 "$s" || bad "clean: $s % of the setpoints reached the camera host (want >= 97)"
  p=$(delivered STEREO_PREVIEW "$d")
  below 95 "${p:-nan}" || bad "clean: ${p:-no} % of the previews reached the monitor host"
  p=$(delivered POINT_CLOUD_PREVIEW "$d")
  below 90 "${p:-nan}" || bad "clean: ${p:-no} % of the cloud previews reached the monitor host"
  # The monitor estimates the other hosts' clocks (one clock here: the offset is the latency).
  # The last estimate that rests on two statuses or more.
  off=$(awk '$1 == "clock" && $2 == "cam" {n = $5; sub(/^\(/, "", n); if (n + 0 >= 2) o = $3}
    END {print o}' "$d/mon/ptz-health.log")
  below "${off#[+-]}" 5 || bad "clean: the monitor's clock offset of cam is '${off:-none}' (want |x| < 5 ms)"
fi

# Loss on the camera host's link, both ways: tracking holds.
for pct in 1 5; do
  if run "loss$pct" --duration 12 --loss "$pct"; then
    d=$work/loss$pct
    c=$(field centering_rms_px "$d/summary.json")
    below "$c" 10 || bad "loss $pct %: centring $c px RMS (want <= 10)"
    r=$(pose_rate "$d")
    below 90 "$r" || bad "loss $pct %: poses for $r % of the frames (want >= 90)"
    # The loss is real: fewer than all poses arrive (the two rules dropped packets).
    t=$(delivered OBJECT_TRACKS "$d")
    [ "$pct" = 1 ] || below "$t" 99.5 || bad "loss $pct %: $t % of the tracks arrived: no loss made?"
  fi
done

# A monitoring station that shows whole frames (--frames-cross): JPEG frames reach it.
if run cross --duration 6 --frames-cross; then
  f=$(delivered STEREO_FRAME "$work/cross")
  below 97 "${f:-nan}" || bad "frames across: ${f:-no} % of the JPEG frames reached the monitor"
fi

# The camera host's link down for 3 s (its multicast route goes with it) and up again.
if run flap --duration 12 --flap-at 4 --flap-for 3; then
  d=$work/flap
  back=$(awk '/^poses back/ {print $3}' "$d/delivery.txt")
  below "${back:-nan}" 1 || bad "flap: poses back ${back:-never} s after the link came up (want <= 1)"
  unsent=$(field frames_not_published "$d/summary.json")
  below 45 "$unsent" || bad "flap: $unsent frames not published while the route was gone (want ~90)"
  lost=$(field target_lost_s "$d/summary.json")
  below 2.5 "$lost" || bad "flap: target_lost_s $lost (want the ~3 s without poses counted)"
  grep -q "ptz-control: \(WARN\|ERROR\): no OBJECT_TRACKS" "$d/ctl/ptz-control.log" ||
    bad "flap: ptz-control did not say its tracks stopped: $(tail -n 5 "$d/ctl/ptz-control.log")"
  grep -qE "ptz-sim: ERROR: .*cannot publish .*Network is unreachable" "$d/cam/ptz-sim.log" ||
    bad "flap: ptz-sim did not say it could not publish: $(tail -n 5 "$d/cam/ptz-sim.log")"
  grep -qE "ptz-detect: ERROR: .*cannot publish" "$d/cam/ptz-detect.log" ||
    bad "flap: ptz-detect did not say it could not publish: $(tail -n 5 "$d/cam/ptz-detect.log")"
  grep -qE "ptz-sim +cam .*(STALE|WARN|ERROR)" "$d/mon/ptz-health.log" ||
    bad "flap: the monitor host never saw the camera host go: $(tail -n 8 "$d/mon/ptz-health.log")"
  grep -q "multicast route on eth0 put back" "$d/cam/check-network.log" ||
    bad "flap: check-network --watch did not put the route back"
fi

if [ $fail -eq 0 ]; then
  echo "several hosts: all checks passed"
  rm -rf "$work"
else
  echo "(output kept in $work)"
fi
exit $fail
