// ptz-mcap on the replay fixture, read back by an independent reader (@mcap/core, both its
// indexed and its stream reader, test/js/mcap_summary.js): every topic with the count its LCM
// channel implies, Foxglove's own schemas satisfied, chunk and message indexes and the summary
// CRC-checked, the run's numbers; and on bad input an exit code and no file.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <map>
#include <string>

#include "support/mcap_check.hpp"
#include "support/run_program.hpp"
#include "tools/logs/log_reader.hpp"
#include "tools/mcap_export/exporter.hpp"

using nlohmann::json;

namespace {

const std::string kFixture = PTZ_SOURCE_DIR "/test/fixtures/closed_loop_2s.lcmlog";

std::string tempPath(const std::string& name) {
  return "/tmp/ptz_mcap_export_" + std::to_string(getpid()) + "_" + name;
}

std::map<std::string, int64_t> lcmCounts(const std::string& path) {
  ptz::tools::LogReader log(path);
  while (log.next()) {
  }
  return log.channelEvents();
}

int64_t count(const std::map<std::string, int64_t>& counts, const std::string& channel) {
  const auto it = counts.find(channel);
  return it == counts.end() ? 0 : it->second;
}

}  // namespace

TEST(McapExport, TheFixtureReadsBackWithEveryTopicCountedAndFoxglovesSchemasSatisfied) {
  PTZ_REQUIRE_JS();
  const std::string out = tempPath("fixture.mcap");
  const auto run = ptz::test::runProgram({PTZ_MCAP_BIN, "--log", kFixture, "--out", out,
                                          "--chunk_size_kb", "512", "--settle_s", "0.5"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const ptz::test::McapSummary s = ptz::test::summarizeMcap(out, /*validate_foxglove=*/true);
  ASSERT_EQ(s.exit_code, 0) << s.err;
  const json& j = s.json;
  EXPECT_EQ(j["header"]["library"], "ptzstereo");
  EXPECT_TRUE(j["agree"].get<bool>()) << j["problems"].dump();
  EXPECT_TRUE(j["dataSectionCrc"]["ok"].get<bool>());
  EXPECT_TRUE(j["summaryCrc"]["ok"].get<bool>());
  EXPECT_TRUE(j["messageIndexSorted"].get<bool>());
  // 8.2 MB of log in chunks of 512 kB: several chunks, each indexed, zstd.
  EXPECT_GE(j["chunkIndexes"]["count"].get<int>(), 5);
  EXPECT_EQ(j["chunkIndexes"]["compression"]["zstd"], j["chunkIndexes"]["count"]);
  for (const char* group : {"0x03", "0x04", "0x0b", "0x08", "0x0d"}) {
    EXPECT_TRUE(j["summaryOffsets"][group]["ok"].get<bool>()) << group;
  }

  // Each topic's count from the LCM channels it comes from.
  const auto lcm = lcmCounts(kFixture);
  const int64_t frames = count(lcm, "STEREO_FRAME");
  ASSERT_GT(frames, 50);
  const std::map<std::string, int64_t> expected = {
      {"/left/image", frames},
      {"/right/image", frames},
      {"/left/camera_info", frames},
      {"/right/camera_info", frames},
      {"/tf", frames + count(lcm, "PTZ_STATE")},
      {"/ptz_state", count(lcm, "PTZ_STATE")},
      {"/ptz_setpoint", count(lcm, "PTZ_SETPOINT")},
      {"/control_state", count(lcm, "CONTROL_STATE")},
      {"/object_detections", count(lcm, "OBJECT_DETECTIONS")},
      {"/left/detections", count(lcm, "OBJECT_DETECTIONS")},
      {"/object_pose", count(lcm, "OBJECT_POSE")},
      {"/object_tracks", count(lcm, "OBJECT_TRACKS")},
      {"/objects", count(lcm, "OBJECT_TRACKS")},
      {"/sim_truth", count(lcm, "SIM_TRUTH")},
      {"/truth", count(lcm, "SIM_TRUTH")},
      {"/cloud", count(lcm, "POINT_CLOUD")},
      {"/status/ptz-sim", count(lcm, "PROCESS_STATUS_PTZ_SIM")},
      {"/status/ptz-detect", count(lcm, "PROCESS_STATUS_PTZ_DETECT")},
      {"/run/summary", 1}};
  const json& topics = j["indexed"]["topics"];
  int64_t total = 0;
  for (const auto& [topic, n] : expected) {
    ASSERT_TRUE(topics.contains(topic)) << topic;
    EXPECT_EQ(topics[topic]["count"].get<int64_t>(), n) << topic;
    EXPECT_GT(n, 0) << topic;
  }
  for (auto it = topics.begin(); it != topics.end(); ++it)
    total += it.value()["count"].get<int64_t>();
  EXPECT_EQ(j["statistics"]["messageCount"].get<int64_t>(), total);
  // Centring per frame after the settling time: most frames of the run.
  EXPECT_GT(topics["/run/centering"]["count"].get<int64_t>(), frames / 2);

  // Every message checked, none invalid: Foxglove's published schemas for foxglove.*, the file's
  // own for the project's types.
  std::map<std::string, std::string> schema_of;
  for (const json& c : j["channels"]) schema_of[c["topic"]] = c["schemaName"];
  EXPECT_EQ(schema_of["/left/image"], "foxglove.CompressedImage");
  EXPECT_EQ(schema_of["/left/camera_info"], "foxglove.CameraCalibration");
  EXPECT_EQ(schema_of["/tf"], "foxglove.FrameTransforms");
  EXPECT_EQ(schema_of["/cloud"], "foxglove.PointCloud");
  EXPECT_EQ(schema_of["/objects"], "foxglove.SceneUpdate");
  EXPECT_EQ(schema_of["/left/detections"], "foxglove.ImageAnnotations");
  for (auto it = j["validation"].begin(); it != j["validation"].end(); ++it) {
    EXPECT_GT(it.value()["checked"].get<int64_t>(), 0) << it.key();
    EXPECT_EQ(it.value()["invalid"].get<int64_t>(), 0) << it.key() << ": " << it.value().dump();
  }

  // The run's numbers as the file's metadata, the log named.
  bool summary_found = false;
  for (const json& m : j["metadata"]) {
    if (m["name"] == "run_summary") {
      summary_found = true;
      EXPECT_EQ(m["metadata"]["frames_published"], std::to_string(frames));
      EXPECT_LT(std::stod(m["metadata"]["centering_rms_px"].get<std::string>()), 5.0);
    }
    if (m["name"] == "source") {
      EXPECT_EQ(m["metadata"]["source_log"], kFixture);
    }
  }
  EXPECT_TRUE(summary_found);
  ::unlink(out.c_str());
}

TEST(McapExport, UncompressedWithScaledImagesAndDecimatedClouds) {
  PTZ_REQUIRE_JS();
  const std::string out = tempPath("small.mcap");
  const auto run = ptz::test::runProgram({PTZ_MCAP_BIN, "--log", kFixture, "--out", out,
                                          "--compression", "none", "--image_rate_hz", "10",
                                          "--image_max_width_px", "320", "--cloud_rate_hz", "2"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const ptz::test::McapSummary s = ptz::test::summarizeMcap(out, true);
  ASSERT_EQ(s.exit_code, 0) << s.err;
  EXPECT_EQ(s.json["chunkIndexes"]["compression"][""], s.json["chunkIndexes"]["count"]);
  const auto lcm = lcmCounts(kFixture);
  const int64_t frames = count(lcm, "STEREO_FRAME");
  const json& topics = s.json["indexed"]["topics"];
  // 30 Hz frames at 10 Hz: a third (a frame more or less at the ends).
  EXPECT_NEAR(topics["/left/image"]["count"].get<double>(), frames / 3.0, 1.5);
  EXPECT_EQ(topics["/tf"]["count"].get<int64_t>(), frames + count(lcm, "PTZ_STATE"));
  EXPECT_LE(topics["/cloud"]["count"].get<int64_t>(), 5);  // 2 s at 2 Hz
  EXPECT_GE(topics["/cloud"]["count"].get<int64_t>(), 3);
  for (auto it = s.json["validation"].begin(); it != s.json["validation"].end(); ++it) {
    EXPECT_EQ(it.value()["invalid"].get<int64_t>(), 0) << it.key();
  }
  ::unlink(out.c_str());
}

TEST(McapExport, BadInputHasItsExitCodeAndLeavesNoFile) {
  const std::string out = tempPath("bad.mcap");
  auto run = ptz::test::runProgram({PTZ_MCAP_BIN, "--log", "/nonexistent.lcmlog", "--out", out});
  EXPECT_EQ(run.exit_code, ptz::tools::log_exit::kMissing);
  EXPECT_NE(run.err.find("/nonexistent.lcmlog"), std::string::npos) << run.err;
  EXPECT_FALSE(ptz::test::exists(out));
  // Not an LCM log.
  run = ptz::test::runProgram({PTZ_MCAP_BIN, "--log", PTZ_SOURCE_DIR "/README.md", "--out", out});
  EXPECT_EQ(run.exit_code, ptz::tools::log_exit::kNotLcm) << run.err;
  EXPECT_FALSE(ptz::test::exists(out));
  run = ptz::test::runProgram({PTZ_MCAP_BIN, "--log", kFixture, "--out", "/nonexistent/x.mcap"});
  EXPECT_EQ(run.exit_code, ptz::tools::log_exit::kOutput) << run.err;
  run = ptz::test::runProgram({PTZ_MCAP_BIN, "--log", kFixture});
  EXPECT_EQ(run.exit_code, ptz::tools::log_exit::kUsage);
  run = ptz::test::runProgram(
      {PTZ_MCAP_BIN, "--log", kFixture, "--out", out, "--compression", "lz4"});
  EXPECT_EQ(run.exit_code, ptz::tools::log_exit::kUsage);
  EXPECT_NE(run.err.find("compression"), std::string::npos) << run.err;
  EXPECT_FALSE(ptz::test::exists(out));
}

// A STEREO_FRAME is the largest message of a run: the converter and the run's numbers share one
// decode of it.
TEST(McapExport, EachStereoFrameIsDecodedOnce) {
  const std::string out = tempPath("decode_once.mcap");
  ptz::tools::ExportOptions options;
  options.target_class = "red_ball";
  int64_t frames = 0;
  {
    ptz::tools::McapExporter exporter(out, ptz::StereoRig::makeDefault(), options);
    ptz::tools::LogReader log(kFixture);
    while (const lcm::LogEvent* ev = log.next()) {
      frames += std::string(ev->channel) == "STEREO_FRAME";
      exporter.add(ev->channel, ev->data, static_cast<size_t>(ev->datalen), ev->timestamp);
    }
    exporter.finish({});
    ASSERT_GT(frames, 10);
    EXPECT_EQ(exporter.decodes("STEREO_FRAME"), frames);
    // Every frame still reaches both the images and the run's numbers.
    EXPECT_EQ(exporter.written().at("/left/image"), frames);
    EXPECT_GE(exporter.written().at("/tf"), frames);
  }
  std::remove(out.c_str());
}
