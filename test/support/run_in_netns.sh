#!/bin/sh
# Runs a test in private network and PID namespaces: multicast on loopback, so no LCM packet
# leaves the test and parallel runs cannot hear each other; the test is PID 1 there, so any
# process it started dies with it, even when it crashes. Without the rights for that the test
# reports itself skipped (exit 77), except in CI (CI set), where that is a failure unless
# PTZ_ALLOW_SKIP=1: a green CI must have run the multi-process tests.
if ! unshare -n -p -f --mount-proc true 2>/dev/null; then
  echo "SKIPPED: this test needs 'unshare -n -p -f' (root or user namespaces) for a private network" >&2
  if [ -n "${CI:-}" ] && [ "${PTZ_ALLOW_SKIP:-0}" != 1 ]; then
    echo "FAILED: in CI the multi-process tests must run (set PTZ_ALLOW_SKIP=1 to allow skipping)" >&2
    exit 1
  fi
  exit 77
fi
# The kernel picks a socket's own port (an LCM sender's, a driver's VISCA socket) from the
# namespace's ephemeral range; the tests' servers listen on fixed ports below 61000 (VISCA 5239x,
# ONVIF 180xx), so that range is moved above them: otherwise a sender can hold a port before the
# server that the test gives it starts (CI once saw "cannot bind UDP 127.0.0.1:52394").
exec unshare -n -p -f --mount-proc sh -c '
  ip link set lo up multicast on && ip route add 224.0.0.0/4 dev lo || exit 1
  echo "61000 65535" 2>/dev/null >/proc/sys/net/ipv4/ip_local_port_range ||
    echo "run_in_netns: cannot move the ephemeral ports above 61000; a fixed port may be taken" >&2
  exec "$@"' sh "$@"
