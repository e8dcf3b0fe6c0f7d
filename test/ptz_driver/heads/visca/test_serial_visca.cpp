// Serial VISCA heads against the camera emulator through a pseudo-terminal: the bytes on the
// wire, the measured pose following the emulated motors (the shared plant model gives the known
// answers), a daisy chain of two cameras on one port, the stop, and the round trip.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "support/hardware/serial_serve.hpp"
#include "support/hardware/visca_serial_fixture.hpp"

using namespace ptz::driver;
using ptz::test::PtyPair;
using ptz::test::ViscaSerial;

namespace {
constexpr double kT = 0.24;  // the plant's time constant (defaultPlantParams)

double percentile(std::vector<double> v, double p) {
  const auto k = static_cast<size_t>(p / 100 * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}
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
            "no camera at VISCA address 2 on " + link.path() + ": Address Set found 1");
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
