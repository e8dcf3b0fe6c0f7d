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
exec unshare -n -p -f --mount-proc sh -c 'ip link set lo up multicast on && ip route add 224.0.0.0/4 dev lo && exec "$@"' sh "$@"
