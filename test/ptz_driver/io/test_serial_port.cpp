// The serial port of the serial heads (raw 8N1 through a pseudo-terminal), with errors that name
// the device and the parameter, and the back-off schedule of what reopens.
#include <gtest/gtest.h>

#include "common/config.hpp"
#include "ptz_driver/heads/common/head_book.hpp"  // waitUntil
#include "ptz_driver/io/backoff.hpp"
#include "ptz_driver/io/serial_port.hpp"
#include "support/error_of.hpp"
#include "support/hardware/pty_pair.hpp"

using ptz::driver::Bytes;
using ptz::driver::SerialPort;
using ptz::test::errorOf;
using ptz::test::PtyPair;
using namespace std::chrono_literals;

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

TEST(Backoff, WaitsHalfASecondThenDoublesUpToEightAndStartsOverAfterASuccess) {
  ptz::driver::Backoff b(0.5, 8.0);
  EXPECT_TRUE(b.due(0)) << "the first attempt at once";
  std::vector<double> waits;
  double t = 0;
  for (int i = 0; i < 6; ++i) {
    waits.push_back(b.failed(t));
    t += waits.back();
    EXPECT_FALSE(b.due(t - 0.125));
    EXPECT_TRUE(b.due(t));
  }
  EXPECT_EQ(waits, (std::vector<double>{0.5, 1, 2, 4, 8, 8}));
  b.succeeded();
  EXPECT_EQ(b.failed(t), 0.5);
}
