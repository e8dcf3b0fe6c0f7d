// The serial port of the serial heads (raw 8N1 through a pseudo-terminal), and what the
// serial backends make of their parameters: errors that name the parameter and the device,
// one line shared when both heads name the same device.
#include <gtest/gtest.h>

#include "ptz/plant.hpp"
#include "ptz_driver/head_book.hpp"
#include "ptz_driver/head_factory.hpp"
#include "ptz_driver/serial_port.hpp"
#include "support/pty_pair.hpp"

using ptz::driver::Bytes;
using ptz::driver::SerialPort;
using ptz::test::PtyPair;
using namespace std::chrono_literals;

namespace {
const std::string kConfig = PTZ_SOURCE_DIR "/config/";

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

ptz::Params driverParams() {
  ptz::Params p("test", "");
  ptz::addPlantParams(p);
  ptz::driver::declareBackendParams(p);
  return p;
}
}  // namespace

TEST(SerialPort, CarriesBytesBothWaysRaw) {
  PtyPair pty;
  SerialPort port(pty.path(), 9600);
  // Bytes a cooked tty would eat or change: XON/XOFF, CR, NL, EOF, DEL, 0xFF.
  const Bytes out = {0x11, 0x13, 0x0D, 0x0A, 0x04, 0x7F, 0xFF, 0x00, 0x88};
  ASSERT_TRUE(port.write(out));
  EXPECT_EQ(pty.readUntil([&](const Bytes& b) { return b.size() >= out.size(); }), out);
  pty.write(out);
  Bytes in;
  ptz::driver::waitUntil(
      port.fd(), 2.0, [&] { port.read(&in); }, [&] { return in.size() >= out.size(); });
  EXPECT_EQ(in, out);
  EXPECT_EQ(port.outputPending(), 0u);
}

TEST(SerialPort, ErrorsNameTheDeviceAndTheParameter) {
  EXPECT_NE(errorOf([] {
              SerialPort("/dev/ttyUSB_missing", 9600);
            }).find("serial device '/dev/ttyUSB_missing' does not exist"),
            std::string::npos);
  EXPECT_NE(
      errorOf([] { SerialPort("/dev/null", 9600); }).find("'/dev/null' is not a serial device"),
      std::string::npos);
  PtyPair pty;
  for (int baud : {2400, 4800, 9600, 19200, 38400, 115200}) {
    EXPECT_NO_THROW(SerialPort(pty.path(), baud));
  }
  EXPECT_THROW(SerialPort(pty.path(), 57601, "serial_baud"), ptz::ConfigError);
  EXPECT_EQ(errorOf([&] { SerialPort(pty.path(), 1234, "serial_baud"); }),
            "parameter 'serial_baud': 1234 is not a supported baud rate (2400, 4800, 9600, 19200, "
            "38400, 115200)");
}

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
  p.set("right_visca_address", "8");
  EXPECT_EQ(errorOf([&] { ptz::driver::makeHeads(p); }),
            "parameter 'right_visca_address': address 8 is not in 1..7");
  p.set("backend", "pelco_d");
  p.set("pelco_model", kConfig + "pelco_d/generic.yaml");
  p.set("right_pelco_address", "1");
  EXPECT_NE(errorOf([&] { ptz::driver::makeHeads(p); }).find("two addresses"), std::string::npos);
  p.set("backend", "can_bus");  // (gpio is a backend since the GPIO heads were merged)
  EXPECT_NE(errorOf([&] { ptz::driver::makeHeads(p); }).find("unknown backend 'can_bus'"),
            std::string::npos);
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
