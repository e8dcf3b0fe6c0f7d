#!/bin/sh
# Runs a test in a private network namespace with multicast on loopback, so no LCM packet
# leaves the test and parallel runs cannot hear each other. Exit 77 (skipped) without root.
if ! unshare -n true 2>/dev/null; then
  echo "SKIPPED: this test needs 'unshare -n' (root or user namespaces) for a private network" >&2
  exit 77
fi
exec unshare -n sh -c 'ip link set lo up multicast on && ip route add 224.0.0.0/4 dev lo && exec "$@"' sh "$@"
