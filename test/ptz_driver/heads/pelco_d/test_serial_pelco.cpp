// Pelco-D heads against the head emulator through a pseudo-terminal: the model's mapping of
// angles, the frames and checksums on the wire, position queries one at a time on a shared
// half-duplex bus, the estimate of heads that cannot say where they are (the shared plant
// model), garbage and the stop (not into a reply; during homing). Time is the test's (seconds
// from 0).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>

#include "common/config.hpp"
#include "common/plant.hpp"
#include "ptz_driver/emulators/pelco_d_bus_emulator.hpp"
#include "ptz_driver/heads/pelco_d/pelco_d_head.hpp"
#include "support/hardware/half_duplex_bus.hpp"
#include "support/hardware/pty_pair.hpp"
#include "support/hardware/serial_serve.hpp"

using namespace ptz::driver;
using ptz::test::PtyPair;

namespace {
const std::string kGeneric = PTZ_SOURCE_DIR "/config/pelco_d/generic.yaml";
constexpr double kDeg = M_PI / 180;
constexpr double kT = 0.24;  // the plant's time constant (defaultPlantParams)
constexpr double kCentideg = kDeg / 100;

class PelcoSerial : public ::testing::Test {
 protected:
  PelcoModel model = PelcoModel::load(kGeneric);
  PtyPair pty;
  ptz::test::DeviceLink link{pty.path()};  // the path the heads open
  PtyPair* wire = &pty;                    // where the heads are plugged in now
  std::shared_ptr<PelcoDLine> line = std::make_shared<PelcoDLine>(link.path(), 2400, "pelco_baud");
  ptz::PtzPlant::Params plant = ptz::defaultPlantParams();

  // Reads until `count` whole frames came from the heads.
  std::vector<Bytes> frames(size_t count) {
    const Bytes b = wire->readUntil([count](const Bytes& all) { return all.size() >= 7 * count; });
    std::vector<Bytes> out;
    for (size_t i = 0; i + 7 <= b.size(); i += 7)
      out.emplace_back(b.begin() + i, b.begin() + i + 7);
    return out;
  }
  // The emulated heads take `count` frames and answer at now_s.
  std::vector<Bytes> serve(PelcoDBusEmulator& bus, size_t count, double now_s) {
    auto in = frames(count);
    EXPECT_EQ(in.size(), count);
    for (const Bytes& f : in) wire->write(bus.feed(f.data(), f.size(), now_s));
    return in;
  }
  bool read(PtzHead& h, double now_s, const std::function<bool()>& done) {
    return waitUntil(
        h.fd(), 2.0, [&] { h.receive(now_s); }, done);
  }
  // One round of queries (pan, tilt, zoom, one at a time) answered at now_s.
  void measure(PelcoDHead& h, PelcoDBusEmulator& bus, double now_s) {
    const int64_t before = h.stats().replies;
    h.inquire(now_s, 0.5);
    for (int i = 1; i <= 3; ++i) {
      serve(bus, 1, now_s);
      ASSERT_TRUE(read(h, now_s, [&] { return h.stats().replies == before + i; }));
    }
  }
};

std::string errorOf(const std::string& path) {
  try {
    PelcoModel::load(path);
  } catch (const ptz::ConfigError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(PelcoModel, MapsTheProjectsAnglesOntoHundredthsOfADegree) {
  const PelcoModel m = PelcoModel::load(kGeneric);
  EXPECT_EQ(m.panCentideg(0), 0);
  EXPECT_EQ(m.panCentideg(90 * kDeg), 9000);
  EXPECT_EQ(m.panCentideg(-90 * kDeg), 27000);
  EXPECT_EQ(m.panCentideg(-200 * kDeg), 36000 - 17000);  // clamped to -170 deg
  EXPECT_EQ(m.tiltCentideg(10 * kDeg), 35000);           // up: the head counts downwards
  EXPECT_EQ(m.tiltCentideg(-30 * kDeg), 3000);
  EXPECT_EQ(m.tiltCentideg(-45 * kDeg), 3000);  // clamped to -30 deg
  EXPECT_NEAR(m.panRad(27000), -90 * kDeg, 1e-12);
  EXPECT_NEAR(m.panRad(18000), 180 * kDeg, 1e-12);
  EXPECT_NEAR(m.tiltRad(35000), 10 * kDeg, 1e-12);
  EXPECT_EQ(m.zoom.position(1.0), 0);
  EXPECT_EQ(m.zoom.position(10.0), 65535);
  EXPECT_EQ(m.zoom.position(5.5), 32768);  // 65535 / 2 rounded
  const std::string bad = ::testing::TempDir() + "pelco_bad.yaml";
  {
    std::ifstream in(kGeneric);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    text.replace(text.find("pan_direction: 1"), 16, "pan_direction: 2");
    std::ofstream(bad) << text;
  }
  EXPECT_EQ(errorOf(bad),
            "Pelco-D model file '" + bad + "', pan_direction: must be 1 or -1, got '2'");
  {
    std::ifstream in(kGeneric);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    text.replace(text.find("pan_max_deg: 170.0"), 18, "pan_max_deg: 190.0\npan_offset: 3");
    std::ofstream(bad) << text;
  }
  const std::string unknown = "Pelco-D model file '" + bad + "', pan_offset: unknown field";
  EXPECT_EQ(errorOf(bad).substr(0, unknown.size()), unknown);
  {
    std::ifstream in(kGeneric);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    text.replace(text.find("pan_max_deg: 170.0"), 18, "pan_max_deg: 190.0");
    std::ofstream(bad) << text;
  }
  EXPECT_EQ(errorOf(bad),
            "Pelco-D model file '" + bad + "', pan_max_deg: must be > -180 and <= 180, got '190'");
  EXPECT_NE(errorOf("/nonexistent/pelco.yaml").find("/nonexistent/pelco.yaml"), std::string::npos);
}

TEST_F(PelcoSerial, CommandsAreTheFramesWithTheirChecksums) {
  PelcoDHead head(model, line, 1, true, plant);
  head.command({90 * kDeg, 10 * kDeg, 5.5}, 0);
  const auto sent = frames(3);
  ASSERT_EQ(sent.size(), 3u);
  EXPECT_EQ(sent[0], (Bytes{0xFF, 0x01, 0x00, 0x4B, 0x23, 0x28, 0x97}));  // 9000
  EXPECT_EQ(sent[1], (Bytes{0xFF, 0x01, 0x00, 0x4D, 0x88, 0xB8, 0x8E}));  // 35000
  EXPECT_EQ(sent[2], (Bytes{0xFF, 0x01, 0x00, 0x4F, 0x80, 0x00, 0xD0}));  // 32768
  head.command({90 * kDeg, 10 * kDeg, 5.5}, 0.1);                         // unchanged: nothing
  head.command({90 * kDeg, 11 * kDeg, 5.5}, 0.2);                         // only the tilt
  EXPECT_EQ(frames(1), std::vector<Bytes>{pelco_d::setTiltPosition(1, 34900)});
  EXPECT_EQ(head.stats().sent, 4);
  EXPECT_TRUE(head.stop(0.3, 1.0));  // twice: nothing confirms it
  EXPECT_EQ(frames(2), (std::vector<Bytes>{pelco_d::stop(1), pelco_d::stop(1)}));
  EXPECT_EQ(pelco_d::stop(1), (Bytes{0xFF, 0x01, 0x00, 0x00, 0x00, 0x00, 0x01}));
}

TEST_F(PelcoSerial, WithPositionQueriesTheMeasuredPoseFollowsTheMotors) {
  PelcoDBusEmulator bus(model, plant, {1}, true);
  PelcoDHead head(model, line, 1, true, plant);
  EXPECT_TRUE(head.measuresPosition());
  head.start(0);
  head.inquire(0, 0.5);
  EXPECT_EQ(serve(bus, 1, 0)[0], (Bytes{0xFF, 0x01, 0x00, 0x51, 0x00, 0x00, 0x52}));
  ASSERT_TRUE(read(head, 0, [&] { return head.stats().replies == 1; }));
  head.inquire(0, 0.5);  // one query at a time: the tilt query now, then the zoom query
  EXPECT_EQ(serve(bus, 1, 0)[0], (Bytes{0xFF, 0x01, 0x00, 0x53, 0x00, 0x00, 0x54}));
  ASSERT_TRUE(read(head, 0, [&] { return head.stats().replies == 2; }));
  EXPECT_EQ(serve(bus, 1, 0)[0], (Bytes{0xFF, 0x01, 0x00, 0x55, 0x00, 0x00, 0x56}));
  ASSERT_TRUE(read(head, 0, [&] { return head.stats().replies == 3; }));
  ASSERT_TRUE(head.measured());
  EXPECT_EQ(head.measured()->pan_rad, 0.0);
  EXPECT_EQ(head.measured()->zoom, 1.0);
  head.command({0.5, 0.2, 4.0}, 0);
  serve(bus, 3, 0);
  const double pan = model.panRad(model.panCentideg(0.5));
  const double tilt = model.tiltRad(model.tiltCentideg(0.2));
  const double zoom = model.zoom.ratio(model.zoom.position(4.0));
  for (const double t : {0.1, kT, 2.0}) {
    measure(head, bus, t);
    const double a = 1 - std::exp(-t / kT);
    EXPECT_NEAR(head.measured()->pan_rad, pan * a, kCentideg) << "t " << t;
    EXPECT_NEAR(head.measured()->tilt_rad, tilt * a, kCentideg) << "t " << t;
    EXPECT_NEAR(head.measured()->zoom, 1 + (zoom - 1) * a, 1e-3) << "t " << t;
    EXPECT_EQ(head.measuredAtS(), t);
  }
  EXPECT_EQ(head.stats().malformed + head.stats().timeouts, 0);
}

TEST_F(PelcoSerial, WithoutQueriesThePoseIsTheEstimateOfThePlantModel) {
  PelcoDBusEmulator bus(model, plant, {1}, false);
  PelcoDHead head(model, line, 1, false, plant);
  EXPECT_FALSE(head.measuresPosition());
  head.start(0);  // home: pan 0, tilt 0, zoom 1
  const auto home = serve(bus, 3, 0);
  EXPECT_EQ(home[0], (Bytes{0xFF, 0x01, 0x00, 0x4B, 0x00, 0x00, 0x4C}));
  EXPECT_EQ(home[1], (Bytes{0xFF, 0x01, 0x00, 0x4D, 0x00, 0x00, 0x4E}));
  EXPECT_EQ(home[2], (Bytes{0xFF, 0x01, 0x00, 0x4F, 0x00, 0x00, 0x50}));
  // The longest move home: 340 deg of pan at 300 deg/s, then 5 T: 1.133 + 1.2 = 2.333 s.
  head.inquire(2.3, 0.1);
  EXPECT_FALSE(head.measured()) << "still homing";
  head.inquire(2.34, 0.1);
  ASSERT_TRUE(head.measured());
  EXPECT_EQ(head.measured()->pan_rad, 0.0);
  head.command({0.5, 0.2, 4.0}, 3.0);
  serve(bus, 3, 3.0);
  const double pan = model.panRad(model.panCentideg(0.5));
  for (const double t : {3.1, 3.0 + kT, 5.0}) {
    head.inquire(t, 0.1);
    const double a = 1 - std::exp(-(t - 3.0) / kT);
    EXPECT_NEAR(head.measured()->pan_rad, pan * a, 1e-9) << "t " << t;
    EXPECT_EQ(head.measuredAtS(), t);
    // The emulated head, moved by the same plant model, is where the estimate says.
    EXPECT_NEAR(head.measured()->pan_rad, bus.pose(0, t).pan_rad, 1e-9);
    EXPECT_NEAR(head.measured()->tilt_rad, bus.pose(0, t).tilt_rad, 1e-9);
    EXPECT_NEAR(head.measured()->zoom, bus.pose(0, t).zoom, 1e-9);
  }
  // Stopped on the way to -0.5 rad: the estimate holds where it has got to.
  head.command({-0.5, 0.2, 4.0}, 6.0);
  serve(bus, 1, 6.0);
  head.inquire(6.1, 0.1);
  const double at_stop = head.measured()->pan_rad;
  const double at_6 = pan * (1 - std::exp(-3.0 / kT));  // 3 s after the move to `pan`
  const double to = model.panRad(model.panCentideg(-0.5));
  EXPECT_NEAR(at_stop, at_6 + (to - at_6) * (1 - std::exp(-0.1 / kT)), 1e-9);
  EXPECT_TRUE(head.stop(6.1, 1.0));
  head.inquire(7.0, 0.1);
  EXPECT_NEAR(head.measured()->pan_rad, at_stop, 1e-9);
}

TEST_F(PelcoSerial, TwoHeadsOnOneBusTakeTurnsAndGetTheirOwnAnswers) {
  PelcoDBusEmulator bus(model, plant, {1, 2}, true, {0.3, 0.0, 1.0});
  PelcoDHead left(model, line, 1, true, plant), right(model, line, 2, true, plant);
  left.inquire(0, 0.5);
  right.inquire(0, 0.5);  // the left head's answer is awaited: the bus is not free
  EXPECT_EQ(right.stats().sent, 0);
  EXPECT_EQ(serve(bus, 1, 0)[0][1], 0x01);
  ASSERT_TRUE(read(left, 0, [&] { return left.stats().replies == 1; }));
  // The left head's tilt query waits: the right head wants the bus and the left talked last.
  left.inquire(0, 0.5);
  right.inquire(0, 0.5);
  EXPECT_EQ(left.stats().sent, 1);
  EXPECT_EQ(serve(bus, 1, 0)[0][1], 0x02);
  ASSERT_TRUE(read(right, 0, [&] { return right.stats().replies == 1; }));
  EXPECT_FALSE(left.measured());  // tilt and zoom not yet known
  for (int i = 0; i < 4; ++i) {   // the rest of both rounds, taking turns
    left.inquire(0, 0.5);
    right.inquire(0, 0.5);
    serve(bus, 1, 0);
    ASSERT_TRUE(waitUntil(
        line->fd(), 2.0,
        [&] {
          left.receive(0);
          right.receive(0);
        },
        [&] { return left.stats().replies + right.stats().replies == 3 + i; }));
  }
  ASSERT_TRUE(left.measured() && right.measured());
  EXPECT_NEAR(left.measured()->pan_rad, 0.3, kCentideg);
  EXPECT_NEAR(right.measured()->pan_rad, 0.3, kCentideg);
  EXPECT_EQ(left.stats().malformed + right.stats().malformed, 0);
}

TEST_F(PelcoSerial, GarbageAndASilentHeadAreCounted) {
  PelcoDBusEmulator bus(model, plant, {1}, true);
  PelcoDHead head(model, line, 1, true, plant);
  head.inquire(0, 0.1);
  const auto query = frames(1);
  // Two stray bytes, a frame with a bad checksum, a reply from address 9, then the answer.
  pty.write({0x13, 0x37});
  pty.write({0xFF, 0x01, 0x00, 0x59, 0x00, 0x10, 0x00});
  pty.write(pelco_d::frame(9, 0, 0x59, 0, 0));
  pty.write(bus.feed(query[0].data(), query[0].size(), 0));
  ASSERT_TRUE(read(head, 0, [&] { return head.stats().replies == 1; }));
  // 2 skipped + 1 bad checksum and its 7 bytes dropped (no sync byte inside) + 1 not ours.
  EXPECT_EQ(head.stats().malformed, 2 + 1 + 7 + 1);
  // Silence: the tilt query times out, is counted, and the round starts over with pan.
  head.inquire(0.05, 0.1);
  EXPECT_EQ(frames(1)[0][3], 0x53);
  head.inquire(0.2, 0.1);
  EXPECT_EQ(head.stats().timeouts, 1);
  EXPECT_EQ(frames(1), std::vector<Bytes>{pelco_d::queryPan(1)});
}

// At exit or by the deadman, with a position query out: a stop sent at once would collide with
// the reply on its way and be lost, unnoticed. It waits for the reply, then goes twice.
TEST_F(PelcoSerial, AStopWaitsForTheReplyOnItsWayAndGoesTwice) {
  PelcoDBusEmulator heads(model, plant, {1}, true);
  ptz::test::HalfDuplexBus bus(&heads, 0.06);  // query and reply: 58 ms at 2400 baud
  ptz::test::SerialServer<ptz::test::HalfDuplexBus> server(pty, &bus);
  PelcoDHead head(model, line, 1, true, plant);
  head.inquire(0, 1.5);  // the pan query
  EXPECT_TRUE(head.stop(0, 3.0)) << "the bus was free within the timeout and the stops went";
  const std::vector<Bytes> expected = {pelco_d::queryPan(1), pelco_d::stop(1), pelco_d::stop(1)};
  EXPECT_TRUE(
      server.waitFor([&](ptz::test::HalfDuplexBus& b) { return b.heads().received() == expected; },
                     std::chrono::milliseconds(2000)));
  server.stop();
  EXPECT_EQ(bus.collidedBytes(), 0);
  EXPECT_EQ(head.stats().replies, 1) << "the reply came whole and was read";
  EXPECT_EQ(head.stats().malformed, 0);
}

// Without position queries a deadman stop during the start-up homing leaves the head somewhere
// between where it was and home: no pose (no PTZ_STATE) until it has been sent home again.
TEST_F(PelcoSerial, WithoutQueriesAStopDuringHomingLeavesThePoseUnknownUntilHomedAgain) {
  PelcoDBusEmulator bus(model, plant, {1}, false, {1.0, 0.3, 1.0});  // switched on away from home
  PelcoDHead head(model, line, 1, false, plant);
  const std::vector<Bytes> home = {pelco_d::setPanPosition(1, 0), pelco_d::setTiltPosition(1, 0),
                                   pelco_d::setZoomPosition(1, 0)};
  head.start(0);
  EXPECT_EQ(serve(bus, 3, 0), home);
  head.inquire(0.1, 0.1);
  EXPECT_TRUE(head.stop(0.1, 1.0));  // the deadman, 0.1 s into the homing
  serve(bus, 2, 0.1);
  EXPECT_GT(bus.pose(0, 5.0).pan_rad, 0.3) << "the real head stopped part-way";
  head.inquire(5.0, 0.1);  // long after the homing would have ended
  EXPECT_FALSE(head.measured()) << "where it stopped is unknown";
  // The next command sends it home, not to the pose: from an unknown place it would be lost.
  head.command({0.5, 0.2, 4.0}, 5.0);
  EXPECT_EQ(serve(bus, 3, 5.0), home);
  head.inquire(6.0, 0.1);
  EXPECT_FALSE(head.measured()) << "homing again";
  // Stopped again while homing; setpoints again: the driver asks it to find its position.
  EXPECT_TRUE(head.stop(6.0, 1.0));
  serve(bus, 2, 6.0);
  PtzHead& as_driver = head;
  as_driver.findPosition(8.0);
  EXPECT_EQ(serve(bus, 3, 8.0), home);
  as_driver.findPosition(8.1);  // once
  EXPECT_EQ(head.stats().sent, 3 + 2 + 3 + 2 + 3);
  head.inquire(10.3, 0.1);
  EXPECT_FALSE(head.measured()) << "the homing takes 2.333 s";
  head.inquire(10.34, 0.1);
  ASSERT_TRUE(head.measured());
  EXPECT_EQ(head.measured()->pan_rad, 0.0);
  EXPECT_NEAR(bus.pose(0, 10.34).pan_rad, 0.0, 1e-3) << "and the real head is there";
  // A stop after the homing: the estimate holds where the head stopped (here: home).
  EXPECT_TRUE(head.stop(11.0, 1.0));
  serve(bus, 2, 11.0);
  head.inquire(12.0, 0.1);
  ASSERT_TRUE(head.measured());
  EXPECT_EQ(head.measured()->pan_rad, 0.0);
}

// The RS-485 adapter unplugged and plugged back (its link re-pointed to the new tty): the line
// opens it again after the back-off and the head starts over. A head that answers queries is
// measured again; one without has lost its position (it may have been moved, or powered off
// and homed itself): unknown until sent home again, as after a stop during homing.
TEST_F(PelcoSerial, AfterAReopenWithQueriesThePoseIsMeasuredAgain) {
  const std::vector<Bytes> pose = {pelco_d::setPanPosition(1, model.panCentideg(0.5)),
                                   pelco_d::setTiltPosition(1, model.tiltCentideg(0.2)),
                                   pelco_d::setZoomPosition(1, model.zoom.position(4.0))};
  PelcoDBusEmulator bus(model, plant, {1}, true);
  PelcoDHead head(model, line, 1, true, plant);
  head.start(0);
  measure(head, bus, 0);
  ASSERT_TRUE(head.measured());
  head.inquire(0.1, 0.5);  // asked just before the unplugging: never answered
  ASSERT_EQ(frames(1).size(), 1u);
  pty.hangUp();
  head.receive(0.2);
  EXPECT_EQ(head.stats().errors, 1);
  EXPECT_EQ(head.stats().last_error,
            "serial device '" + link.path() + "' hung up (adapter unplugged?), reopening in 0.5 s");
  PtyPair plugged_back;
  link.pointTo(plugged_back.path());
  wire = &plugged_back;
  head.receive(0.69);
  EXPECT_EQ(head.stats().reopens, 0) << "not before the back-off";
  head.receive(0.7);
  EXPECT_EQ(head.stats().reopens, 1);
  EXPECT_FALSE(head.measured()) << "until answered again";
  // The round starts over with the pan query (not the tilt query after the lost answer).
  head.inquire(0.8, 0.5);
  EXPECT_EQ(serve(bus, 1, 0.8), std::vector<Bytes>{pelco_d::queryPan(1)});
  ASSERT_TRUE(read(head, 0.8, [&] { return head.stats().replies == 4; }));
  EXPECT_FALSE(head.measured());
  for (int i = 5; i <= 6; ++i) {
    head.inquire(0.8, 0.5);
    serve(bus, 1, 0.8);
    ASSERT_TRUE(read(head, 0.8, [&] { return head.stats().replies == i; }));
  }
  ASSERT_TRUE(head.measured());
  EXPECT_EQ(head.measuredAtS(), 0.8);
  head.command({0.5, 0.2, 4.0}, 0.9);
  EXPECT_EQ(serve(bus, 3, 0.9), pose);
  EXPECT_EQ(head.stats().malformed, 0);
}

TEST_F(PelcoSerial, AfterAReopenWithoutQueriesThePoseIsUnknownUntilHomedAgain) {
  const std::vector<Bytes> pose = {pelco_d::setPanPosition(1, model.panCentideg(0.5)),
                                   pelco_d::setTiltPosition(1, model.tiltCentideg(0.2)),
                                   pelco_d::setZoomPosition(1, model.zoom.position(4.0))};
  PelcoDBusEmulator bus(model, plant, {1}, false);
  PelcoDHead head(model, line, 1, false, plant);
  const std::vector<Bytes> home = {pelco_d::setPanPosition(1, 0), pelco_d::setTiltPosition(1, 0),
                                   pelco_d::setZoomPosition(1, 0)};
  head.start(0);
  EXPECT_EQ(serve(bus, 3, 0), home);
  head.inquire(3.0, 0.1);
  ASSERT_TRUE(head.measured());  // homed (2.333 s)
  pty.hangUp();
  head.receive(3.0);
  EXPECT_EQ(head.stats().errors, 1);
  const int64_t sent = head.stats().sent;
  head.command({0.5, 0.2, 4.0}, 3.1);
  EXPECT_EQ(head.stats().sent, sent) << "nothing goes out meanwhile";
  PtyPair plugged_back;
  link.pointTo(plugged_back.path());
  wire = &plugged_back;
  head.receive(3.5);
  EXPECT_EQ(head.stats().reopens, 1);
  head.inquire(3.5, 0.1);
  EXPECT_FALSE(head.measured()) << "where it is now is unknown";
  // The driver asks it to find its position: home, and the estimate once it must be there.
  PtzHead& as_driver = head;
  as_driver.findPosition(3.6);
  EXPECT_EQ(serve(bus, 3, 3.6), home);
  head.inquire(5.9, 0.1);
  EXPECT_FALSE(head.measured()) << "the homing takes 2.333 s";
  head.inquire(5.94, 0.1);
  ASSERT_TRUE(head.measured());
  EXPECT_EQ(head.measured()->pan_rad, 0.0);
  head.command({0.5, 0.2, 4.0}, 6.0);
  EXPECT_EQ(serve(bus, 3, 6.0), pose);
  EXPECT_EQ(head.stats().errors, 1);
}
