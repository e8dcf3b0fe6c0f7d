// The MCAP writer against an independent reader (test/js/mcap_summary.js: @mcap/core's indexed
// and stream readers plus its own walk of offsets and CRCs), and byte for byte where the spec
// fixes the bytes: magic, footer, Data End, the empty file.
#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "support/error_of.hpp"
#include "support/mcap_check.hpp"
#include "tools/mcap/mcap_writer.hpp"

namespace {

using ptz::mcap::Writer;
using ptz::mcap::WriterOptions;

constexpr uint64_t kBaseNs = 1'700'000'000'123'456'789ull;  // above 2^53: exact u64s or bust
constexpr uint64_t kMsNs = 1'000'000;
constexpr size_t kChunkBytes = 4096;

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

uint64_t le(const std::string& b, size_t at, size_t n) {
  uint64_t v = 0;
  for (size_t i = 0; i < n; ++i) v |= uint64_t(static_cast<unsigned char>(b.at(at + i))) << (8 * i);
  return v;
}

uint32_t crcOf(const std::string& b, size_t from, size_t to) {
  return static_cast<uint32_t>(
      crc32(0, reinterpret_cast<const Bytef*>(b.data() + from), static_cast<uInt>(to - from)));
}

struct Expected {
  uint64_t sequence, log_ns, publish_ns, size;
  uint32_t crc;
};

// The reference file: 2 schemas, 3 channels with messages and one without, 300 + 151 + 50
// messages over many 4 KiB chunks, every 10th log time 3 ms early (out of order), a 10 KB message
// bigger than a chunk, a metadata record.
struct Reference {
  std::map<std::string, std::vector<Expected>> by_topic;
  uint64_t min_ns = UINT64_MAX, max_ns = 0;
  uint32_t chunks = 0;
  uint64_t bytes = 0;
};

const char* kSampleSchema =
    R"({"type":"object","properties":{"seq":{"type":"integer"},"value":{"type":"number"},)"
    R"("pad":{"type":"string"}},"required":["seq","value"]})";

Reference writeReference(const std::string& path, const std::string& compression) {
  WriterOptions opts;
  opts.compression = compression;
  opts.chunk_size_bytes = kChunkBytes;
  opts.profile = "x-ptzstereo-test";
  Writer w(path, opts);
  const uint16_t sample = w.addSchema("ptz.Sample", "jsonschema", kSampleSchema);
  const uint16_t log = w.addSchema("foxglove.Log", "jsonschema", R"({"type":"object"})");
  const uint16_t a = w.addChannel(sample, "/sample/a", "json");
  const uint16_t b = w.addChannel(sample, "/sample/b", "json", {{"rate_hz", "30"}, {"side", "L"}});
  const uint16_t l = w.addChannel(log, "/log", "json");
  w.addChannel(0, "/never", "x-raw");
  w.addMetadata("run", {{"rig", "bench"}, {"operator", "test"}});

  Reference ref;
  std::map<uint16_t, uint64_t> seq;
  std::map<uint16_t, std::string> topic{{a, "/sample/a"}, {b, "/sample/b"}, {l, "/log"}};
  auto put = [&](uint16_t ch, uint64_t log_ns, const std::string& data) {
    const uint64_t publish_ns = log_ns - 500'000;
    w.write(ch, log_ns, publish_ns, data.data(), data.size());
    ref.by_topic[topic[ch]].push_back(
        {seq[ch]++, log_ns, publish_ns, data.size(), crcOf(data, 0, data.size())});
    ref.min_ns = std::min(ref.min_ns, log_ns);
    ref.max_ns = std::max(ref.max_ns, log_ns);
  };
  for (int i = 0; i < 300; ++i) {
    // The second message is the earliest; the last written is not the latest.
    const uint64_t t = i == 1 ? kBaseNs - 5 * kMsNs
                              : kBaseNs + uint64_t(i) * kMsNs - (i % 10 == 9 ? 3 * kMsNs : 0);
    put(a, t, R"({"seq":)" + std::to_string(i) + R"(,"value":)" + std::to_string(i * 0.5) + "}");
    if (i % 2 == 0) {
      put(b, t + 100, R"({"seq":)" + std::to_string(i) + R"(,"value":-1.25})");
    }
    if (i % 6 == 0) {
      put(l, t + 200,
          R"({"timestamp":{"sec":1700000000,"nsec":)" + std::to_string(i) +
              R"(},"level":2,"message":"step )" + std::to_string(i) +
              R"(","name":"test","file":"test_mcap_writer.cpp","line":)" + std::to_string(i + 1) +
              "}");
    }
    if (i == 150) {
      put(b, t + 300, R"({"seq":-1,"value":0,"pad":")" + std::string(10000, 'x') + R"("})");
    }
  }
  w.close();
  ref.chunks = w.chunkCount();
  ref.bytes = w.bytesWritten();
  EXPECT_EQ(w.messageCount(), 501u);
  EXPECT_EQ(w.messageCount(b), 151u);
  return ref;
}

class McapWriterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/ptz_mcap_test_XXXXXX";
    ASSERT_NE(mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string dir_;
};

// Everything the checker reads back equals what was written.
void expectReadsBack(const ptz::test::McapSummary& s, const Reference& ref,
                     const std::string& compression) {
  ASSERT_EQ(s.exit_code, 0) << s.err;
  const auto& j = s.json;
  ASSERT_TRUE(j.is_object()) << s.err;
  EXPECT_EQ(j["header"]["profile"], "x-ptzstereo-test");
  EXPECT_EQ(j["header"]["library"], "ptzstereo");
  EXPECT_EQ(j["sizeBytes"].get<uint64_t>(), ref.bytes);
  ASSERT_EQ(j["schemas"].size(), 2u);
  EXPECT_EQ(j["schemas"][0]["name"], "ptz.Sample");
  EXPECT_EQ(j["schemas"][1]["name"], "foxglove.Log");
  EXPECT_EQ(j["schemas"][0]["dataBytes"].get<size_t>(), std::string(kSampleSchema).size());
  EXPECT_TRUE(j["schemas"][0]["matchesOfficial"].is_null());
  EXPECT_EQ(j["schemas"][1]["matchesOfficial"], false);  // {"type":"object"} is not Foxglove's Log
  ASSERT_EQ(j["channels"].size(), 4u);
  EXPECT_EQ(j["channels"][1]["topic"], "/sample/b");
  EXPECT_EQ(j["channels"][1]["schemaName"], "ptz.Sample");
  EXPECT_EQ(j["channels"][1]["metadata"], (nlohmann::json{{"rate_hz", "30"}, {"side", "L"}}));
  EXPECT_EQ(j["channels"][3]["topic"], "/never");
  EXPECT_EQ(j["channels"][3]["schemaId"], 0);

  const auto& st = j["statistics"];
  EXPECT_EQ(st["messageCount"].get<uint64_t>(), 501u);
  EXPECT_EQ(st["schemaCount"], 2);
  EXPECT_EQ(st["channelCount"], 4);
  EXPECT_EQ(st["metadataCount"], 1);
  EXPECT_EQ(st["attachmentCount"], 0);
  EXPECT_EQ(st["chunkCount"].get<uint32_t>(), ref.chunks);
  EXPECT_GE(ref.chunks, 10u);  // 501 messages in 4 KiB chunks
  EXPECT_EQ(st["messageStartTime"].get<uint64_t>(), ref.min_ns);
  EXPECT_EQ(st["messageEndTime"].get<uint64_t>(), ref.max_ns);
  EXPECT_EQ(st["channelMessageCounts"], (nlohmann::json{{"1", 300}, {"2", 151}, {"3", 50}}));

  EXPECT_EQ(j["chunkIndexes"]["count"].get<uint32_t>(), ref.chunks);
  EXPECT_EQ(j["chunkIndexes"]["compression"], (nlohmann::json{{compression, ref.chunks}}));
  for (const char* op : {"0x03", "0x04", "0x0b", "0x08", "0x0d"}) {
    EXPECT_TRUE(j["summaryOffsets"].contains(op)) << op;
    EXPECT_EQ(j["summaryOffsets"][op]["ok"], true) << op;
  }
  EXPECT_EQ(j["summaryOffsets"]["0x08"]["records"].get<uint32_t>(), ref.chunks);
  // Chunks stay within 4 KiB but for the 10 KB message's own (its record and JSON around it).
  int big_chunks = 0;
  for (const auto& size : j["chunkIndexes"]["uncompressedSizes"]) {
    if (size.get<uint64_t>() <= kChunkBytes) continue;
    ++big_chunks;
    EXPECT_LT(size.get<uint64_t>(), 10000u + 100) << "the big message shares its chunk";
  }
  EXPECT_EQ(big_chunks, 1);
  EXPECT_EQ(j["dataSectionCrc"]["ok"], true);
  EXPECT_NE(j["dataSectionCrc"]["stored"], 0);
  EXPECT_EQ(j["summaryCrc"]["ok"], true);
  EXPECT_EQ(j["messageIndexSorted"], true);
  EXPECT_EQ(j["messageIndexEntriesChecked"], 501);
  EXPECT_EQ(j["agree"], true);
  EXPECT_EQ(j["problems"].size(), 0u);
  EXPECT_EQ(
      j["metadata"],
      (nlohmann::json::parse(R"([{"name":"run","metadata":{"operator":"test","rig":"bench"}}])")));

  for (const auto& [topic, msgs] : ref.by_topic) {
    SCOPED_TRACE(topic);
    uint64_t min_ns = UINT64_MAX, max_ns = 0;
    for (const auto& m : msgs)
      min_ns = std::min(min_ns, m.log_ns), max_ns = std::max(max_ns, m.log_ns);
    for (const char* reader : {"indexed", "stream"}) {
      const auto& t = j[reader]["topics"][topic];
      EXPECT_EQ(t["count"].get<size_t>(), msgs.size()) << reader;
      EXPECT_EQ(t["minLogTime"].get<uint64_t>(), min_ns) << reader;
      EXPECT_EQ(t["maxLogTime"].get<uint64_t>(), max_ns) << reader;
    }
    // The indexed reader yields by log time.
    EXPECT_EQ(j["firstLastLogTime"][topic]["first"].get<uint64_t>(), min_ns);
    EXPECT_EQ(j["firstLastLogTime"][topic]["last"].get<uint64_t>(), max_ns);
    const auto& got = j["messages"][topic];
    ASSERT_EQ(got.size(), msgs.size());
    for (size_t i = 0; i < msgs.size(); ++i) {
      const auto& g = got[i];
      ASSERT_EQ(g["sequence"].get<uint64_t>(), msgs[i].sequence) << i;
      EXPECT_EQ(g["logTime"].get<uint64_t>(), msgs[i].log_ns) << i;
      EXPECT_EQ(g["publishTime"].get<uint64_t>(), msgs[i].publish_ns) << i;
      EXPECT_EQ(g["size"].get<uint64_t>(), msgs[i].size) << i;
      EXPECT_EQ(g["crc32"].get<uint32_t>(), msgs[i].crc) << i;
    }
  }
  // Foxglove's official schema for /log, the file's own for the samples.
  const auto& v = j["validation"];
  EXPECT_EQ(v["/log"]["checked"], 50);
  EXPECT_EQ(v["/sample/a"]["checked"], 300);
  EXPECT_EQ(v["/sample/b"]["checked"], 151);
  for (const char* topic : {"/log", "/sample/a", "/sample/b"}) {
    EXPECT_EQ(v[topic]["invalid"], 0) << topic << ": " << v[topic]["firstError"];
  }
}

TEST_F(McapWriterTest, ZstdFileReadsBackExactly) {
  PTZ_REQUIRE_JS();
  const std::string path = dir_ + "/zstd.mcap";
  const Reference ref = writeReference(path, "zstd");
  const auto s = ptz::test::summarizeMcap(path, true, true);
  expectReadsBack(s, ref, "zstd");
  // Compression did something: the JSON samples shrink.
  EXPECT_LT(s.json["chunkIndexes"]["compressedBytes"].get<uint64_t>(),
            s.json["chunkIndexes"]["uncompressedBytes"].get<uint64_t>() / 2);
}

TEST_F(McapWriterTest, UncompressedFileReadsBackTheSameMessages) {
  PTZ_REQUIRE_JS();
  const std::string raw_path = dir_ + "/raw.mcap", zstd_path = dir_ + "/zstd.mcap";
  const Reference ref = writeReference(raw_path, "");
  writeReference(zstd_path, "zstd");
  const auto raw = ptz::test::summarizeMcap(raw_path, true, true);
  expectReadsBack(raw, ref, "");
  const auto zstd = ptz::test::summarizeMcap(zstd_path);
  ASSERT_EQ(zstd.exit_code, 0) << zstd.err;
  EXPECT_EQ(raw.json["indexed"], zstd.json["indexed"]);  // counts, times and digests per topic
  EXPECT_EQ(raw.json["chunkIndexes"]["compressedBytes"],
            raw.json["chunkIndexes"]["uncompressedBytes"]);
}

// What the spec fixes to the byte: magic, header, footer offsets and CRCs, Data End's CRC.
TEST_F(McapWriterTest, FooterDataEndAndCrcsPointAtTheRightBytes) {
  const std::string path = dir_ + "/bytes.mcap";
  const Reference ref = writeReference(path, "zstd");
  const std::string f = slurp(path);
  ASSERT_EQ(f.size(), ref.bytes);
  const std::string magic("\x89MCAP0\r\n", 8);
  EXPECT_EQ(f.substr(0, 8), magic);
  EXPECT_EQ(f.substr(f.size() - 8), magic);
  // Header: op 1, then profile and library strings.
  EXPECT_EQ(f[8], 0x01);
  const uint64_t header_len = le(f, 9, 8);
  EXPECT_EQ(le(f, 17, 4), 16u);
  EXPECT_EQ(f.substr(21, 16), "x-ptzstereo-test");
  EXPECT_EQ(le(f, 37, 4), 9u);
  EXPECT_EQ(f.substr(41, 9), "ptzstereo");
  EXPECT_EQ(header_len, 4u + 16 + 4 + 9);
  // Footer: op 2, length 20, summary_start, summary_offset_start, summary_crc.
  const size_t footer = f.size() - 8 - 29;
  ASSERT_EQ(f[footer], 0x02);
  EXPECT_EQ(le(f, footer + 1, 8), 20u);
  const uint64_t summary_start = le(f, footer + 9, 8);
  const uint64_t summary_offset_start = le(f, footer + 17, 8);
  const uint32_t summary_crc = static_cast<uint32_t>(le(f, footer + 25, 4));
  // Data End (13 bytes) right before the summary; its CRC covers every byte before it.
  const size_t data_end = summary_start - 13;
  ASSERT_EQ(f[data_end], 0x0F);
  EXPECT_EQ(le(f, data_end + 1, 8), 4u);
  EXPECT_EQ(le(f, data_end + 9, 4), crcOf(f, 0, data_end));
  EXPECT_EQ(f[summary_start], 0x03);  // the summary opens with the schemas
  EXPECT_EQ(f[summary_offset_start], 0x0E);
  // Summary offsets: 5 groups of 26 bytes between summary_offset_start and the footer.
  EXPECT_EQ(footer - summary_offset_start, 5u * 26);
  for (size_t at = summary_offset_start; at < footer; at += 26) {
    EXPECT_EQ(f[at], 0x0E);
    const uint64_t group_start = le(f, at + 10, 8);
    EXPECT_EQ(static_cast<uint8_t>(f[group_start]), static_cast<uint8_t>(f[at + 9]));
  }
  // The summary CRC: from the summary's start through summary_offset_start in the footer.
  EXPECT_EQ(summary_crc, crcOf(f, summary_start, footer + 25));
}

// Closed with nothing written: still a valid, indexed MCAP, of exactly the spec's bytes: magic 8,
// header 9+4+0+4+9, Data End 13, Statistics 9+46, one Summary Offset 9+17, footer 29, magic 8.
TEST_F(McapWriterTest, EmptyFileIsValid) {
  const std::string path = dir_ + "/empty.mcap";
  {
    Writer w(path);
    w.close();
    EXPECT_EQ(w.bytesWritten(), 165u);
  }
  EXPECT_EQ(slurp(path).size(), 165u);
  PTZ_REQUIRE_JS();
  const auto s = ptz::test::summarizeMcap(path, true);
  ASSERT_EQ(s.exit_code, 0) << s.err;
  EXPECT_EQ(s.json["statistics"]["messageCount"], 0);
  EXPECT_EQ(s.json["statistics"]["chunkCount"], 0);
  EXPECT_EQ(s.json["statistics"]["messageStartTime"], 0);
  EXPECT_EQ(s.json["chunkIndexes"]["count"], 0);
  EXPECT_EQ(s.json["summaryOffsets"].size(), 1u);
  EXPECT_EQ(s.json["dataSectionCrc"]["ok"], true);
  EXPECT_EQ(s.json["agree"], true);
}

// A writer left to its destructor still closes the file properly.
TEST_F(McapWriterTest, DestructorCloses) {
  const std::string path = dir_ + "/dtor.mcap";
  {
    Writer w(path, WriterOptions{"zstd", 3, 256});
    const uint16_t ch = w.addChannel(0, "/raw", "x-raw");
    for (uint32_t i = 0; i < 40; ++i) w.write(ch, 1000 + i, 1000 + i, &i, sizeof i);
  }
  PTZ_REQUIRE_JS();
  const auto s = ptz::test::summarizeMcap(path);
  ASSERT_EQ(s.exit_code, 0) << s.err;
  EXPECT_EQ(s.json["indexed"]["topics"]["/raw"]["count"], 40);
  EXPECT_GT(s.json["statistics"]["chunkCount"], 1);
}

TEST_F(McapWriterTest, MissingFolderIsAnErrorNamingThePath) {
  const std::string path = dir_ + "/no/such/folder/out.mcap";
  const std::string err = ptz::test::errorOf([&] { Writer w(path); });
  EXPECT_NE(err.find(path), std::string::npos) << err;
  EXPECT_NE(err.find("No such file or directory"), std::string::npos) << err;
  const std::string dir_err = ptz::test::errorOf([&] { Writer w(dir_); });
  EXPECT_NE(dir_err.find(dir_ + ": Is a directory"), std::string::npos) << dir_err;
}

TEST_F(McapWriterTest, FullDiskIsAnErrorNamingThePath) {
  // Linux always has it (the project is Linux only): its absence is a broken machine, no skip.
  ASSERT_EQ(access("/dev/full", W_OK), 0) << "no writable /dev/full";
  const std::string err = ptz::test::errorOf([&] { Writer w("/dev/full"); });
  EXPECT_NE(err.find("/dev/full"), std::string::npos) << err;
  EXPECT_NE(err.find("No space left on device"), std::string::npos) << err;
}

TEST_F(McapWriterTest, BadCallsAreErrors) {
  EXPECT_THROW(Writer(dir_ + "/x.mcap", WriterOptions{"lz4"}), std::invalid_argument);
  EXPECT_THROW(Writer(dir_ + "/x.mcap", WriterOptions{"zstd", 99}), std::invalid_argument);
  Writer w(dir_ + "/bad.mcap");
  EXPECT_NE(ptz::test::errorOf([&] { w.addChannel(7, "/t", "json"); }).find("schema id 7"),
            std::string::npos);
  const char byte = 1;
  EXPECT_NE(ptz::test::errorOf([&] { w.write(3, 0, 0, &byte, 1); }).find("channel id 3"),
            std::string::npos);
  for (int i = 0; i < 65535; ++i) w.addSchema("s", "", "");
  EXPECT_NE(ptz::test::errorOf([&] { w.addSchema("s", "", ""); }).find("no schema id left"),
            std::string::npos);
  for (int i = 0; i < 65535; ++i) w.addChannel(0, "c", "x");
  EXPECT_NE(ptz::test::errorOf([&] { w.addChannel(0, "c", "x"); }).find("no channel id left"),
            std::string::npos);
  w.close();
  EXPECT_THROW(w.write(1, 0, 0, &byte, 1), std::runtime_error);
}

// The checker has teeth: a flipped byte in a chunk, or in Data End's CRC, fails it.
TEST_F(McapWriterTest, CheckerRejectsDamagedFiles) {
  PTZ_REQUIRE_JS();
  const std::string path = dir_ + "/raw.mcap";
  writeReference(path, "");
  const std::string good = slurp(path);
  auto damaged = [&](size_t at, const std::string& name) {
    std::string f = good;
    f[at] = static_cast<char>(f[at] ^ 0x20);
    const std::string p = dir_ + "/" + name;
    std::ofstream(p, std::ios::binary) << f;
    return ptz::test::summarizeMcap(p);
  };
  // The first chunk's records, well inside (the first message's JSON).
  const size_t first_chunk = good.find(std::string("{\"seq\":0"));
  ASSERT_NE(first_chunk, std::string::npos);
  const auto chunk = damaged(first_chunk + 3, "chunk.mcap");
  EXPECT_EQ(chunk.exit_code, 1);
  EXPECT_NE(chunk.err.find("CRC"), std::string::npos) << chunk.err;
  const size_t summary_start = le(good, good.size() - 8 - 29 + 9, 8);
  const auto crc = damaged(summary_start - 2, "dataend.mcap");
  EXPECT_EQ(crc.exit_code, 1);
  EXPECT_NE(crc.err.find("Data End CRC"), std::string::npos) << crc.err;
}

// Validation is real: a foxglove.Log with a level outside its enum, a CompressedImage whose data
// is not base64, a sample missing a required field.
TEST_F(McapWriterTest, CheckerRejectsInvalidMessages) {
  PTZ_REQUIRE_JS();
  const std::string path = dir_ + "/invalid.mcap";
  // Foxglove's own Log schema, as @foxglove/schemas has it, embedded in the file.
  const auto official = ptz::test::runProgram(
      {ptz::test::nodePath(), "-e",
       "process.stdout.write(JSON.stringify(require(process.argv[1]).Log))",
       ptz::test::jsCheckersDir() + "/node_modules/@foxglove/schemas/jsonschema"});
  ASSERT_EQ(official.exit_code, 0) << official.err;
  {
    Writer w(path);
    const uint16_t log =
        w.addChannel(w.addSchema("foxglove.Log", "jsonschema", official.out), "/log", "json");
    const uint16_t img =
        w.addChannel(w.addSchema("foxglove.CompressedImage", "jsonschema", "{}"), "/img", "json");
    const uint16_t sample =
        w.addChannel(w.addSchema("ptz.Sample", "jsonschema", kSampleSchema), "/s", "json");
    const std::string bad_log =
        R"({"timestamp":{"sec":1,"nsec":2},"level":9,"message":"m","name":"n","file":"f","line":1})";
    const std::string bad_img =
        R"({"timestamp":{"sec":1,"nsec":2},"frame_id":"cam","data":"not base64!","format":"jpeg"})";
    const std::string good_img =
        R"({"timestamp":{"sec":1,"nsec":2},"frame_id":"cam","data":"/9j/4A==","format":"jpeg"})";
    const std::string bad_sample = R"({"seq":1})";
    w.write(log, 1, 1, bad_log.data(), bad_log.size());
    w.write(img, 2, 2, bad_img.data(), bad_img.size());
    w.write(img, 3, 3, good_img.data(), good_img.size());
    w.write(sample, 4, 4, bad_sample.data(), bad_sample.size());
    w.close();
  }
  const auto s = ptz::test::summarizeMcap(path, true);
  EXPECT_EQ(s.exit_code, 3) << s.err;
  EXPECT_EQ(s.json["schemas"][0]["matchesOfficial"], true);
  EXPECT_EQ(s.json["schemas"][1]["matchesOfficial"], false);  // "{}"
  const auto& v = s.json["validation"];
  EXPECT_EQ(v["/log"]["invalid"], 1);
  EXPECT_EQ(v["/img"]["checked"], 2);
  EXPECT_EQ(v["/img"]["invalid"], 1);
  EXPECT_NE(v["/img"]["firstError"].get<std::string>().find("base64"), std::string::npos);
  EXPECT_EQ(v["/s"]["invalid"], 1);
  EXPECT_NE(v["/s"]["firstError"].get<std::string>().find("value"), std::string::npos);
}

}  // namespace
