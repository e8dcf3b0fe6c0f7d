#!/usr/bin/env node
// An independent ONVIF client (the npm package `onvif`, agsh/onvif) against ptz-sim's ONVIF
// cameras: connects as any NVR would (GetSystemDateAndTime for the camera's clock, GetServices or
// GetCapabilities, GetProfiles, GetVideoSources), signs with its own WS-UsernameToken digest,
// reads the profiles, moves the head with AbsoluteMove and polls GetStatus until it is there.
//
//   ONVIF_PASSWORD=... node onvif_client_check.js --port P --user U --x X --y Y --zoom Z
//       [--host 127.0.0.1] [--tolerance 0.005] [--timeout-s 30] [--exercise 1]
//
// Prints one JSON object: profiles (token, name, encoding, resolution, PTZ node), deviceInformation,
// requested, status (the last GetStatus: position x, y, zoom, moveStatus), polls, reached,
// timeShiftMs (the camera's clock as the client saw it, minus its own); with --exercise 1, once
// there, the rest of the PTZ and media operations through the package (exercise: nodes,
// configurations, options, stream URI, presets set, listed, gone to and removed, relative and
// continuous moves, stop, the position after each). Exit codes: 0 reached (and every exercised
// call answered); 1 an ONVIF error or not reached in time (stderr says which); 2 usage.
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

// A call of the package as a promise: resolves with its result, rejects with its error.
function call(name, ...argsOf) {
  return new Promise((resolve, reject) => {
    cam[name](...argsOf, (err, result) => (err ? reject(new Error(`${name}: ${err.message}`))
                                              : resolve(result)));
  });
}

async function position() {
  const s = await call('getStatus', {});
  return { x: s.position.x, y: s.position.y, zoom: s.position.zoom };
}

async function exercise() {
  const out = {};
  const nodes = await call('getNodes');
  out.nodes = Object.keys(nodes);
  out.maximumNumberOfPresets = nodes[out.nodes[0]].maximumNumberOfPresets;
  out.configurations = Object.values(await call('getConfigurations'))
    .map((c) => ({ token: c.token, nodeToken: c.nodeToken, defaultPTZSpeed: c.defaultPTZSpeed }));
  const options = await call('getConfigurationOptions', out.configurations[0].token);
  out.absoluteX = options.spaces.absolute.x;
  out.ptzTimeout = options.ptzTimeout;
  out.streamUri = (await call('getStreamUri', { protocol: 'RTSP' })).uri;
  await call('setPreset', { presetName: 'door' });
  const presets = await call('getPresets', {});
  out.presetsSet = Object.keys(presets);
  const token = presets.door && presets.door.$.token;
  out.presetToken = token;
  await call('relativeMove', { x: -0.2, y: 0, zoom: 0 });
  out.afterRelativeMove = await settle();
  await call('continuousMove', { x: 0.5, y: 0, zoom: 0, timeout: 60000 });
  await new Promise((r) => setTimeout(r, 500));  // half a second of panning, then Stop
  out.duringContinuousMove = await position();
  await call('stop', { panTilt: true, zoom: true });
  out.afterStop = await settle();
  await call('gotoPreset', { preset: token });
  out.afterGotoPreset = await settle();
  await call('removePreset', { presetToken: token });
  out.presetsLeft = Object.keys(await call('getPresets', {}));
  return out;
}

// Polls until two positions 0.2 s apart agree (the head has settled).
async function settle() {
  let last = await position();
  for (let i = 0; i < 100; ++i) {
    await new Promise((r) => setTimeout(r, 200));
    const p = await position();
    if (Math.abs(p.x - last.x) < 1e-4 && Math.abs(p.y - last.y) < 1e-4 &&
        Math.abs(p.zoom - last.zoom) < 1e-4) return p;
    last = p;
  }
  return last;
}

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
            const result = {
              profiles,
              deviceInformation: info,
              activeProfile: cam.activeSource && cam.activeSource.profileToken,
              requested,
              status: { x: p.x, y: p.y, zoom: p.zoom, moveStatus: status.moveStatus },
              polls,
              reached,
              timeShiftMs: cam.timeShift !== undefined
                ? cam.timeShift + process.uptime() * 1000 - Date.now() : null,
            };
            const done = () => {
              process.stdout.write(JSON.stringify(result) + '\n');
              if (!reached) fail('position', `not reached in ${args['timeout-s']} s`);
              process.exit(0);
            };
            if (!reached || args.exercise !== '1') return done();
            exercise().then((r) => {
              result.exercise = r;
              done();
            }, (err) => {
              process.stdout.write(JSON.stringify(result) + '\n');
              fail('exercise', err);
            });
            return;
          }
          setTimeout(poll, 100);
        });
      };
      poll();
    });
  });
});
