// VISCA, VISCA over IP and Pelco-D byte for byte against the examples and formats of the
// protocol documents, and the reply parsers fed random bytes (no crash, no hang, bounded).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include "common/config.hpp"
#include "ptz_driver/emulators/visca_camera_emulator.hpp"
#include "ptz_driver/heads/pelco_d/pelco_d.hpp"
#include "ptz_driver/heads/visca/visca.hpp"
#include "ptz_driver/heads/visca/visca_model.hpp"

using ptz::driver::Bytes;
namespace visca = ptz::driver::visca;
namespace visca_ip = ptz::driver::visca_ip;
namespace pelco = ptz::driver::pelco_d;

TEST(Visca, CommandsAreTheDocumentedBytes) {
  // EVI-D70: pan +170 deg is 08DB, -170 deg F725 (16-bit two's complement, 4 nibbles).
  EXPECT_EQ(visca::panTiltAbsolute(1, 0x18, 0x14, 0x08DB, 0, 4),
            (Bytes{0x81, 0x01, 0x06, 0x02, 0x18, 0x14, 0x00, 0x08, 0x0D, 0x0B, 0x00, 0x00, 0x00,
                   0x00, 0xFF}));
  EXPECT_EQ(visca::panTiltAbsolute(2, 0x01, 0x01, -2267, -1, 4),
            (Bytes{0x82, 0x01, 0x06, 0x02, 0x01, 0x01, 0x0F, 0x07, 0x02, 0x05, 0x0F, 0x0F, 0x0F,
                   0x0F, 0xFF}));
  // Five pan nibbles (EVI-H100S, SRG series): 20-bit two's complement.
  EXPECT_EQ(visca::panTiltAbsolute(1, 0x18, 0x17, -1, 0x0123, 5),
            (Bytes{0x81, 0x01, 0x06, 0x02, 0x18, 0x17, 0x0F, 0x0F, 0x0F, 0x0F, 0x0F, 0x00, 0x01,
                   0x02, 0x03, 0xFF}));
  EXPECT_EQ(visca::panTiltStop(1, 0x18, 0x14),
            (Bytes{0x81, 0x01, 0x06, 0x01, 0x18, 0x14, 0x03, 0x03, 0xFF}));
  EXPECT_EQ(visca::zoomDirect(1, 0x4000),
            (Bytes{0x81, 0x01, 0x04, 0x47, 0x04, 0x00, 0x00, 0x00, 0xFF}));
  EXPECT_EQ(visca::zoomStop(3), (Bytes{0x83, 0x01, 0x04, 0x07, 0x00, 0xFF}));
  EXPECT_EQ(visca::panTiltPositionInquiry(1), (Bytes{0x81, 0x09, 0x06, 0x12, 0xFF}));
  EXPECT_EQ(visca::zoomPositionInquiry(1), (Bytes{0x81, 0x09, 0x04, 0x47, 0xFF}));
  EXPECT_EQ(visca::ifClear(), (Bytes{0x88, 0x01, 0x00, 0x01, 0xFF}));
  EXPECT_EQ(visca::addressSet(), (Bytes{0x88, 0x30, 0x01, 0xFF}));
}

TEST(Visca, RepliesAreRecognisedAndDecoded) {
  visca::ReplyParser p;
  const Bytes stream = {0x90, 0x41, 0xFF,                          // ACK, socket 1
                        0x90, 0x51, 0xFF,                          // completion, socket 1
                        0x90, 0x60, 0x02, 0xFF,                    // syntax error
                        0x90, 0x61, 0x41, 0xFF,                    // not executable, socket 1
                        0x90, 0x60, 0x03, 0xFF,                    // command buffer full
                        0x90, 0x50, 0x0F, 0x07, 0x02, 0x05,        // pan -2267
                        0x00, 0x01, 0x02, 0x03, 0xFF,              // tilt 0x0123
                        0x90, 0x50, 0x04, 0x00, 0x00, 0x00, 0xFF,  // zoom 0x4000
                        0x88, 0x30, 0x02, 0xFF};                   // address set, next address 2
  p.feed(stream.data(), stream.size());
  using K = visca::Reply::Kind;
  auto r = p.next();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->kind, K::kAck);
  EXPECT_EQ(r->socket, 1);
  EXPECT_EQ(r->address, 1);
  EXPECT_EQ(p.next()->kind, K::kCompletion);
  r = p.next();
  EXPECT_EQ(r->kind, K::kError);
  EXPECT_EQ(r->error, visca::kSyntax);
  r = p.next();
  EXPECT_EQ(r->error, visca::kNotExecutable);
  EXPECT_EQ(r->socket, 1);
  EXPECT_EQ(visca::errorName(p.next()->error), "command buffer full");
  r = p.next();
  int32_t pan = 0, tilt = 0;
  ASSERT_TRUE(visca::decodePanTiltPosition(*r, 4, &pan, &tilt));
  EXPECT_EQ(pan, -2267);
  EXPECT_EQ(tilt, 0x0123);
  EXPECT_FALSE(visca::decodePanTiltPosition(*r, 5, &pan, &tilt));  // wrong length for 5
  int zoom = 0;
  ASSERT_TRUE(visca::decodeZoomPosition(*p.next(), &zoom));
  EXPECT_EQ(zoom, 0x4000);
  EXPECT_EQ(p.next()->kind, K::kAddress);
  EXPECT_FALSE(p.next());
  EXPECT_EQ(p.malformed(), 0);
}

TEST(ViscaOverIp, HeaderAndSequenceNumbers) {
  // Sony's example: CAM_Zoom Tele (81 01 04 07 02 FF) as the command with sequence number FF.
  const Bytes zoom_tele = {0x81, 0x01, 0x04, 0x07, 0x02, 0xFF};
  EXPECT_EQ(
      visca_ip::wrap(visca_ip::kCommand, 0xFF, zoom_tele),
      (Bytes{0x01, 0x00, 0x00, 0x06, 0x00, 0x00, 0x00, 0xFF, 0x81, 0x01, 0x04, 0x07, 0x02, 0xFF}));
  EXPECT_EQ(visca_ip::resetSequence(0),
            (Bytes{0x02, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x01}));
  const Bytes reply = visca_ip::wrap(visca_ip::kReply, 0x01020304, {0x90, 0x41, 0xFF});
  visca_ip::Message m;
  std::string error;
  ASSERT_TRUE(visca_ip::unwrap(reply.data(), reply.size(), &m, &error)) << error;
  EXPECT_EQ(m.type, visca_ip::kReply);
  EXPECT_EQ(m.sequence, 0x01020304u);
  EXPECT_EQ(m.payload, (Bytes{0x90, 0x41, 0xFF}));
  // A length that disagrees with the datagram, a short datagram, an unknown type.
  Bytes bad = reply;
  bad[3] = 0x05;
  EXPECT_FALSE(visca_ip::unwrap(bad.data(), bad.size(), &m, &error));
  EXPECT_NE(error.find("payload length 5"), std::string::npos) << error;
  EXPECT_FALSE(visca_ip::unwrap(reply.data(), 7, &m, &error));
  bad = reply;
  bad[0] = 0x07;
  EXPECT_FALSE(visca_ip::unwrap(bad.data(), bad.size(), &m, &error));
}

TEST(PelcoD, FramesAndChecksumsAreTheDocumentedBytes) {
  // The protocol document's examples: stop; pan left at speed 0x20 (checksum 0x25).
  EXPECT_EQ(pelco::stop(1), (Bytes{0xFF, 0x01, 0x00, 0x00, 0x00, 0x00, 0x01}));
  EXPECT_EQ(pelco::panTilt(1, -0x20, 0), (Bytes{0xFF, 0x01, 0x00, 0x04, 0x20, 0x00, 0x25}));
  EXPECT_EQ(pelco::panTilt(2, 0x10, 0x3F), (Bytes{0xFF, 0x02, 0x00, 0x0A, 0x10, 0x3F, 0x5B}));
  EXPECT_EQ(pelco::panTilt(1, 0, -100), (Bytes{0xFF, 0x01, 0x00, 0x10, 0x00, 0x3F, 0x50}));
  // Set pan position 90.00 deg = 9000 = 0x2328 (checksum 0x97); queries.
  EXPECT_EQ(pelco::setPanPosition(1, 9000), (Bytes{0xFF, 0x01, 0x00, 0x4B, 0x23, 0x28, 0x97}));
  EXPECT_EQ(pelco::setPanPosition(1, 40000), pelco::setPanPosition(1, 35999));  // clamped
  EXPECT_EQ(pelco::queryPan(1), (Bytes{0xFF, 0x01, 0x00, 0x51, 0x00, 0x00, 0x52}));
  EXPECT_EQ(pelco::queryTilt(1), (Bytes{0xFF, 0x01, 0x00, 0x53, 0x00, 0x00, 0x54}));
  EXPECT_EQ(pelco::queryZoom(1), (Bytes{0xFF, 0x01, 0x00, 0x55, 0x00, 0x00, 0x56}));
  // The pan position response, after garbage and a frame with a bad checksum.
  pelco::ReplyParser p;
  const Bytes stream = {0x12, 0x34, 0xFF, 0x01, 0x00, 0x59, 0x23, 0x28,
                        0x00, 0xFF, 0x01, 0x00, 0x59, 0x23, 0x28, 0xA5};
  p.feed(stream.data(), stream.size());
  const auto r = p.next();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->command2, 0x59);
  EXPECT_EQ(r->value, 9000);
  EXPECT_FALSE(p.next());
  EXPECT_EQ(p.badChecksums(), 1);
}

TEST(Protocols, ReplyParsersSurviveRandomBytes) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> byte(0, 255), chunk(1, 40);
  visca::ReplyParser v;
  pelco::ReplyParser pd;
  const Bytes ack = {0x90, 0x41, 0xFF};
  int64_t fed = 0, acks_fed = 0, acks_seen = 0;
  for (int i = 0; i < 50000; ++i) {
    Bytes data(static_cast<size_t>(chunk(rng)));
    for (auto& b : data) b = static_cast<uint8_t>(byte(rng));
    if (i % 10 == 0) {  // a real reply after a terminator: it must come through
      data.push_back(0xFF);
      data.insert(data.end(), ack.begin(), ack.end());
      ++acks_fed;
    }
    v.feed(data.data(), data.size());
    pd.feed(data.data(), data.size());
    fed += static_cast<int64_t>(data.size());
    while (auto r = v.next()) {
      ASSERT_LE(r->bytes.size(), 16u);
      ASSERT_EQ(r->bytes.back(), 0xFF);
      acks_seen += r->bytes == ack;
    }
    while (pd.next()) {
    }
  }
  EXPECT_GT(fed, 1000000);
  EXPECT_GE(acks_seen, acks_fed);  // random bytes may add some, never lose one
  EXPECT_GT(v.malformed(), 0);
  EXPECT_GT(pd.badChecksums() + pd.skippedBytes(), 0);
}

namespace {
const std::string kD70 = PTZ_SOURCE_DIR "/config/visca/sony_evi_d70.yaml";
const std::string kSrg = PTZ_SOURCE_DIR "/config/visca/sony_srg300.yaml";
}  // namespace

TEST(ViscaCamera, TheModelFileGivesTheDocumentedUnits) {
  const auto d70 = ptz::driver::ViscaModel::load(kD70);
  EXPECT_EQ(d70.panUnits(170 * M_PI / 180), 0x08DB);  // EVI-D70 manual: +170 deg
  EXPECT_EQ(d70.panUnits(-170 * M_PI / 180), -0x08DB);
  EXPECT_EQ(d70.panUnits(3.0), 0x08DB);  // clamped to the head's range
  EXPECT_EQ(d70.zoomPosition(4.0), 10336);
  EXPECT_NEAR(d70.zoomRatio(d70.zoomPosition(2.5)), 2.5, 1e-3);
  EXPECT_THROW(ptz::driver::ViscaModel::load("/nonexistent.yaml"), ptz::ConfigError);
}

// A model file with one thing wrong at a time: named with the file, the field and the value.
TEST(ViscaCamera, ABadModelFileIsRefusedNamingTheFieldAndTheValue) {
  std::ifstream in(kSrg);
  const std::string good((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string path = ::testing::TempDir() + "visca_bad.yaml";
  struct Case {
    std::string from, to, expected;
  };
  const std::vector<Case> cases = {
      {"pan_speed_max: 24", "pan_speed_max: 24\npan_sped_max: 3", "pan_sped_max: unknown field"},
      {"pan_min_deg: -170.0", "pan_min_deg: 175.0",
       "pan_min_deg = 175 must be below pan_max_deg = 170"},
      {"pan_speed_max: 24", "pan_speed_max: 0", "pan_speed_max: must be within 1 .. 127, got '0'"},
      {"zoom_ratios:    [1, 2, 3", "zoom_ratios:    [1, 3, 2",
       "zoom_ratios[1] = 3 must be below zoom_ratios[2] = 2"},
      {"zoom_positions: [0, 5638", "zoom_positions: [0, \"far\"",
       "zoom_positions[1]: must be a number, got 'far'"},
      {"zoom_ratios:    [1, 2, 3", "zoom_ratios:    [2, 3",
       "zoom_ratios: must have as many entries as zoom_positions (16), got 15"},
      // fuzz_visca_model's find: a tilt of 4 nibbles cannot say -102040.
      {"tilt_units_per_deg: 51.2", "tilt_units_per_deg: 5102",
       "tilt_min_deg: -20.000000 deg is -102040.000000 units, beyond the 4 nibbles"},
  };
  for (const auto& c : cases) {
    std::string text = good;
    ASSERT_NE(text.find(c.from), std::string::npos) << c.from;
    text.replace(text.find(c.from), c.from.size(), c.to);
    std::ofstream(path) << text;
    std::string what;
    try {
      ptz::driver::ViscaModel::load(path);
    } catch (const ptz::ConfigError& e) {
      what = e.what();
    }
    const std::string expected = "VISCA model file '" + path + "', " + c.expected;
    EXPECT_EQ(what.substr(0, expected.size()), expected) << what;
  }
}

TEST(ViscaCamera, TheEmulatorAnswersAsTheCameraDoes) {
  const ptz::driver::ViscaCameraEmulator cam(ptz::driver::ViscaModel::load(kD70), 1);
  ptz::driver::ViscaTarget target;
  const ptz::PtzPose at{-170 * M_PI / 180, 0.0, 4.0};
  // Position inquiry at -170 deg: the manual's F725.
  auto replies = cam.handle(visca::panTiltPositionInquiry(1), at, &target);
  ASSERT_EQ(replies.size(), 1u);
  EXPECT_EQ(replies[0], (Bytes{0x90, 0x50, 0x0F, 0x07, 0x02, 0x05, 0x00, 0x00, 0x00, 0x00, 0xFF}));
  replies = cam.handle(visca::zoomPositionInquiry(1), at, &target);
  EXPECT_EQ(replies[0], (Bytes{0x90, 0x50, 0x02, 0x08, 0x06, 0x00, 0xFF}));  // 10336 = 0x2860
  // An absolute move: ACK, completion, and the target in radians.
  replies = cam.handle(visca::panTiltAbsolute(1, 24, 20, 0x0400, -0x0100, 4), at, &target);
  ASSERT_EQ(replies.size(), 2u);
  EXPECT_EQ(replies[0], (Bytes{0x90, 0x41, 0xFF}));
  EXPECT_EQ(replies[1], (Bytes{0x90, 0x51, 0xFF}));
  ASSERT_TRUE(target.pan_rad && target.tilt_rad);
  EXPECT_NEAR(*target.pan_rad, 0x0400 / 13.335 * M_PI / 180, 1e-12);
  EXPECT_NEAR(*target.tilt_rad, -0x0100 / 13.335 * M_PI / 180, 1e-12);
  // A command it does not know, and a packet of the wrong length for this model (5 nibbles).
  replies = cam.handle({0x81, 0x01, 0x7E, 0x01, 0xFF}, at, &target);
  EXPECT_EQ(replies[0], (Bytes{0x90, 0x60, 0x02, 0xFF}));
  replies = cam.handle(visca::panTiltAbsolute(1, 24, 20, 0, 0, 5), at, &target);
  EXPECT_EQ(replies[0], (Bytes{0x90, 0x60, 0x02, 0xFF}));
  EXPECT_FALSE(target.pan_rad);
  // The SRG model's 5 nibbles round-trip through the driver's encoder and decoder.
  const ptz::driver::ViscaCameraEmulator srg(ptz::driver::ViscaModel::load(kSrg), 1);
  replies = srg.handle(visca::panTiltPositionInquiry(1), {1.0, 0.2, 1.0}, &target);
  visca::ReplyParser parser;
  parser.feed(replies[0].data(), replies[0].size());
  int32_t pan = 0, tilt = 0;
  ASSERT_TRUE(visca::decodePanTiltPosition(*parser.next(), 5, &pan, &tilt));
  EXPECT_EQ(pan, srg.model().panUnits(1.0));
  EXPECT_NEAR(srg.model().panRad(pan), 1.0, 0.5 / srg.model().pan_units_per_rad);
  EXPECT_NEAR(srg.model().tiltRad(tilt), 0.2, 0.5 / srg.model().tilt_units_per_rad);
}
