#!/usr/bin/env node
// Test-only checker: a real Foxglove WebSocket client (@foxglove/ws-protocol's FoxgloveClient on
// the `ws` package) against ptz-foxglove-bridge. Connects, waits for serverInfo and the
// advertised topics, subscribes to --topics and the --control topic, takes at least one message
// of each, unsubscribes --topics, and then counts what still comes for them while the control
// topic keeps flowing (so their absence means something). Prints one JSON summary on stdout;
// the C++ test asserts on it. Exit 0 when the summary is complete, 1 otherwise (summary.error).
//
// The end of the unsubscribe is marked without a sleep: the server handles a client's messages
// in order and sends in order, so after the status answering a getParameters sent right after
// the unsubscribe (the server has no parameters), no message of those subscriptions may come.
//
// usage: ws_client_check.js --url ws://127.0.0.1:8765 [--topics /left/image,/tf]
//        [--control /right/image] [--window-ms 1000] [--min-control 3] [--timeout-ms 30000]
"use strict";

const { FoxgloveClient } = require("@foxglove/ws-protocol");
const WebSocket = require("ws");

function args() {
  const a = {
    url: "ws://127.0.0.1:8765",
    topics: "/left/image,/tf",
    control: "/right/image",
    windowMs: 1000,
    minControl: 3,
    timeoutMs: 30000,
  };
  const argv = process.argv.slice(2);
  for (let i = 0; i < argv.length; i += 2) {
    const key = argv[i].replace(/^--/, "").replace(/-([a-z])/g, (_, c) => c.toUpperCase());
    if (!(key in a) || i + 1 >= argv.length) {
      process.stderr.write(`ws_client_check.js: unknown or incomplete argument ${argv[i]}\n`);
      process.exit(2);
    }
    a[key] = typeof a[key] === "number" ? Number(argv[i + 1]) : argv[i + 1];
  }
  a.topics = a.topics.split(",").filter((t) => t.length > 0);
  return a;
}

// What the C++ test checks of one decoded message: its keys and the fields that name frames.
function describe(topic, schemaName, bytes, json) {
  const d = { size_bytes: bytes, schema_name: schemaName, keys: Object.keys(json).sort() };
  if ("format" in json) d.format = json.format;
  if ("frame_id" in json) d.frame_id = json.frame_id;
  if (typeof json.data === "string") {
    const raw = Buffer.from(json.data, "base64");
    d.data_bytes = raw.length;
    d.jpeg_soi = raw.length > 2 && raw[0] === 0xff && raw[1] === 0xd8;
  }
  if (Array.isArray(json.transforms)) {
    d.transforms = json.transforms.map((t) => ({
      parent_frame_id: t.parent_frame_id,
      child_frame_id: t.child_frame_id,
    }));
  }
  return d;
}

function main() {
  const a = args();
  const summary = {
    ok: false,
    error: null,
    url: a.url,
    server_info: null,
    channels: [],
    received: {},
    statuses: [],
    in_flight_after_unsubscribe: {},
    after_unsubscribe: {},
    control_after_unsubscribe: 0,
    window_ms: 0,
  };
  const textDecoder = new TextDecoder();
  const ws = new WebSocket(a.url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  const client = new FoxgloveClient({ ws });
  const byTopic = new Map(); // topic -> channel
  const subOf = new Map(); // topic -> subscription id
  const topicOfSub = new Map(); // subscription id -> topic
  const wanted = [...a.topics, a.control];
  let phase = "advertise"; // advertise -> receive -> unsubscribing -> window -> done
  let windowStart = 0;

  function finish(error) {
    if (phase === "done") return;
    phase = "done";
    summary.error = error;
    summary.ok = error === null;
    process.stdout.write(JSON.stringify(summary, null, 1) + "\n");
    client.close();
    process.exit(error === null ? 0 : 1);
  }
  const timer = setTimeout(() => {
    const missing = wanted.filter((t) => !summary.received[t]);
    finish(`timeout in phase ${phase} after ${a.timeoutMs} ms (no message yet on: ${missing})`);
  }, a.timeoutMs);
  timer.unref();

  client.on("error", (e) => finish(`client error: ${e && e.message}`));
  client.on("close", (e) => finish(`closed by the server (code ${e && e.code})`));
  client.on("serverInfo", (info) => {
    summary.server_info = {
      name: info.name,
      capabilities: info.capabilities,
      supported_encodings: info.supportedEncodings,
      metadata: info.metadata,
      session_id: info.sessionId,
    };
  });
  client.on("status", (s) => {
    summary.statuses.push({ level: s.level, message: s.message });
    if (phase === "unsubscribing" && /getParameters/.test(s.message)) {
      phase = "window";
      windowStart = Date.now();
    }
  });
  client.on("advertise", (channels) => {
    for (const c of channels) {
      summary.channels.push({
        id: c.id,
        topic: c.topic,
        encoding: c.encoding,
        schema_name: c.schemaName,
        schema_encoding: c.schemaEncoding,
        schema_bytes: c.schema.length,
      });
      byTopic.set(c.topic, c);
    }
    if (phase !== "advertise" || !wanted.every((t) => byTopic.has(t))) return;
    if (summary.server_info === null) return finish("advertise before serverInfo");
    phase = "receive";
    for (const t of wanted) {
      const id = client.subscribe(byTopic.get(t).id);
      subOf.set(t, id);
      topicOfSub.set(id, t);
    }
  });
  client.on("message", ({ subscriptionId, timestamp, data }) => {
    const topic = topicOfSub.get(subscriptionId);
    if (topic === undefined) return finish(`message for unknown subscription ${subscriptionId}`);
    if (phase === "receive" && !summary.received[topic]) {
      let json;
      try {
        json = JSON.parse(textDecoder.decode(data));
      } catch (e) {
        return finish(`${topic}: message is not JSON: ${e.message}`);
      }
      summary.received[topic] = describe(topic, byTopic.get(topic).schemaName, data.byteLength,
                                         json);
      summary.received[topic].timestamp_ns = timestamp.toString();
      if (wanted.every((t) => summary.received[t])) {
        phase = "unsubscribing";
        for (const t of a.topics) {
          summary.after_unsubscribe[t] = 0;
          client.unsubscribe(subOf.get(t));
        }
        client.getParameters([], "marker");
      }
      return;
    }
    if (phase === "unsubscribing" && a.topics.includes(topic)) {
      summary.in_flight_after_unsubscribe[topic] =
        (summary.in_flight_after_unsubscribe[topic] || 0) + 1;
    }
    if (phase !== "window") return;
    if (topic === a.control) {
      summary.control_after_unsubscribe += 1;
    } else {
      summary.after_unsubscribe[topic] = (summary.after_unsubscribe[topic] || 0) + 1;
    }
    summary.window_ms = Date.now() - windowStart;
    if (summary.window_ms >= a.windowMs && summary.control_after_unsubscribe >= a.minControl) {
      finish(null);
    }
  });
}

main();
