// Serial VISCA heads when things go wrong: camera errors by name, a silent camera, lost and
// late replies, an unplugged adapter (and plugged back), garbage on the line, "command buffer
// full".
#include <gtest/gtest.h>

#include <cmath>

#include "support/hardware/visca_serial_fixture.hpp"

using namespace ptz::driver;
using ptz::test::ViscaSerial;

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

// On a busy chain an answer can come after its timeout, once the inquiry has been asked again:
// it is the old inquiry's (counted late), not the new one's, which would date the old position
// at the new inquiry's time.
TEST_F(ViscaSerial, AnAnswerAfterItsTimeoutIsNotTakenForTheNewInquirys) {
  startChain();
  left.command({0.5, 0.2, 4.0}, 0);  // the motors move from home
  serve(2, 0);
  ASSERT_TRUE(read(0, [&] { return replies() == 2 + 4; }));  // 2 ACKs, 2 completions
  const int64_t before = left.stats().replies;
  left.inquire(0, 0.1);
  const auto first = ptz::test::readViscaPackets(pty, 1);
  const Bytes held = chain.feed(first[0].data(), first[0].size(), 0);  // answered at home
  left.inquire(0.15, 0.1);  // unanswered for the timeout: counted, asked again
  EXPECT_EQ(left.stats().timeouts, 1);
  const auto again = ptz::test::readViscaPackets(pty, 1);
  ASSERT_EQ(again, first);
  pty.write(held);  // the first answer comes after all
  ASSERT_TRUE(
      read(0.16, [&] { return left.stats().replies + left.stats().late_replies > before; }));
  EXPECT_EQ(left.stats().late_replies, 1);
  EXPECT_EQ(left.stats().replies, before) << "not the new inquiry's answer";
  EXPECT_TRUE(left.stats().round_trip_ms.empty());
  pty.write(chain.feed(again[0].data(), again[0].size(), 0.17));  // the new one's answer
  ASSERT_TRUE(read(0.18, [&] { return left.stats().replies == before + 1; }));
  serve(1, 0.18);  // the zoom inquiry follows
  ASSERT_TRUE(read(0.18, [&] { return left.stats().replies == before + 2; }));
  ASSERT_TRUE(left.measured());
  // Where the plant is at 0.17 s (x_target (1 - exp(-t/T)), T 0.24 s), not home.
  EXPECT_NEAR(left.measured()->pan_rad, model.panRad(382) * (1 - std::exp(-0.17 / 0.24)),
              1 / model.pan_units_per_rad);
  EXPECT_DOUBLE_EQ(left.measuredAtS(), (0.15 + 0.18) / 2);  // the new inquiry's round trip
  ASSERT_EQ(left.stats().round_trip_ms.size(), 1u);
  EXPECT_NEAR(left.stats().round_trip_ms[0], 30.0, 1e-9);
  EXPECT_EQ(left.stats().malformed, 0);
  EXPECT_EQ(left.stats().timeouts, 1);
}

TEST_F(ViscaSerial, AnUnpluggedAdapterIsOneNamedErrorAndTheProcessGoesOn) {
  const int fd = line->fd();
  pty.hangUp();
  left.receive(0);
  right.receive(0);
  left.receive(0.1);
  EXPECT_EQ(left.stats().errors, 1);
  EXPECT_EQ(left.stats().last_error,
            "serial device '" + link.path() + "' hung up (adapter unplugged?), reopening in 0.5 s");
  EXPECT_EQ(right.stats().errors, 0) << "one line, one error";
  EXPECT_EQ(left.fd(), -1) << "no longer polled (was " << fd << ")";
  left.inquire(0.2, 0.1);  // writes fail quietly: nothing measured, nothing thrown
  EXPECT_FALSE(left.measured());
}

// The adapter comes back (udev points its /dev/serial/by-id/ link to the new tty): the line
// opens it again after the back-off, the chain is addressed again, and the heads start over:
// nothing of before is matched to a new reply, the position is measured again.
TEST_F(ViscaSerial, AnAdapterPluggedBackIsReopenedAndTheHeadsStartOver) {
  const std::vector<Bytes> chain_start = {visca::addressSet(), visca::ifClear()};
  left.start(0);
  right.start(0);
  ASSERT_EQ(serve(2, 0), chain_start);
  ASSERT_TRUE(read(0, [&] { return replies() == 2; }));
  measure(left, 0);
  ASSERT_TRUE(left.measured());
  left.inquire(0.9, 0.1);  // asked just before the unplugging: its answer never comes
  ASSERT_EQ(ptz::test::readViscaPackets(pty, 1).size(), 1u);

  pty.hangUp();
  left.receive(1.0);
  right.receive(1.0);
  const std::string device = "serial device '" + link.path() + "'";
  EXPECT_EQ(left.stats().errors + right.stats().errors, 1);
  EXPECT_EQ(left.stats().last_error, device + " hung up (adapter unplugged?), reopening in 0.5 s");
  EXPECT_EQ(line->problem(1.2), device + " hung up (adapter unplugged?), reopening in 0.3 s");
  EXPECT_EQ(left.problem(1.2), line->problem(1.2));
  EXPECT_EQ(line->fd(), -1);
  const int64_t sent = left.stats().sent + right.stats().sent;
  left.command({0.5, 0.2, 4.0}, 1.1);
  left.inquire(1.3, 0.1);
  right.inquire(1.3, 0.1);
  EXPECT_EQ(left.stats().sent + right.stats().sent, sent) << "nothing goes out meanwhile";

  // Still unplugged at the first attempt (0.5 s after): the next waits 1 s.
  link.remove();
  left.receive(1.5);
  EXPECT_EQ(line->problem(1.5),
            device +
                " does not exist (adapter unplugged? see ls /dev/serial/by-id/), "
                "reopening in 1.0 s");
  EXPECT_EQ(left.stats().errors + right.stats().errors, 1) << "one outage, one error";

  // Plugged back in under another tty: not before the back-off, then at once.
  ptz::test::PtyPair plugged_back;
  link.pointTo(plugged_back.path());
  wire = &plugged_back;
  left.receive(2.4);
  right.receive(2.4);
  EXPECT_EQ(line->reopens(), 0);
  EXPECT_EQ(line->fd(), -1);
  left.receive(2.5);
  right.receive(2.5);
  EXPECT_EQ(line->reopens(), 1);
  EXPECT_EQ(left.stats().reopens + right.stats().reopens, 1) << "one line, one reopen";
  EXPECT_GE(line->fd(), 0);
  EXPECT_EQ(line->problem(2.5), "");
  EXPECT_FALSE(left.measured()) << "the position is measured again first";
  EXPECT_FALSE(right.measured());
  // The chain is addressed again, once for both heads.
  const int64_t before = replies();
  ASSERT_EQ(serve(2, 2.5), chain_start);
  ASSERT_TRUE(read(2.5, [&] { return replies() == before + 2; }));
  EXPECT_TRUE(plugged_back.read(std::chrono::milliseconds(0)).empty());

  // Measured again: the answer is the new inquiry's, not the one lost with the old port's.
  left.stats().round_trip_ms.clear();
  measure(left, 2.6);
  ASSERT_TRUE(left.measured());
  EXPECT_DOUBLE_EQ(left.measuredAtS(), 2.6);
  ASSERT_EQ(left.stats().round_trip_ms.size(), 1u);
  EXPECT_EQ(left.stats().round_trip_ms[0], 0.0);
  // And it follows commands.
  left.command({0.5, 0.2, 4.0}, 2.7);
  const auto commands = serve(2, 2.7);
  ASSERT_EQ(commands.size(), 2u);
  EXPECT_EQ(commands[0],
            visca::panTiltAbsolute(1, model.pan_speed_max, model.tilt_speed_max,
                                   model.panUnits(0.5), model.tiltUnits(0.2), model.pan_nibbles));
  ASSERT_TRUE(read(2.7, [&] { return replies() == before + 2 + 2 + 4; }));  // ACKs, completions
  EXPECT_EQ(left.stats().malformed + right.stats().malformed, 0);
  EXPECT_EQ(left.stats().late_replies, 0);
  EXPECT_EQ(left.stats().errors + right.stats().errors, 1);
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
