#include "ptz_driver/io/serial_port.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "common/config.hpp"

namespace ptz::driver {
namespace {

speed_t speedOf(int baud) {
  switch (baud) {
    case 2400:
      return B2400;
    case 4800:
      return B4800;
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 115200:
      return B115200;
    default:
      return B0;
  }
}

std::string openError(const std::string& device, int error) {
  const std::string d = "serial device '" + device + "'";
  switch (error) {
    case ENOENT:
      return d + " does not exist (adapter unplugged? see ls /dev/serial/by-id/)";
    case EACCES:
      return "no permission to open " + d + " (add the user to group dialout)";
    case EBUSY:
      return d + " is in use by another process";
    default:
      return "cannot open " + d + ": " + std::strerror(error);
  }
}

}  // namespace

void checkBaud(int baud, const std::string& parameter) {
  if (speedOf(baud) == B0) {
    throw ConfigError("parameter '" + parameter + "': " + std::to_string(baud) +
                      " is not a supported baud rate (2400, 4800, 9600, 19200, 38400, 115200)");
  }
}

SerialPort::SerialPort(const std::string& device, int baud, const std::string& baud_parameter)
    : device_(device) {
  checkBaud(baud, baud_parameter);
  fd_ = ::open(device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) throw std::runtime_error(openError(device, errno));
  termios t{};
  if (!::isatty(fd_) || ::tcgetattr(fd_, &t) != 0) {
    ::close(fd_);
    throw std::runtime_error("'" + device + "' is not a serial device");
  }
  if (::ioctl(fd_, TIOCEXCL) != 0) {
    const int e = errno;
    ::close(fd_);
    throw std::runtime_error(openError(device, e));
  }
  ::cfmakeraw(&t);  // 8 data bits, no parity, no echo, no line editing
  t.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | PARENB | CRTSCTS);  // one stop bit, no RTS/CTS
  t.c_cflag |= CLOCAL | CREAD;
  t.c_cc[VMIN] = 0;
  t.c_cc[VTIME] = 0;
  ::cfsetispeed(&t, speedOf(baud));
  ::cfsetospeed(&t, speedOf(baud));
  if (::tcsetattr(fd_, TCSANOW, &t) != 0) {
    const int e = errno;
    ::close(fd_);
    throw std::runtime_error("cannot set serial device '" + device + "' to " +
                             std::to_string(baud) + " baud 8N1: " + std::strerror(e));
  }
  ::tcflush(fd_, TCIOFLUSH);  // what an earlier run left in the buffers is not ours
}

SerialPort::~SerialPort() {
  if (fd_ < 0) return;
  ::ioctl(fd_, TIOCNXCL);  // the next process (or test) may open it
  ::close(fd_);
}

bool SerialPort::flush() {
  while (!out_.empty()) {
    const ssize_t n = ::write(fd_, out_.data(), out_.size());
    if (n > 0) {
      out_.erase(out_.begin(), out_.begin() + n);
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) return true;  // the rest goes later
    error_ = "serial device '" + device_ + "': " + std::strerror(errno);
    return false;
  }
  return true;
}

bool SerialPort::write(const Bytes& data) {
  out_.insert(out_.end(), data.begin(), data.end());
  return flush();
}

bool SerialPort::read(Bytes* data) {
  if (!flush()) return false;
  uint8_t buffer[256];
  for (;;) {
    const ssize_t n = ::read(fd_, buffer, sizeof(buffer));
    if (n > 0) {
      data->insert(data->end(), buffer, buffer + n);
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) return true;
    if (n < 0) {
      error_ = "serial device '" + device_ + "': " + std::strerror(errno);
      return false;
    }
    // 0: nothing waiting (VMIN 0), or the device hung up (adapter unplugged): poll tells.
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 0) == 1 && (p.revents & (POLLHUP | POLLERR))) {
      error_ = "serial device '" + device_ + "' hung up (adapter unplugged?)";
      return false;
    }
    return true;
  }
}

size_t SerialPort::outputPending() {
  flush();
  int queued = 0;
  if (::ioctl(fd_, TIOCOUTQ, &queued) != 0) queued = 0;
  return out_.size() + static_cast<size_t>(queued > 0 ? queued : 0);
}

}  // namespace ptz::driver
