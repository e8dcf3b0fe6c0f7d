#!/usr/bin/env node
// Test-only checker: hostile clients against ptz-foxglove-bridge while a good one (FoxgloveClient)
// stays subscribed to --topic. A raw `ws` client sends, one at a time, things no client should
// (garbage JSON, an unknown op, a subscription to an unknown channel, a duplicate subscription
// id, wrong types, binary data, a 100 kB message) and records the status each one got back;
// then a 2 MB message, which must close its connection (1009, or 1006 when the server's reset
// overtakes its close frame). A client without the foxglove.websocket.v1 subprotocol must be
// refused. The good client's message count before and after shows it was served throughout.
// Prints one JSON summary; exit 0 when it is complete.
//
// usage: ws_hostile_check.js --url ws://127.0.0.1:8765 [--topic /tf] [--min-good 3]
//        [--timeout-ms 30000]
"use strict";

const { FoxgloveClient } = require("@foxglove/ws-protocol");
const WebSocket = require("ws");

function args() {
  const a = { url: "ws://127.0.0.1:8765", topic: "/tf", minGood: 3, timeoutMs: 30000 };
  const argv = process.argv.slice(2);
  for (let i = 0; i < argv.length; i += 2) {
    const key = argv[i].replace(/^--/, "").replace(/-([a-z])/g, (_, c) => c.toUpperCase());
    if (!(key in a) || i + 1 >= argv.length) {
      process.stderr.write(`ws_hostile_check.js: unknown or incomplete argument ${argv[i]}\n`);
      process.exit(2);
    }
    a[key] = typeof a[key] === "number" ? Number(argv[i + 1]) : argv[i + 1];
  }
  return a;
}

const summary = {
  ok: false,
  error: null,
  refused_without_subprotocol: null, // the HTTP status of the refusal
  replies: [], // {name, level, message} per hostile message
  hostile_binary_messages: 0, // data its one good subscription got meanwhile
  giant_close_code: null,
  good_messages_before: 0,
  good_messages_after_hostile: 0,
  good_messages_after_giant: 0,
  good_closed: false,
};

function finish(error) {
  summary.error = error;
  summary.ok = error === null;
  process.stdout.write(JSON.stringify(summary, null, 1) + "\n");
  process.exit(error === null ? 0 : 1);
}

// Resolves once cond() holds, checked on every event of the emitters given (no polling).
function until(cond, hooks) {
  return new Promise((resolve) => {
    if (cond()) return resolve();
    hooks.push(() => {
      if (cond()) {
        resolve();
        return true;
      }
      return false;
    });
  });
}

async function main() {
  const a = args();
  const timer = setTimeout(() => finish(`timeout after ${a.timeoutMs} ms`), a.timeoutMs);
  timer.unref();
  let hooks = [];
  const poke = () => {
    hooks = hooks.filter((h) => !h());
  };

  // 1. No subprotocol: refused at the handshake.
  await new Promise((resolve) => {
    const plain = new WebSocket(a.url);
    plain.on("unexpected-response", (_req, res) => {
      summary.refused_without_subprotocol = res.statusCode;
      res.resume();
      plain.terminate();
      resolve();
    });
    plain.on("open", () => {
      summary.refused_without_subprotocol = "accepted";
      plain.close();
      resolve();
    });
    plain.on("error", () => resolve());
  });

  // 2. The good client: subscribed to --topic, counting.
  let good = 0;
  const goodWs = new WebSocket(a.url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  const goodClient = new FoxgloveClient({ ws: goodWs });
  let goodSubscribed = false;
  goodClient.on("advertise", (channels) => {
    const c = channels.find((ch) => ch.topic === a.topic);
    if (c && !goodSubscribed) {
      goodSubscribed = true;
      goodClient.subscribe(c.id);
    }
  });
  goodClient.on("message", () => {
    good += 1;
    poke();
  });
  goodClient.on("close", () => {
    summary.good_closed = true;
    poke();
  });
  goodClient.on("error", (e) => finish(`good client error: ${e && e.message}`));
  await until(() => good >= a.minGood, hooks);
  summary.good_messages_before = good;

  // 3. The hostile client.
  const bad = new WebSocket(a.url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  const statuses = [];
  let channels = [];
  let closeCode = null;
  bad.on("message", (data, isBinary) => {
    if (isBinary) {
      summary.hostile_binary_messages += 1;
    } else {
      const m = JSON.parse(data.toString());
      if (m.op === "status") statuses.push(m);
      if (m.op === "advertise") channels = channels.concat(m.channels);
    }
    poke();
  });
  bad.on("close", (code) => {
    closeCode = code;
    poke();
  });
  bad.on("error", () => poke());
  await until(() => channels.length > 0 || closeCode !== null, hooks);
  if (closeCode !== null) return finish(`hostile client closed early (${closeCode})`);
  const topicChannel = channels.find((c) => c.topic === a.topic);
  if (!topicChannel) return finish(`${a.topic} not advertised`);
  const unknownChannel = Math.max(...channels.map((c) => c.id)) + 1000;

  const sends = [
    ["garbage_json", ["not json{"]],
    ["not_an_object", ["[1,2,3]"]],
    ["unknown_op", [JSON.stringify({ op: "explode" })]],
    ["unknown_channel",
     [JSON.stringify({ op: "subscribe", subscriptions: [{ id: 1, channelId: unknownChannel }] })]],
    ["wrong_types",
     [JSON.stringify({ op: "subscribe", subscriptions: [{ id: -5, channelId: "x" }] })]],
    // The first subscribes (no answer), the second reuses its id.
    ["duplicate_subscription_id",
     [JSON.stringify({ op: "subscribe", subscriptions: [{ id: 7, channelId: topicChannel.id }] }),
      JSON.stringify({ op: "subscribe", subscriptions: [{ id: 7, channelId: topicChannel.id }] })]],
    ["unknown_unsubscribe", [JSON.stringify({ op: "unsubscribe", subscriptionIds: [12345] })]],
    ["binary", [Buffer.from([0x01, 0xff, 0xff, 0xff, 0xff, 0x00])]],
    ["too_large", [JSON.stringify({ op: "subscribe", pad: "x".repeat(100 * 1024) })]],
  ];
  for (const [name, messages] of sends) {
    const before = statuses.length;
    for (const m of messages) bad.send(m);
    await until(() => statuses.length > before || closeCode !== null, hooks);
    if (closeCode !== null) return finish(`hostile client closed after ${name} (${closeCode})`);
    const s = statuses[before];
    summary.replies.push({ name, level: s.level, message: s.message });
  }
  // Its good subscription is served too.
  await until(() => summary.hostile_binary_messages > 0 || closeCode !== null, hooks);
  const afterHostile = good;
  await until(() => good >= afterHostile + a.minGood || summary.good_closed, hooks);
  summary.good_messages_after_hostile = good - afterHostile;

  // 4. A message over the socket's limit: that connection is closed, no other.
  bad.send("y".repeat(2 * 1024 * 1024));
  await until(() => closeCode !== null, hooks);
  summary.giant_close_code = closeCode;
  const afterGiant = good;
  await until(() => good >= afterGiant + a.minGood || summary.good_closed, hooks);
  summary.good_messages_after_giant = good - afterGiant;
  goodClient.close();
  if (summary.good_closed && summary.good_messages_after_giant < a.minGood) {
    return finish("the good client was closed");
  }
  finish(null);
}

main().catch((e) => finish(`exception: ${e && e.stack}`));
