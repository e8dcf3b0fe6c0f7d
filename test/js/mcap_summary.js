#!/usr/bin/env node
// Test-only checker of an MCAP file, independent of the C++ writer: reads it with @mcap/core's
// McapIndexedReader (summary, chunk indexes, message indexes) and McapStreamReader (every record
// from the first byte), and walks the record framing itself to check what neither reader checks
// (Data End CRC, summary offset groups, chunk and message index offsets, statistics). Prints one
// JSON object on stdout; u64 values are printed as exact JSON integers.
//
//   node test/js/mcap_summary.js FILE [--validate-foxglove] [--messages]
//
// --validate-foxglove: every JSON message whose schema is foxglove.X is validated against
// @foxglove/schemas' JSON schema X, and messages of other "jsonschema" schemas against the schema
// in the file. --messages: each topic's messages (sequence, times, size, crc32) in the output.
// Exit codes: 0 all good; 1 the file cannot be read or is inconsistent (stderr says why; the JSON
// is printed when both readers got through, with "problems"); 2 usage; 3 invalid messages.
"use strict";

const fs = require("fs");
const crypto = require("crypto");
const { McapIndexedReader, McapStreamReader } = require("@mcap/core");
const fzstd = require("fzstd");
const Ajv = require("ajv");
const Ajv2019 = require("ajv/dist/2019");
const Ajv2020 = require("ajv/dist/2020");
const foxgloveSchemas = require("@foxglove/schemas/jsonschema");

const MAGIC = Buffer.from([0x89, 0x4d, 0x43, 0x41, 0x50, 0x30, 0x0d, 0x0a]);
const OP = {
  HEADER: 0x01, FOOTER: 0x02, SCHEMA: 0x03, CHANNEL: 0x04, MESSAGE: 0x05, CHUNK: 0x06,
  MESSAGE_INDEX: 0x07, CHUNK_INDEX: 0x08, ATTACHMENT: 0x09, ATTACHMENT_INDEX: 0x0a,
  STATISTICS: 0x0b, METADATA: 0x0c, METADATA_INDEX: 0x0d, SUMMARY_OFFSET: 0x0e, DATA_END: 0x0f,
};

function usage(msg) {
  process.stderr.write(`${msg}\nusage: node mcap_summary.js FILE [--validate-foxglove] [--messages]\n`);
  process.exit(2);
}

// CRC-32 (IEEE, reflected, as the MCAP spec and zlib), written here so the check does not lean on
// the readers' own CRC code.
const CRC_TABLE = (() => {
  const t = new Uint32Array(256);
  for (let n = 0; n < 256; n++) {
    let c = n;
    for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    t[n] = c >>> 0;
  }
  return t;
})();
function crc32(bytes) {
  let c = 0xffffffff;
  for (let i = 0; i < bytes.length; i++) c = CRC_TABLE[(c ^ bytes[i]) & 0xff] ^ (c >>> 8);
  return (c ^ 0xffffffff) >>> 0;
}

const decompressHandlers = {
  zstd: (buffer, decompressedSize) => {
    const out = fzstd.decompress(buffer, new Uint8Array(Number(decompressedSize)));
    if (BigInt(out.length) !== BigInt(decompressedSize)) {
      throw new Error(`zstd chunk decompressed to ${out.length} bytes, expected ${decompressedSize}`);
    }
    return out;
  },
};

// The record framing, read by hand: [{op, offset, length (with prefix), content}].
function walkRecords(bytes, start, end, problems, where) {
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const records = [];
  let pos = start;
  while (pos < end) {
    if (end - pos < 9) {
      problems.push(`${where}: ${end - pos} stray bytes at ${pos}`);
      break;
    }
    const op = view.getUint8(pos);
    const len = view.getBigUint64(pos + 1, true);
    if (BigInt(pos + 9) + len > BigInt(end)) {
      problems.push(`${where}: record 0x${op.toString(16)} at ${pos} of ${len} bytes runs past ${end}`);
      break;
    }
    const length = 9 + Number(len);
    records.push({ op, offset: pos, length, content: bytes.subarray(pos + 9, pos + length) });
    pos += length;
    if (op === OP.FOOTER) break;
  }
  return { records, end: pos };
}

class Cursor {
  constructor(bytes) {
    this.bytes = bytes;
    this.view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    this.pos = 0;
  }
  u8() { return this.view.getUint8((this.pos += 1) - 1); }
  u16() { return this.view.getUint16((this.pos += 2) - 2, true); }
  u32() { return this.view.getUint32((this.pos += 4) - 4, true); }
  u64() { return this.view.getBigUint64((this.pos += 8) - 8, true); }
  str() { const n = this.u32(); return Buffer.from(this.bytes.subarray(this.pos, (this.pos += n))).toString("utf8"); }
  raw(n) { return this.bytes.subarray(this.pos, (this.pos += n)); }
}

function hex(n) { return `0x${n.toString(16).padStart(2, "0")}`; }

// What the messages of a topic add up to, whatever the order they are read in: the count, the
// time range and a digest of the multiset of (sequence, log time, publish time, data).
class TopicTally {
  constructor() { this.count = 0; this.hashes = []; this.min = undefined; this.max = undefined; this.first = undefined; this.last = undefined; this.list = []; }
  add(m, keepList) {
    this.count++;
    if (this.first === undefined) this.first = m.logTime;
    this.last = m.logTime;
    if (this.min === undefined || m.logTime < this.min) this.min = m.logTime;
    if (this.max === undefined || m.logTime > this.max) this.max = m.logTime;
    const h = crypto.createHash("sha256");
    const head = Buffer.alloc(20);
    head.writeUInt32LE(m.sequence, 0);
    head.writeBigUInt64LE(m.logTime, 4);
    head.writeBigUInt64LE(m.publishTime, 12);
    h.update(head);
    h.update(m.data);
    this.hashes.push(h.digest("hex"));
    if (keepList) {
      this.list.push({ sequence: m.sequence, logTime: m.logTime, publishTime: m.publishTime, size: m.data.length, crc32: crc32(m.data) });
    }
  }
  digest() { return crypto.createHash("sha256").update(this.hashes.slice().sort().join("")).digest("hex"); }
  summary() {
    return { count: this.count, minLogTime: this.min ?? null, maxLogTime: this.max ?? null, digest: this.digest() };
  }
}

function mapToObject(m) {
  const o = {};
  for (const [k, v] of m) o[String(k)] = v;
  return o;
}

// JSON with BigInts as exact integers (JSON.stringify cannot emit them; a marker is swapped).
function stringifyExact(value) {
  const s = JSON.stringify(value, (_k, v) => (typeof v === "bigint" ? `__u64__${v}` : v));
  return s.replace(/"__u64__(\d+)"/g, "$1");
}

// Checks base64 strings where the schema says contentEncoding base64 (ajv treats it as an annotation).
function base64Errors(schema, data, path) {
  if (!schema || typeof schema !== "object" || data === null || data === undefined) return [];
  if (schema.contentEncoding === "base64" && typeof data === "string") {
    return /^(?:[A-Za-z0-9+/]{4})*(?:[A-Za-z0-9+/]{2}==|[A-Za-z0-9+/]{3}=)?$/.test(data) ? [] : [`${path || "/"} is not base64`];
  }
  const errors = [];
  if (schema.properties && typeof data === "object" && !Array.isArray(data)) {
    for (const [k, sub] of Object.entries(schema.properties)) errors.push(...base64Errors(sub, data[k], `${path}/${k}`));
  }
  if (schema.items && Array.isArray(data)) {
    data.forEach((d, i) => errors.push(...base64Errors(schema.items, d, `${path}/${i}`)));
  }
  return errors;
}

// For a foxglove.X jsonschema schema: whether the file's schema is @foxglove/schemas' X (keys in any
// order); null for other schemas.
function canonical(v) {
  if (Array.isArray(v)) return v.map(canonical);
  if (v && typeof v === "object") return Object.fromEntries(Object.keys(v).sort().map((k) => [k, canonical(v[k])]));
  return v;
}
function matchesOfficial(schemaRecord) {
  if (!schemaRecord.name.startsWith("foxglove.") || schemaRecord.encoding !== "jsonschema") return null;
  const official = foxgloveSchemas[schemaRecord.name.slice("foxglove.".length)];
  if (!official) return false;
  try {
    const embedded = JSON.parse(Buffer.from(schemaRecord.data).toString("utf8"));
    return JSON.stringify(canonical(embedded)) === JSON.stringify(canonical(official));
  } catch {
    return false;
  }
}

function ajvFor(schema) {
  const dialect = typeof schema.$schema === "string" ? schema.$schema : "";
  if (dialect.includes("2020-12")) return new Ajv2020({ allErrors: false });
  if (dialect.includes("2019-09")) return new Ajv2019({ allErrors: false });
  return new Ajv({ allErrors: false });
}

class Validator {
  constructor() { this.byTopic = new Map(); this.compiled = new Map(); }
  validatorFor(schemaRecord) {
    const key = schemaRecord.id;
    if (this.compiled.has(key)) return this.compiled.get(key);
    let entry;
    try {
      let schema;
      let source;
      if (schemaRecord.name.startsWith("foxglove.")) {
        schema = foxgloveSchemas[schemaRecord.name.slice("foxglove.".length)];
        source = "@foxglove/schemas";
        if (!schema) throw new Error(`no schema ${schemaRecord.name} in @foxglove/schemas`);
      } else {
        schema = JSON.parse(Buffer.from(schemaRecord.data).toString("utf8"));
        source = "the file";
      }
      entry = { validate: ajvFor(schema).compile(schema), schema, source };
    } catch (e) {
      entry = { error: `schema ${schemaRecord.name} (id ${schemaRecord.id}): ${e.message}` };
    }
    this.compiled.set(key, entry);
    return entry;
  }
  check(channel, schemaRecord, message) {
    if (!schemaRecord) return;
    const official = schemaRecord.name.startsWith("foxglove.");
    if (!official && schemaRecord.encoding !== "jsonschema") return;
    let t = this.byTopic.get(channel.topic);
    if (!t) this.byTopic.set(channel.topic, (t = { schema: schemaRecord.name, checked: 0, invalid: 0, skipped: 0, firstError: null }));
    if (channel.messageEncoding !== "json") {
      t.skipped++;
      if (!t.firstError) t.firstError = `message encoding ${channel.messageEncoding}, not json: not validated`;
      return;
    }
    t.checked++;
    const fail = (msg) => {
      t.invalid++;
      if (!t.firstError) t.firstError = `sequence ${message.sequence} log_time ${message.logTime}: ${msg}`;
    };
    const v = this.validatorFor(schemaRecord);
    if (v.error) return fail(v.error);
    let data;
    try {
      data = JSON.parse(Buffer.from(message.data).toString("utf8"));
    } catch (e) {
      return fail(`not JSON: ${e.message}`);
    }
    if (!v.validate(data)) {
      return fail(`against ${schemaRecord.name} from ${v.source}: ${v.validate.errors.map((e) => `${e.instancePath || "/"} ${e.message}`).join("; ")}`);
    }
    const b64 = base64Errors(v.schema, data, "");
    if (b64.length) fail(`against ${schemaRecord.name} from ${v.source}: ${b64.join("; ")}`);
  }
}

async function readIndexed(path, keepList, problems) {
  const fh = await fs.promises.open(path, "r");
  try {
    const size = BigInt((await fh.stat()).size);
    const readable = {
      size: async () => size,
      read: async (offset, length) => {
        if (offset + length > size) throw new Error(`read of ${length} bytes at ${offset} past the end (${size})`);
        const buf = Buffer.alloc(Number(length));
        const { bytesRead } = await fh.read(buf, 0, Number(length), Number(offset));
        if (bytesRead !== Number(length)) throw new Error(`short read at ${offset}`);
        return new Uint8Array(buf.buffer, buf.byteOffset, buf.byteLength);
      },
    };
    const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
    const topics = new Map();
    let inOrder = true;
    let previous;
    for await (const m of reader.readMessages({ validateCrcs: true })) {
      const channel = reader.channelsById.get(m.channelId);
      if (!channel) throw new Error(`message on channel ${m.channelId}, absent from the summary`);
      if (!topics.has(channel.topic)) topics.set(channel.topic, new TopicTally());
      topics.get(channel.topic).add(m, keepList);
      if (previous !== undefined && m.logTime < previous) inOrder = false;
      previous = m.logTime;
    }
    if (!inOrder) problems.push("indexed reader: messages not in log time order (message indexes wrong)");
    const metadata = [];
    for await (const md of reader.readMetadata()) metadata.push({ name: md.name, metadata: mapToObject(md.metadata) });
    return { reader, topics, metadata };
  } finally {
    await fh.close();
  }
}

function readStream(bytes, validator) {
  const reader = new McapStreamReader({ decompressHandlers, validateCrcs: true, includeChunks: true });
  reader.append(bytes);
  const counts = {};
  const channels = new Map();
  const schemas = new Map();
  const topics = new Map();
  const messageIndexes = [];
  const metadata = [];
  let header;
  let dataEnd;
  for (let r; (r = reader.nextRecord()); ) {
    counts[r.type] = (counts[r.type] ?? 0) + 1;
    switch (r.type) {
      case "Header": header = r; break;
      case "Schema": schemas.set(r.id, r); break;
      case "Channel": channels.set(r.id, r); break;
      case "Message": {
        const channel = channels.get(r.channelId);
        if (!topics.has(channel.topic)) topics.set(channel.topic, new TopicTally());
        topics.get(channel.topic).add(r, false);
        if (validator) validator.check(channel, schemas.get(channel.schemaId), r);
        break;
      }
      case "MessageIndex": messageIndexes.push(r); break;
      case "Metadata": metadata.push({ name: r.name, metadata: mapToObject(r.metadata) }); break;
      case "DataEnd": dataEnd = r; break;
      default: break;
    }
  }
  if (!reader.done()) throw new Error(`stream reader: file incomplete (${reader.bytesRemaining()} bytes unparsed)`);
  return { counts, header, channels, schemas, topics, messageIndexes, metadata, dataEnd };
}

// The framing, offsets and CRCs, by hand.
function checkStructure(bytes, indexed, problems) {
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const out = {};
  if (bytes.length < 16 || !MAGIC.equals(Buffer.from(bytes.subarray(0, 8))) ||
      !MAGIC.equals(Buffer.from(bytes.subarray(bytes.length - 8)))) {
    problems.push("leading or trailing magic wrong");
    return out;
  }
  const { records, end } = walkRecords(bytes, 8, bytes.length - 8, problems, "file");
  const footer = records[records.length - 1];
  if (!footer || footer.op !== OP.FOOTER || end !== bytes.length - 8) {
    problems.push("the footer is not the last record before the closing magic");
    return out;
  }
  if (records[0].op !== OP.HEADER) problems.push("the first record is not the Header");
  const byOffset = new Map(records.map((r, i) => [r.offset, i]));
  const dataEndIndex = records.findIndex((r) => r.op === OP.DATA_END);
  if (dataEndIndex < 0) {
    problems.push("no Data End record");
    return out;
  }
  const dataEnd = records[dataEndIndex];
  const storedCrc = new DataView(dataEnd.content.buffer, dataEnd.content.byteOffset).getUint32(0, true);
  const computedCrc = crc32(bytes.subarray(0, dataEnd.offset));
  out.dataSectionCrc = { stored: storedCrc, computed: computedCrc, ok: storedCrc === computedCrc };
  if (storedCrc !== 0 && storedCrc !== computedCrc) problems.push(`Data End CRC ${storedCrc} != computed ${computedCrc}`);

  const fc = new Cursor(footer.content);
  const summaryStart = Number(fc.u64());
  const summaryOffsetStart = Number(fc.u64());
  const summaryCrc = fc.u32();
  const afterDataEnd = records[dataEndIndex + 1];
  const expectedSummaryStart = afterDataEnd.op === OP.FOOTER ? 0 : afterDataEnd.offset;
  if (summaryStart !== expectedSummaryStart) problems.push(`footer summary_start ${summaryStart}, the summary starts at ${expectedSummaryStart}`);
  const firstOffsetRecord = records.find((r) => r.op === OP.SUMMARY_OFFSET);
  const expectedOffsetStart = firstOffsetRecord ? firstOffsetRecord.offset : 0;
  if (summaryOffsetStart !== expectedOffsetStart) problems.push(`footer summary_offset_start ${summaryOffsetStart}, the first Summary Offset is at ${expectedOffsetStart}`);
  if (summaryStart) {
    const computed = crc32(bytes.subarray(summaryStart, footer.offset + 1 + 8 + 8 + 8));
    out.summaryCrc = { stored: summaryCrc, computed, ok: computed === summaryCrc };
    if (summaryCrc !== 0 && summaryCrc !== computed) problems.push(`summary CRC ${summaryCrc} != computed ${computed}`);
  }

  // Summary offset groups: each covers exactly the run of records of its opcode.
  const summaryRecords = records.slice(dataEndIndex + 1, -1);
  out.summaryOffsets = {};
  for (const r of summaryRecords.filter((x) => x.op === OP.SUMMARY_OFFSET)) {
    const c = new Cursor(r.content);
    const op = c.u8();
    const start = Number(c.u64());
    const length = Number(c.u64());
    const run = summaryRecords.filter((x) => x.op === op);
    const runStart = run.length ? run[0].offset : -1;
    const runLength = run.reduce((a, x) => a + x.length, 0);
    const contiguous = run.every((x, i) => i === 0 || x.offset === run[i - 1].offset + run[i - 1].length);
    const ok = start === runStart && length === runLength && contiguous;
    if (!ok) problems.push(`Summary Offset of ${hex(op)}: ${start}+${length}, the records are at ${runStart}+${runLength}${contiguous ? "" : " (not grouped)"}`);
    out.summaryOffsets[hex(op)] = { start, length, records: run.length, ok };
  }
  for (const op of new Set(summaryRecords.map((x) => x.op))) {
    if (op !== OP.SUMMARY_OFFSET && !out.summaryOffsets[hex(op)]) problems.push(`no Summary Offset for the summary's ${hex(op)} records`);
  }

  // Chunks: every one indexed; the index's offsets, sizes and times, and every message index entry
  // pointing at a message of its channel and log time.
  const chunks = records.filter((r) => r.op === OP.CHUNK);
  const indexedOffsets = new Set(indexed.chunkIndexes.map((ci) => Number(ci.chunkStartOffset)));
  for (const ch of chunks) if (!indexedOffsets.has(ch.offset)) problems.push(`chunk at ${ch.offset} has no Chunk Index`);
  let entriesChecked = 0;
  let sorted = true;
  for (const ci of indexed.chunkIndexes) {
    const where = `chunk index -> ${ci.chunkStartOffset}`;
    const i = byOffset.get(Number(ci.chunkStartOffset));
    if (i === undefined || records[i].op !== OP.CHUNK) { problems.push(`${where}: no chunk there`); continue; }
    const chunk = records[i];
    if (Number(ci.chunkLength) !== chunk.length) problems.push(`${where}: chunk_length ${ci.chunkLength}, the record is ${chunk.length}`);
    const c = new Cursor(chunk.content);
    const start = c.u64(), endTime = c.u64(), uncompressedSize = c.u64(), crc = c.u32();
    const compression = c.str();
    const compressed = c.raw(Number(c.u64()));
    if (compression !== ci.compression || BigInt(compressed.length) !== ci.compressedSize || uncompressedSize !== ci.uncompressedSize) {
      problems.push(`${where}: compression/sizes differ from the chunk's`);
    }
    const data = compression === "" ? compressed : compression === "zstd" ? fzstd.decompress(compressed) : null;
    if (!data) { problems.push(`${where}: compression ${compression} unknown to the checker`); continue; }
    if (BigInt(data.length) !== uncompressedSize) problems.push(`${where}: ${data.length} bytes uncompressed, the chunk says ${uncompressedSize}`);
    if (crc !== 0 && crc32(data) !== crc) problems.push(`${where}: records CRC wrong`);
    const inner = walkRecords(data, 0, data.length, problems, where).records;
    const messages = new Map(inner.filter((r) => r.op === OP.MESSAGE).map((r) => {
      const m = new Cursor(r.content);
      return [r.offset, { channelId: m.u16(), sequence: m.u32(), logTime: m.u64() }];
    }));
    const times = [...messages.values()].map((m) => m.logTime);
    const minT = times.length ? times.reduce((a, b) => (b < a ? b : a)) : 0n;
    const maxT = times.length ? times.reduce((a, b) => (b > a ? b : a)) : 0n;
    if (start !== minT || endTime !== maxT || ci.messageStartTime !== minT || ci.messageEndTime !== maxT) {
      problems.push(`${where}: times ${start}..${endTime} (index ${ci.messageStartTime}..${ci.messageEndTime}), messages ${minT}..${maxT}`);
    }
    // The message index records right after the chunk.
    let pos = chunk.offset + chunk.length;
    let indexBytes = 0;
    const seen = new Set();
    while (byOffset.has(pos) && records[byOffset.get(pos)].op === OP.MESSAGE_INDEX) {
      const r = records[byOffset.get(pos)];
      const m = new Cursor(r.content);
      const channelId = m.u16();
      const n = m.u32() / 16;
      if (ci.messageIndexOffsets.get(channelId) !== BigInt(r.offset)) problems.push(`${where}: message_index_offsets[${channelId}] is ${ci.messageIndexOffsets.get(channelId)}, the record is at ${r.offset}`);
      let prev = 0n;
      for (let k = 0; k < n; k++) {
        const t = m.u64();
        const off = Number(m.u64());
        const msg = messages.get(off);
        entriesChecked++;
        if (t < prev) sorted = false;
        prev = t;
        if (!msg || msg.channelId !== channelId || msg.logTime !== t || seen.has(off)) {
          problems.push(`${where}: message index entry (${t}, ${off}) of channel ${channelId} matches no message`);
        }
        seen.add(off);
      }
      indexBytes += r.length;
      pos += r.length;
    }
    if (BigInt(indexBytes) !== ci.messageIndexLength) problems.push(`${where}: message_index_length ${ci.messageIndexLength}, the records take ${indexBytes}`);
    if (seen.size !== messages.size) problems.push(`${where}: ${messages.size} messages, ${seen.size} indexed`);
  }
  if (!sorted) problems.push("message index entries not sorted by log time");
  out.messageIndexEntriesChecked = entriesChecked;
  out.messageIndexSorted = sorted;
  for (const mi of indexed.metadataIndexes) {
    const i = byOffset.get(Number(mi.offset));
    if (i === undefined || records[i].op !== OP.METADATA || records[i].length !== Number(mi.length) ||
        new Cursor(records[i].content).str() !== mi.name) {
      problems.push(`metadata index ${mi.name} -> ${mi.offset}+${mi.length}: no such Metadata record`);
    }
  }
  out.topLevelRecords = {};
  for (const r of records) out.topLevelRecords[hex(r.op)] = (out.topLevelRecords[hex(r.op)] ?? 0) + 1;
  return out;
}

function statisticsProblems(stats, stream, problems) {
  if (!stats) return;
  const expect = (name, got, want) => {
    if (BigInt(got) !== BigInt(want)) problems.push(`Statistics.${name} ${got}, the file holds ${want}`);
  };
  const messageCount = [...stream.topics.values()].reduce((a, t) => a + t.count, 0);
  expect("messageCount", stats.messageCount, messageCount);
  expect("schemaCount", stats.schemaCount, stream.schemas.size);
  expect("channelCount", stats.channelCount, stream.channels.size);
  expect("chunkCount", stats.chunkCount, stream.counts.Chunk ?? 0);
  expect("metadataCount", stats.metadataCount, stream.counts.Metadata ?? 0);
  expect("attachmentCount", stats.attachmentCount, stream.counts.Attachment ?? 0);
  const times = [...stream.topics.values()].filter((t) => t.count);
  const min = times.length ? times.map((t) => t.min).reduce((a, b) => (b < a ? b : a)) : 0n;
  const max = times.length ? times.map((t) => t.max).reduce((a, b) => (b > a ? b : a)) : 0n;
  expect("messageStartTime", stats.messageStartTime, min);
  expect("messageEndTime", stats.messageEndTime, max);
  if (stats.channelMessageCounts.size) {
    for (const [id, ch] of stream.channels) {
      const want = stream.topics.get(ch.topic)?.count ?? 0;
      expect(`channelMessageCounts[${id}]`, stats.channelMessageCounts.get(id) ?? 0n, want);
    }
  }
}

async function main() {
  const args = process.argv.slice(2);
  const path = args.find((a) => !a.startsWith("--"));
  const unknown = args.filter((a) => a.startsWith("--") && a !== "--validate-foxglove" && a !== "--messages");
  if (!path || unknown.length) usage(unknown.length ? `unknown option ${unknown[0]}` : "no file");
  const validate = args.includes("--validate-foxglove");
  const keepList = args.includes("--messages");

  let bytes;
  try {
    bytes = new Uint8Array(fs.readFileSync(path));
  } catch (e) {
    process.stderr.write(`${path}: ${e.message}\n`);
    process.exit(1);
  }
  const problems = [];
  let indexed;
  let stream;
  const validator = validate ? new Validator() : null;
  try {
    indexed = await readIndexed(path, keepList, problems);
  } catch (e) {
    process.stderr.write(`${path}: McapIndexedReader: ${e.message}\n`);
    process.exit(1);
  }
  try {
    stream = readStream(bytes, validator);
  } catch (e) {
    process.stderr.write(`${path}: McapStreamReader: ${e.message}\n`);
    process.exit(1);
  }
  const r = indexed.reader;
  let structure = {};
  try {
    structure = checkStructure(bytes, r, problems);
  } catch (e) {
    problems.push(`structure: ${e.message}`);
  }
  statisticsProblems(r.statistics, stream, problems);

  const topicsOf = (tallies) => {
    const o = {};
    for (const [topic, t] of [...tallies].sort(([a], [b]) => (a < b ? -1 : a > b ? 1 : 0))) o[topic] = t.summary();
    return o;
  };
  const indexedTopics = topicsOf(indexed.topics);
  const streamTopics = topicsOf(stream.topics);
  const agree = JSON.stringify(indexedTopics, (_k, v) => (typeof v === "bigint" ? String(v) : v)) ===
    JSON.stringify(streamTopics, (_k, v) => (typeof v === "bigint" ? String(v) : v));
  if (!agree) problems.push("the indexed and the stream reader read different messages");
  const metadataAgree = JSON.stringify(indexed.metadata) === JSON.stringify(stream.metadata);
  if (!metadataAgree) problems.push("the indexed and the stream reader read different metadata");

  const schemaName = (id) => r.schemasById.get(id)?.name ?? null;
  const result = {
    file: path,
    sizeBytes: bytes.length,
    header: { profile: r.header.profile, library: r.header.library },
    schemas: [...r.schemasById.values()].map((s) => ({
      id: s.id, name: s.name, encoding: s.encoding, dataBytes: s.data.length, matchesOfficial: matchesOfficial(s),
    })),
    channels: [...r.channelsById.values()].map((c) => ({
      id: c.id, topic: c.topic, schemaId: c.schemaId, schemaName: schemaName(c.schemaId),
      messageEncoding: c.messageEncoding, metadata: mapToObject(c.metadata),
    })),
    statistics: r.statistics ? {
      messageCount: r.statistics.messageCount, schemaCount: r.statistics.schemaCount,
      channelCount: r.statistics.channelCount, attachmentCount: r.statistics.attachmentCount,
      metadataCount: r.statistics.metadataCount, chunkCount: r.statistics.chunkCount,
      messageStartTime: r.statistics.messageStartTime, messageEndTime: r.statistics.messageEndTime,
      channelMessageCounts: mapToObject(r.statistics.channelMessageCounts),
    } : null,
    chunkIndexes: {
      count: r.chunkIndexes.length,
      compression: r.chunkIndexes.reduce((o, ci) => ({ ...o, [ci.compression]: (o[ci.compression] ?? 0) + 1 }), {}),
      compressedBytes: r.chunkIndexes.reduce((a, ci) => a + ci.compressedSize, 0n),
      uncompressedBytes: r.chunkIndexes.reduce((a, ci) => a + ci.uncompressedSize, 0n),
      uncompressedSizes: r.chunkIndexes.map((ci) => ci.uncompressedSize),
    },
    summaryOffsets: structure.summaryOffsets ?? {},
    dataSectionCrc: structure.dataSectionCrc ?? null,
    summaryCrc: structure.summaryCrc ?? null,
    messageIndexEntriesChecked: structure.messageIndexEntriesChecked ?? 0,
    messageIndexSorted: structure.messageIndexSorted ?? false,
    topLevelRecords: structure.topLevelRecords ?? {},
    streamRecords: stream.counts,
    metadata: indexed.metadata,
    indexed: { topics: indexedTopics },
    stream: { topics: streamTopics },
    firstLastLogTime: Object.fromEntries([...indexed.topics].map(([topic, t]) => [topic, { first: t.first, last: t.last }])),
    agree: agree && metadataAgree,
    problems,
  };
  if (keepList) {
    result.messages = Object.fromEntries([...indexed.topics].map(([topic, t]) => [topic, t.list.slice().sort((a, b) => a.sequence - b.sequence)]));
  }
  let invalid = 0;
  if (validator) {
    result.validation = Object.fromEntries(validator.byTopic);
    invalid = [...validator.byTopic.values()].reduce((a, t) => a + t.invalid, 0);
  }
  process.stdout.write(`${stringifyExact(result)}\n`);
  if (problems.length) {
    process.stderr.write(`${path}: ${problems.length} problem(s):\n  ${problems.slice(0, 20).join("\n  ")}\n`);
    process.exit(1);
  }
  if (invalid) {
    const first = [...validator.byTopic].find(([, t]) => t.invalid);
    process.stderr.write(`${path}: ${invalid} message(s) invalid; ${first[0]}: ${first[1].firstError}\n`);
    process.exit(3);
  }
}

main().catch((e) => {
  process.stderr.write(`mcap_summary: ${e.stack || e.message}\n`);
  process.exit(1);
});
