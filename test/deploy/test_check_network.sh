#!/usr/bin/env bash
# scripts/check-network on two hosts (network namespaces joined by a veth pair) and on a host
# alone: it never routes multicast to lo on a host with peers, its fixes make LCM messages cross
# (a logged STEREO_FRAME, ~43 kB in IP fragments, from one host to the other, ttl=1), and
# --watch puts the route back after the link went down and up.
#   test_check_network.sh SOURCE_DIR BUILD_DIR
set -uo pipefail
src=$1 build=$2
if ! unshare -n true 2>/dev/null; then
  echo "SKIPPED: needs 'unshare -n' (root) for private networks" >&2
  if [ -n "${CI:-}" ] && [ "${PTZ_ALLOW_SKIP:-0}" != 1 ]; then exit 1; fi
  exit 77
fi
# Everything below runs in host A's own network namespace; host B is a child in another.
if [ -z "${PTZ_IN_NETNS:-}" ]; then
  exec env PTZ_IN_NETNS=1 unshare -n "$0" "$@"
fi
check=$src/scripts/check-network
fail=0
bad() {
  echo "FAILED: $*"
  fail=1
}
# Polls cmd (a shell command) until it succeeds, at most the seconds given.
within() {
  local seconds=$1
  shift
  local end=$((SECONDS + seconds))
  until sh -c "$*"; do
    [ $SECONDS -lt $end ] || return 1
    sleep 0.1
  done
}
ip link set lo up
unshare -n sleep 600 &
b_pid=$!
# Host B exists once its process has left this network namespace.
until [ "$(readlink "/proc/$b_pid/ns/net")" != "$(readlink /proc/$$/ns/net)" ]; do sleep 0.01; done
trap 'kill $b_pid $watch_pid 2>/dev/null' EXIT
watch_pid=""
on_b() { nsenter -t "$b_pid" -n "$@"; }
ip link add v0 type veth peer name v1 netns "$b_pid"
ip addr add 10.77.0.1/24 dev v0
ip link set v0 up
on_b ip link set lo up
on_b ip addr add 10.77.0.2/24 dev v1
on_b ip link set v1 up

# A host with peers and no role given: asks, routes nothing.
out=$("$check" --fix 2>&1)
[ $? -eq 1 ] || bad "no role on a host with peers should exit 1: $out"
echo "$out" | grep -q -- "--interface IF" || bad "no advice to name the interface: $out"
[ -z "$(ip route show 224.0.0.0/4)" ] || bad "a route was added without a role: $(ip route show 224.0.0.0/4)"

# The interface named: the fix is for it, never lo.
out=$("$check" --interface v0 2>&1)
[ $? -eq 1 ] || bad "a missing route should exit 1: $out"
echo "$out" | grep -q "ip route replace 224.0.0.0/4 dev v0" || bad "no fix for v0: $out"
echo "$out" | grep -q "dev lo" && bad "lo proposed on a host with peers: $out"
# A route to lo (the single-host fix) on a host with peers is what cuts it off.
ip route add 224.0.0.0/4 dev lo
out=$("$check" --interface v0 2>&1)
echo "$out" | grep -q "routed to lo: the other hosts never hear" || bad "lo route not named: $out"
"$check" --interface v0 --fix >/dev/null 2>&1 || bad "--fix on A failed"
ip -o route get 239.255.76.67 | grep -q "dev v0" || bad "A's multicast not on v0: $(ip -o route get 239.255.76.67)"
on_b "$check" --peer 10.77.0.1 --fix >/dev/null 2>&1 || bad "--fix on B (by its peer) failed"
on_b ip -o route get 239.255.76.67 | grep -q "dev v1" || bad "B's multicast not on v1"
[ "$(cat /proc/sys/net/ipv4/ipfrag_time)" -le 5 ] || bad "ipfrag_time not lowered"
"$check" --interface v0 >/dev/null 2>&1 || bad "check after the fix is not ok: $("$check" --interface v0 2>&1)"

# Real LCM across: B plays the fixture's frames (ttl=1) until A has one.
url="udpm://239.255.76.67:7667?ttl=1&recv_buf_size=4194304"
"$build/tools/ptz-wait-for" --lcm-url "$url" --channels STEREO_FRAME --timeout-s 20 &
wait_pid=$!
for _ in $(seq 1 10); do
  kill -0 $wait_pid 2>/dev/null || break
  on_b lcm-logplayer -l "$url" -e '^STEREO_FRAME$' "$src/test/fixtures/closed_loop_2s.lcmlog" \
    >/dev/null 2>&1
done
wait $wait_pid || bad "no STEREO_FRAME from host B reached host A"

# --watch: the link goes down (the kernel takes its routes) and up; the route comes back.
"$check" --interface v0 --fix --watch >/dev/null 2>&1 &
watch_pid=$!
ip link set v0 down
within 5 '! ip -o route get 239.255.76.67 2>/dev/null | grep -q "dev v0"' ||
  bad "the route did not go with the link"
ip link set v0 up
within 5 'ip -o route get 239.255.76.67 2>/dev/null | grep -q "dev v0"' ||
  bad "--watch did not put the route back after the link came up"
kill $watch_pid 2>/dev/null

# A host alone (only lo): the single-host fix, on lo.
out=$(unshare -n sh -c "ip link set lo up; '$check' --fix; ip -o route get 239.255.76.67" 2>&1)
echo "$out" | grep -q "single host, multicast on lo): fixed" || bad "single host not fixed: $out"
echo "$out" | grep -q "dev lo" || bad "single host's route not on lo: $out"
"$check" --bogus >/dev/null 2>&1
[ $? -eq 2 ] || bad "an unknown argument should exit 2"
"$check" --help | grep -q -- "--single-host" || bad "--help does not describe the roles"

[ $fail -eq 0 ] && echo "check-network: all checks passed"
exit $fail
