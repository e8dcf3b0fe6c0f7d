#!/usr/bin/env node
// An independent ONVIF client (the npm package `onvif`, agsh/onvif) against ptz-sim's ONVIF
// cameras: connects as any NVR would (GetSystemDateAndTime for the camera's clock, GetServices or
// GetCapabilities, GetProfiles, GetVideoSources), signs with its own WS-UsernameToken digest,
// reads the profiles, moves the head with AbsoluteMove and polls GetStatus until it is there.
//
//   ONVIF_PASSWORD=... node onvif_client_check.js --port P --user U --x X --y Y --zoom Z
//       [--host 127.0.0.1] [--tolerance 0.005] [--timeout-s 30]
//
// Prints one JSON object: profiles (token, name, encoding, resolution, PTZ node), deviceInformation,
// requested, status (the last GetStatus: position x, y, zoom, moveStatus), polls, reached,
// timeShiftMs (the camera's clock as the client saw it, minus its own). Exit codes: 0 reached;
// 1 an ONVIF error or not reached in time (stderr says which); 2 usage.
'use strict';
const { Cam } = require('onvif');

function usage(msg) {
  process.stderr.write(`onvif_client_check: ${msg}\n`);
  process.exit(2);
}

const args = { host: '127.0.0.1', tolerance: 0.005, 'timeout-s': 30 };
const argv = process.argv.slice(2);
for (let i = 0; i < argv.length; i += 2) {
  if (!argv[i].startsWith('--') || i + 1 >= argv.length) usage(`bad argument '${argv[i]}'`);
  args[argv[i].slice(2)] = argv[i + 1];
}
for (const k of ['port', 'user', 'x', 'y', 'zoom']) if (args[k] === undefined) usage(`--${k} missing`);
const requested = { x: Number(args.x), y: Number(args.y), zoom: Number(args.zoom) };
const tolerance = Number(args.tolerance);
const deadline = Date.now() + Number(args['timeout-s']) * 1000;

function fail(what, err) {
  process.stderr.write(`onvif_client_check: ${what}: ${err && err.message ? err.message : err}\n`);
  process.exit(1);
}

const cam = new Cam({
  hostname: args.host,
  port: Number(args.port),
  username: args.user,
  password: process.env.ONVIF_PASSWORD || '',
  timeout: 10000,
  autoconnect: false,
});

cam.connect((err) => {
  if (err) fail('connect', err);
  const profiles = (cam.profiles || []).map((p) => ({
    token: p.$ && p.$.token,
    name: p.name,
    encoding: p.videoEncoderConfiguration && p.videoEncoderConfiguration.encoding,
    width: p.videoEncoderConfiguration && p.videoEncoderConfiguration.resolution.width,
    height: p.videoEncoderConfiguration && p.videoEncoderConfiguration.resolution.height,
    ptzNode: p.PTZConfiguration && p.PTZConfiguration.nodeToken,
  }));
  cam.getDeviceInformation((err, info) => {
    if (err) fail('getDeviceInformation', err);
    cam.absoluteMove(requested, (err) => {
      if (err) fail('absoluteMove', err);
      let polls = 0;
      const poll = () => {
        cam.getStatus({}, (err, status) => {
          if (err) fail('getStatus', err);
          ++polls;
          const p = status.position;
          const reached = Math.abs(p.x - requested.x) <= tolerance &&
                          Math.abs(p.y - requested.y) <= tolerance &&
                          Math.abs(p.zoom - requested.zoom) <= tolerance;
          if (reached || Date.now() > deadline) {
            process.stdout.write(JSON.stringify({
              profiles,
              deviceInformation: info,
              activeProfile: cam.activeSource && cam.activeSource.profileToken,
              requested,
              status: { x: p.x, y: p.y, zoom: p.zoom, moveStatus: status.moveStatus },
              polls,
              reached,
              timeShiftMs: cam.timeShift !== undefined
                ? cam.timeShift + process.uptime() * 1000 - Date.now() : null,
            }) + '\n');
            if (!reached) fail('position', `not reached in ${args['timeout-s']} s`);
            process.exit(0);
          }
          setTimeout(poll, 100);
        });
      };
      poll();
    });
  });
});
