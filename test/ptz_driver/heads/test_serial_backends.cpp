// The serial backends' parameters checked by name, the right camera's address on a shared or
// own line, and a serial line that reopens its port with back-off after the adapter is gone.
#include <gtest/gtest.h>

#include "common/plant.hpp"
#include "ptz_driver/heads/common/head_book.hpp"
#include "ptz_driver/heads/head_factory.hpp"
#include "ptz_driver/heads/pelco_d/pelco_d_head.hpp"
#include "ptz_driver/io/backoff.hpp"
#include "ptz_driver/io/serial_port.hpp"
#include "support/error_of.hpp"
#include "support/hardware/pty_pair.hpp"

using ptz::driver::Bytes;
using ptz::driver::SerialPort;
using ptz::test::errorOf;
using ptz::test::PtyPair;
using namespace std::chrono_literals;

namespace {
const std::string kConfig = PTZ_SOURCE_DIR "/config/";

ptz::Params driverParams() {
  ptz::Params p("test", "");
  ptz::addAxisLimitParams(p);
  ptz::driver::declareBackendParams(p);
  return p;
}
}  // namespace

TEST(SerialBackends, ParametersAreCheckedByName) {
  PtyPair pty;
  ptz::Params p = driverParams();
  p.set("backend", "visca_serial");
  EXPECT_EQ(errorOf([&] { ptz::driver::makeHeads(p); }),
            "parameter 'visca_model' is required with backend visca_serial");
  p.set("visca_model", kConfig + "visca/sony_evi_d70.yaml");
  p.set("left_serial_device", "/dev/ttyUSB_missing");
  p.set("right_serial_device", "/dev/ttyUSB_missing");
  EXPECT_EQ(errorOf([&] { ptz::driver::makeHeads(p); }),
            "parameter 'left_serial_device': serial device '/dev/ttyUSB_missing' does not exist "
            "(adapter unplugged? see ls /dev/serial/by-id/)");
  p.set("left_serial_device", pty.path());
  p.set("right_serial_device", pty.path());
  p.set("serial_baud", "14400");
  EXPECT_NE(errorOf([&] { ptz::driver::makeHeads(p); }).find("parameter 'serial_baud'"),
            std::string::npos);
  p.set("serial_baud", "9600");
  p.set("right_visca_address", "1");
  EXPECT_NE(errorOf([&] { ptz::driver::makeHeads(p); }).find("two addresses"), std::string::npos);
  EXPECT_EQ(errorOf([&] { p.set("right_visca_address", "8"); }),
            "set: parameter 'right_visca_address' must be within 0 .. 7, got '8'");
  p.set("right_visca_address", "0");
  p.set("backend", "pelco_d");
  p.set("pelco_model", kConfig + "pelco_d/generic.yaml");
  p.set("right_pelco_address", "1");
  EXPECT_NE(errorOf([&] { ptz::driver::makeHeads(p); }).find("two addresses"), std::string::npos);
  p.set("backend", "stepper");
  EXPECT_EQ(errorOf([&] { ptz::driver::makeHeads(p); }),
            "set: parameter 'backend' must be visca_ip, visca_serial, pelco_d, gpio or onvif, got "
            "'stepper'");
}

// right_visca_address 0: 2 on the left's line (a daisy chain), 1 on a line of its own.
TEST(SerialBackends, TheRightCameraIsAddressTwoOnASharedLineAndOneOnItsOwn) {
  PtyPair a, b;
  for (const bool shared : {true, false}) {
    ptz::Params p = driverParams();
    p.set("backend", "visca_serial");
    p.set("visca_model", kConfig + "visca/sony_evi_d70.yaml");
    p.set("left_serial_device", a.path());
    p.set("right_serial_device", shared ? a.path() : b.path());
    auto heads = ptz::driver::makeHeads(p);
    EXPECT_EQ(heads[0]->fd() == heads[1]->fd(), shared);
    heads[1]->inquire(0, 0.1);
    const auto packets = ptz::test::readViscaPackets(shared ? a : b, 1);
    ASSERT_EQ(packets.size(), 1u);
    EXPECT_EQ(packets[0],
              (Bytes{static_cast<uint8_t>(shared ? 0x82 : 0x81), 0x09, 0x06, 0x12, 0xFF}));
  }
}

// The adapter unplugged and its device path gone: the line tries to open it again after 0.5,
// 1, 2, 4, 8, 8 s, saying when; the outage is one error; once it is back the line is open.
TEST(SerialLine, AFailedPortIsOpenedAgainWithBackOffAndSaysWhen) {
  auto pty = std::make_unique<PtyPair>();
  ptz::test::DeviceLink link(pty->path());
  ptz::driver::PelcoDLine line(link.path(), 2400, "pelco_baud");
  ptz::driver::HeadBook book;
  const std::string device = "serial device '" + link.path() + "'";
  pty->hangUp();
  link.remove();
  line.pump(&book, 100);
  EXPECT_EQ(line.fd(), -1);
  EXPECT_EQ(line.problem(100), device + " hung up (adapter unplugged?), reopening in 0.5 s");
  std::string why = device + " hung up (adapter unplugged?)";
  double t = 100.5;
  for (const double wait : {1.0, 2.0, 4.0, 8.0, 8.0}) {
    line.pump(&book, t - 0.125);
    EXPECT_EQ(line.problem(t - 0.125), why + ", reopening in 0.1 s") << "not yet at " << t;
    line.pump(&book, t);
    why = device + " does not exist (adapter unplugged? see ls /dev/serial/by-id/)";
    EXPECT_EQ(line.problem(t), why + ", reopening in " + ptz::driver::secondsText(wait))
        << "at " << t;
    t += wait;
  }
  EXPECT_EQ(book.stats().errors, 1) << "one outage, one error";
  EXPECT_EQ(line.reopens(), 0);
  pty = std::make_unique<PtyPair>();  // plugged back
  link.pointTo(pty->path());
  line.pump(&book, t);
  EXPECT_EQ(line.reopens(), 1);
  EXPECT_EQ(book.stats().reopens, 1);
  EXPECT_EQ(line.problem(t), "");
  EXPECT_GE(line.fd(), 0);
  EXPECT_TRUE(line.send({0xFF, 0x01, 0x00, 0x00, 0x00, 0x00, 0x01}));
  EXPECT_EQ(pty->read(2000ms).size(), 7u);
}
