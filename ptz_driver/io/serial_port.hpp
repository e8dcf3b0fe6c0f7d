// A serial port (RS-232, or RS-485 through an adapter) as the heads use it: raw 8N1 at a fixed
// baud rate, non-blocking, exclusive (TIOCEXCL: a second driver on the same adapter fails at
// open instead of mixing its bytes in). Writes that the tty cannot take at once are kept and
// flushed later, so a packet never goes out in part.
#pragma once

#include <string>

#include "ptz_driver/io/bytes.hpp"

namespace ptz::driver {

// The baud rates a head's serial line may use: 2400, 4800, 9600, 19200, 38400, 115200.
// Throws ConfigError naming `parameter` for any other.
void checkBaud(int baud, const std::string& parameter);

class SerialPort {
 public:
  // Opens `device` raw 8N1 at `baud`. Throws ConfigError naming `baud_parameter` for a baud
  // rate not in the list, std::runtime_error naming the device when it is missing, not a
  // serial device, in use or not ours to open.
  SerialPort(const std::string& device, int baud, const std::string& baud_parameter = "baud");
  ~SerialPort();
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  // Queues data and writes what the tty takes now. False (and error() says why) when the
  // device has gone (adapter unplugged).
  bool write(const Bytes& data);
  // Appends whatever is waiting to *data. False (and error()) when the device has gone.
  bool read(Bytes* data);
  // Bytes written but not yet on the wire: ours still queued plus the driver's output queue
  // (TIOCOUTQ). A head sends the next packet only when this is 0, so it never sends faster
  // than the line carries.
  size_t outputPending();

  int fd() const { return fd_; }
  const std::string& device() const { return device_; }
  const std::string& error() const { return error_; }

 private:
  bool flush();

  std::string device_;
  int fd_ = -1;
  Bytes out_;
  std::string error_;
};

}  // namespace ptz::driver
