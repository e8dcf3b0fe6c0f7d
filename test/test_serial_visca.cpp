// Serial VISCA heads against the camera emulator through a pseudo-terminal: the bytes on the
// wire, the FIFO matching of ACKs, completions and answers, a daisy chain of two cameras on one
// port, errors, timeouts, garbage, "command buffer full" and the stop. Time is the test's
// (seconds from 0): the emulated motors (the shared plant model) give the known answers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "ptz/plant.hpp"
#include "ptz_driver/visca_chain_emulator.hpp"
#include "ptz_driver/visca_serial_head.hpp"
#include "support/pty_pair.hpp"
#include "support/serial_serve.hpp"

using namespace ptz::driver;
using ptz::test::PtyPair;

namespace {
const std::string kD70 = PTZ_SOURCE_DIR "/config/visca/sony_evi_d70.yaml";
constexpr double kT = 0.24;  // the plant's time constant (defaultPlantParams)

double percentile(std::vector<double> v, double p) {
  const auto k = static_cast<size_t>(p / 100 * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

class ViscaSerial : public ::testing::Test {
 protected:
  ViscaModel model = ViscaModel::load(kD70);
  PtyPair pty;
  ViscaChainEmulator chain{model, ptz::defaultPlantParams(), 2};
  std::shared_ptr<ViscaSerialLine> line =
      std::make_shared<ViscaSerialLine>(pty.path(), 9600, "serial_baud");
  ViscaSerialHead left{model, line, 1};
  ViscaSerialHead right{model, line, 2};

  // The chain takes `packets` packets from the heads and answers them at now_s.
  std::vector<Bytes> serve(size_t packets, double now_s) {
    const auto in = ptz::test::readViscaPackets(pty, packets);
    EXPECT_EQ(in.size(), packets);
    for (const Bytes& p : in) pty.write(chain.feed(p.data(), p.size(), now_s));
    return in;
  }
  // The heads read at now_s until done() (at most 2 s).
  bool read(double now_s, const std::function<bool()>& done) {
    return waitUntil(
        line->fd(), 2.0,
        [&] {
          left.receive(now_s);
          right.receive(now_s);
        },
        done);
  }
  int64_t replies() { return left.stats().replies + right.stats().replies; }
  void startChain() {
    left.start(0);
    right.start(0);
    serve(2, 0);
    ASSERT_TRUE(read(0, [&] { return replies() == 2; }));
  }
  // One round of position inquiries of head h, answered at now_s (pan-tilt, then zoom).
  void measure(ViscaSerialHead& h, double now_s) {
    const int64_t before = h.stats().replies;
    h.inquire(now_s, 0.1);
    serve(1, now_s);
    ASSERT_TRUE(read(now_s, [&] { return h.stats().replies == before + 1; }));
    serve(1, now_s);  // the zoom inquiry went after the pan-tilt answer
    ASSERT_TRUE(read(now_s, [&] { return h.stats().replies == before + 2; }));
  }
};
}  // namespace

TEST_F(ViscaSerial, StartsTheChainOnceWithAddressSetAndIfClear) {
  left.start(0);
  right.start(0);  // the same line: nothing more
  const auto sent = ptz::test::readViscaPackets(pty, 2);
  ASSERT_EQ(sent.size(), 2u);
  EXPECT_EQ(sent[0], (Bytes{0x88, 0x30, 0x01, 0xFF}));
  EXPECT_EQ(sent[1], (Bytes{0x88, 0x01, 0x00, 0x01, 0xFF}));
  for (const Bytes& p : sent) pty.write(chain.feed(p.data(), p.size(), 0));
  ASSERT_TRUE(read(0, [&] { return replies() == 2; }));  // 88 30 03 FF and 88 01 00 01 FF back
  EXPECT_EQ(chain.address(0), 1);
  EXPECT_EQ(chain.address(1), 2);
  EXPECT_EQ(left.stats().errors + right.stats().errors, 0);
  EXPECT_EQ(left.stats().malformed + right.stats().malformed, 0);
}

TEST_F(ViscaSerial, AnAddressTheChainDoesNotHaveIsAnError) {
  ViscaChainEmulator one_camera(model, ptz::defaultPlantParams(), 1);
  left.start(0);
  for (const Bytes& p : ptz::test::readViscaPackets(pty, 2))
    pty.write(one_camera.feed(p.data(), p.size(), 0));
  ASSERT_TRUE(read(0, [&] { return replies() == 2; }));
  EXPECT_EQ(left.stats().errors + right.stats().errors, 1);
  EXPECT_EQ(left.stats().last_error + right.stats().last_error,
            "no camera at VISCA address 2 on " + pty.path() + ": Address Set found 1");
}

TEST_F(ViscaSerial, CommandsAreTheBytesAndTheMeasuredPoseFollowsTheMotors) {
  startChain();
  measure(left, 0);
  ASSERT_TRUE(left.measured());
  EXPECT_EQ(left.measured()->pan_rad, 0.0);
  EXPECT_EQ(left.measured()->zoom, 1.0);
  EXPECT_EQ(left.measuredAtS(), 0.0);
  // 0.5 rad = 28.648 deg = 382 units (0x017E), 0.2 rad = 153 (0x0099); zoom 4x = 10336 (0x2860).
  const int64_t before = replies();
  left.command({0.5, 0.2, 4.0}, 0);
  const auto sent = serve(2, 0);
  EXPECT_EQ(sent[0], (Bytes{0x81, 0x01, 0x06, 0x02, 0x18, 0x14, 0x00, 0x01, 0x07, 0x0E, 0x00, 0x00,
                            0x09, 0x09, 0xFF}));
  EXPECT_EQ(sent[1], (Bytes{0x81, 0x01, 0x04, 0x47, 0x02, 0x08, 0x06, 0x00, 0xFF}));
  ASSERT_TRUE(read(0, [&] { return replies() == before + 4; }));  // 2 ACKs, 2 completions
  left.command({0.5, 0.2, 4.0}, 0.01);                            // nothing changed: nothing sent
  EXPECT_EQ(left.stats().sent, 2 + 2 + 2);
  // The plant: x(t) = x_target (1 - exp(-t/T)) (no rate limit reached: 2.1 rad/s at most).
  const double unit = 1 / model.pan_units_per_rad;
  const double pan = model.panRad(382), tilt = model.tiltRad(153);
  for (const double t : {0.1, kT, 0.5, 2.0}) {
    measure(left, t);
    const double a = 1 - std::exp(-t / kT);
    EXPECT_NEAR(left.measured()->pan_rad, pan * a, unit) << "t " << t;
    EXPECT_NEAR(left.measured()->tilt_rad, tilt * a, unit) << "t " << t;
    EXPECT_NEAR(left.measured()->zoom, 1 + 3 * a, 1e-3) << "t " << t;
    EXPECT_EQ(left.measuredAtS(), t);
  }
  EXPECT_NEAR(left.measured()->pan_rad, pan, unit);  // converged within a unit at 2 s
  EXPECT_EQ(left.stats().timeouts + left.stats().errors + left.stats().malformed, 0);
}

TEST_F(ViscaSerial, RepliesOnADaisyChainGoToTheirCamera) {
  startChain();
  left.command({0.5, 0.0, 1.0}, 0);
  right.command({-0.3, 0.1, 2.0}, 0);
  const auto sent = serve(4, 0);
  EXPECT_EQ(sent[0][0], 0x81);
  EXPECT_EQ(sent[2][0], 0x82);
  ASSERT_TRUE(read(0, [&] { return replies() == 2 + 8; }));
  // The right camera asks first, so its answer comes first while the left's is also awaited.
  right.inquire(3, 0.1);
  left.inquire(3, 0.1);
  const auto inquiries = serve(2, 3);
  EXPECT_EQ(inquiries[0][0], 0x82);
  ASSERT_TRUE(read(3, [&] { return replies() == 2 + 8 + 2; }));
  serve(2, 3);  // both zoom inquiries
  ASSERT_TRUE(read(3, [&] { return replies() == 2 + 8 + 4; }));
  const double unit = 1 / model.pan_units_per_rad;
  EXPECT_NEAR(left.measured()->pan_rad, chain.pose(0, 3).pan_rad, unit);
  EXPECT_NEAR(right.measured()->pan_rad, chain.pose(1, 3).pan_rad, unit);
  EXPECT_NEAR(left.measured()->pan_rad, 0.5, 2 * unit);
  EXPECT_NEAR(right.measured()->pan_rad, -0.3, 2 * unit);
  EXPECT_NEAR(right.measured()->tilt_rad, 0.1, 2 * unit);
  EXPECT_NEAR(right.measured()->zoom, 2.0, 1e-3);
  EXPECT_EQ(left.stats().malformed + right.stats().malformed, 0);
}

TEST_F(ViscaSerial, ErrorsAreCountedByNameAndARefusedCommandGoesAgain) {
  left.command({0.5, 0.2, 4.0}, 0);
  const auto sent = ptz::test::readViscaPackets(pty, 2);
  pty.write({0x90, 0x60, 0x02, 0xFF});  // the pan-tilt command: syntax error
  ASSERT_TRUE(read(0, [&] { return left.stats().errors == 1; }));
  EXPECT_EQ(left.stats().last_error, "syntax error");
  pty.write({0x90, 0x41, 0xFF, 0x90, 0x61, 0x41, 0xFF});  // zoom: ACK, then not executable
  ASSERT_TRUE(read(0, [&] { return left.stats().errors == 2; }));
  EXPECT_EQ(left.stats().last_error, "command not executable");
  left.command({0.5, 0.2, 4.0}, 0.01);
  EXPECT_EQ(ptz::test::readViscaPackets(pty, 2), sent);  // both again, the same bytes
  EXPECT_EQ(left.stats().malformed, 0);
}

TEST_F(ViscaSerial, ASilentCameraGivesTimeoutsAndResends) {
  const Bytes inquiry = {0x81, 0x09, 0x06, 0x12, 0xFF};
  left.inquire(0, 0.1);
  EXPECT_EQ(ptz::test::readViscaPackets(pty, 1), std::vector<Bytes>{inquiry});
  left.inquire(0.05, 0.1);  // not yet timed out: nothing more
  EXPECT_EQ(left.stats().sent, 1);
  left.inquire(0.15, 0.1);
  EXPECT_EQ(left.stats().timeouts, 1);
  EXPECT_EQ(ptz::test::readViscaPackets(pty, 1), std::vector<Bytes>{inquiry});
  left.command({0.5, 0.2, 4.0}, 0.15);
  const auto commands = ptz::test::readViscaPackets(pty, 2);
  left.command({0.6, 0.2, 4.0}, 0.2);  // the pan-tilt command still awaits its ACK: waits
  EXPECT_EQ(left.stats().sent, 4);
  // At 0.3 s the inquiry (one round) and both commands are lost: counted, and asked again.
  left.inquire(0.3, 0.1);
  EXPECT_EQ(left.stats().timeouts, 1 + 1 + 2);
  EXPECT_EQ(ptz::test::readViscaPackets(pty, 1), std::vector<Bytes>{inquiry});
  left.command({0.5, 0.2, 4.0}, 0.3);
  EXPECT_EQ(ptz::test::readViscaPackets(pty, 2), commands);
  EXPECT_FALSE(left.measured());
}

TEST_F(ViscaSerial, AReplyThatSkipsARequestMeansThatRequestsReplyWasLost) {
  left.inquire(0, 0.1);
  left.command({0.5, 0.2, 4.0}, 0);
  ASSERT_EQ(ptz::test::readViscaPackets(pty, 3).size(), 3u);  // inquiry, pan-tilt, zoom
  pty.write({0x90, 0x41, 0xFF});  // the pan-tilt command's ACK: the inquiry's answer is lost
  ASSERT_TRUE(read(0, [&] { return left.stats().timeouts == 1; }));
  left.inquire(0.01, 0.1);  // asked again at once, not after the timeout
  EXPECT_EQ(ptz::test::readViscaPackets(pty, 1),
            std::vector<Bytes>{visca::panTiltPositionInquiry(1)});
  EXPECT_EQ(left.stats().malformed, 0);
}

TEST_F(ViscaSerial, GarbageIsCountedAndSkipped) {
  startChain();
  const int64_t before = replies();
  left.inquire(0, 0.1);
  const auto in = ptz::test::readViscaPackets(pty, 1);
  // Five bytes the parser cannot use (no header byte, a lone terminator), then the answer.
  pty.write({0x00, 0x13, 0x37, 0xFF, 0x42});
  pty.write(chain.feed(in[0].data(), in[0].size(), 0));
  ASSERT_TRUE(read(0, [&] { return replies() == before + 1; }));
  EXPECT_EQ(left.stats().malformed + right.stats().malformed, 5);
  // An answer nobody asked for (no inquiry out now) is counted too, and skipped.
  serve(1, 0);  // the zoom inquiry
  ASSERT_TRUE(read(0, [&] { return replies() == before + 2; }));
  pty.write({0x90, 0x50, 0x00, 0x00, 0x00, 0x00, 0xFF});
  ASSERT_TRUE(read(0, [&] { return left.stats().malformed + right.stats().malformed == 6; }));
  EXPECT_TRUE(left.measured());
}

TEST_F(ViscaSerial, ACommandBufferFullMakesTheHeadWaitForACompletion) {
  startChain();
  chain.setCompletionDelay(-1);  // commands run until the test completes them
  const int64_t before = replies();
  left.command({0.5, 0.2, 4.0}, 0);
  serve(2, 0);  // ACK on sockets 1 and 2
  ASSERT_TRUE(read(0, [&] { return replies() == before + 2; }));
  left.command({0.6, 0.2, 4.0}, 0.02);
  serve(1, 0.02);  // both sockets busy: 90 60 03 FF
  ASSERT_TRUE(read(0.02, [&] { return left.stats().buffer_full == 1; }));
  EXPECT_EQ(left.stats().last_error, "command buffer full");
  const int64_t sent = left.stats().sent;
  left.command({0.7, 0.2, 4.0}, 0.04);
  EXPECT_EQ(left.stats().sent, sent) << "waits for a completion";
  pty.write(chain.releaseCompletion(0));  // 90 51 FF: socket 1 free
  ASSERT_TRUE(read(0.06, [&] { return replies() == before + 2 + 1 + 1; }));
  left.command({0.7, 0.2, 4.0}, 0.06);
  const auto again = ptz::test::readViscaPackets(pty, 2);  // the refusal sent everything again
  ASSERT_EQ(again.size(), 2u);
  EXPECT_EQ(again[0], visca::panTiltAbsolute(1, 24, 20, model.panUnits(0.7), 153, 4));
  EXPECT_EQ(again[1], visca::zoomDirect(1, 10336));
}

TEST_F(ViscaSerial, StopSendsTheStopBytesAndReportsTheConfirmation) {
  {
    ptz::test::SerialServer<ViscaChainEmulator> server(pty, &chain);
    left.start(0);
    EXPECT_TRUE(left.stop(0, 1.0));
  }
  const auto& got = chain.received();
  ASSERT_EQ(got.size(), 4u);
  EXPECT_EQ(got[2], (Bytes{0x81, 0x01, 0x06, 0x01, 0x18, 0x14, 0x03, 0x03, 0xFF}));
  EXPECT_EQ(got[3], (Bytes{0x81, 0x01, 0x04, 0x07, 0x00, 0xFF}));
  // A camera that does not answer: three tries, then the stop is reported unconfirmed.
  chain.setSilent(true);
  {
    ptz::test::SerialServer<ViscaChainEmulator> server(pty, &chain);
    EXPECT_FALSE(right.stop(0, 0.15));
  }
  EXPECT_EQ(chain.received().size(), 4u + 6u);
  EXPECT_EQ(chain.received().back(), (Bytes{0x82, 0x01, 0x04, 0x07, 0x00, 0xFF}));
}

// The round trip of the pan-tilt inquiry through the pty, on the wall clock. A pty does not
// pace bytes: at 9600 baud 8N1 (10 bits a byte) a real line adds 16 bytes (inquiry 5, answer
// 11) * 1.04 ms = 16.7 ms, and the camera's own answer time.
TEST_F(ViscaSerial, RoundTripThroughThePty) {
  ptz::test::SerialServer<ViscaChainEmulator> server(pty, &chain);
  left.start(server.nowS());
  ASSERT_TRUE(read(0, [&] { return replies() == 2; }));  // the chain numbered
  left.stats().replies = 0;
  std::vector<double> rtt_ms;
  for (int i = 0; i < 200; ++i) {
    const int64_t zoom_answers = left.stats().replies;
    left.inquire(server.nowS(), 0.5);
    ASSERT_TRUE(waitUntil(
        line->fd(), 2.0, [&] { left.receive(server.nowS()); },
        [&] { return left.stats().replies >= zoom_answers + 2; }));
  }
  rtt_ms = left.stats().round_trip_ms;
  ASSERT_EQ(rtt_ms.size(), 200u);
  const double p50 = percentile(rtt_ms, 50), p99 = percentile(rtt_ms, 99);
  const double line_ms = (5 + 11) * 10 * 1000.0 / 9600;
  std::printf(
      "serial VISCA pan-tilt inquiry round trip through the pty: p50 %.3f ms, p99 %.3f "
      "ms; a 9600-baud line adds %.1f ms (16 bytes), the zoom inquiry %.1f ms more\n",
      p50, p99, line_ms, (5 + 7) * 10 * 1000.0 / 9600);
  EXPECT_LT(p50, 20.0);
  EXPECT_EQ(left.stats().timeouts, 0);
}
