#!/usr/bin/env node
// The npm package `onvif`'s Discovery.probe (an independent WS-Discovery client, as NVRs use):
// one Probe to 239.255.255.250:3702, the answers collected for --timeout-ms. Prints one JSON
// object: `devices` (endpoint, xaddrs, scopes, types as the package read them, by endpoint) and
// `errors` (the answers it could not read). Exit codes: 0 at least --expect devices found; 1 fewer
// (stderr says how many); 2 usage.
'use strict';

const { Discovery } = require('onvif');

function usage(why) {
  process.stderr.write(`onvif_discovery_check: ${why}\n` +
    'usage: node onvif_discovery_check.js [--timeout-ms 2000] [--expect 1]\n');
  process.exit(2);
}

const opts = { 'timeout-ms': '2000', expect: '1' };
const argv = process.argv.slice(2);
for (let i = 0; i < argv.length; i += 2) {
  const key = argv[i].replace(/^--/, '');
  if (!(key in opts) || i + 1 >= argv.length) usage(`bad argument '${argv[i]}'`);
  opts[key] = argv[i + 1];
}
const timeoutMs = Number(opts['timeout-ms']);
const expect = Number(opts.expect);
if (!(timeoutMs > 0) || !(expect >= 0)) usage('--timeout-ms and --expect must be numbers');

// The package's own text fields, which may be objects ({_: text, $: attributes}).
const text = (v) => (v === undefined ? '' : typeof v === 'object' && '_' in v ? v._ : String(v));

Discovery.on('error', () => {});  // collected from the callback's errors instead
Discovery.probe({ timeout: timeoutMs, resolve: false }, (err, found) => {
  const errors = Array.isArray(err) ? err.map(String) : err ? [String(err)] : [];
  const devices = (found || []).map((d) => {
    const m = d.probeMatches.probeMatch;
    return {
      endpoint: text(m.endpointReference.address),
      xaddrs: text(m.XAddrs).split(' '),
      scopes: text(m.scopes).split(' '),
      types: text(m.types).split(' '),
    };
  }).sort((a, b) => a.endpoint.localeCompare(b.endpoint));
  process.stdout.write(JSON.stringify({ devices, errors }) + '\n');
  if (devices.length < expect) {
    process.stderr.write(`onvif_discovery_check: ${devices.length} devices, expected ${expect}\n`);
    process.exit(1);
  }
  process.exit(0);
});
