// A pseudo-terminal pair for the serial heads' tests: the head opens the slave by its path, as
// a user passes /dev/ttyUSB0; the test plays the cameras on the master. A pty does not pace
// bytes at the baud rate: what a real line adds is computed from the byte counts.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <stdlib.h>
#include <unistd.h>

#include <cstdio>

#include <chrono>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace ptz::test {

class PtyPair {
 public:
  using Bytes = std::vector<uint8_t>;

  PtyPair() {
    char name[256] = {};
    if (::openpty(&master_, &slave_, name, nullptr, nullptr) != 0) {
      throw std::runtime_error("openpty failed");
    }
    path_ = name;
    ::fcntl(master_, F_SETFL, ::fcntl(master_, F_GETFL) | O_NONBLOCK);
    // Not inherited by a driver the test starts: hangUp() must close the last master.
    ::fcntl(master_, F_SETFD, FD_CLOEXEC);
    ::fcntl(slave_, F_SETFD, FD_CLOEXEC);
  }
  ~PtyPair() {
    if (master_ >= 0) ::close(master_);
    if (slave_ >= 0) ::close(slave_);  // kept open so the master never reads EIO meanwhile
  }
  PtyPair(const PtyPair&) = delete;
  PtyPair& operator=(const PtyPair&) = delete;

  const std::string& path() const { return path_; }
  // The far end goes away, as when a USB adapter is unplugged: the slave side hangs up.
  void hangUp() {
    ::close(master_);
    ::close(slave_);
    master_ = slave_ = -1;
  }
  int master() const { return master_; }

  void write(const Bytes& b) const {
    if (!b.empty() && ::write(master_, b.data(), b.size()) != static_cast<ssize_t>(b.size())) {
      throw std::runtime_error("write to the pty master failed");
    }
  }
  // Whatever the head has written, waiting at most timeout for anything at all.
  Bytes read(std::chrono::milliseconds timeout) const {
    Bytes out;
    pollfd pfd{master_, POLLIN, 0};
    if (::poll(&pfd, 1, static_cast<int>(timeout.count())) <= 0) return out;
    uint8_t buffer[512];
    ssize_t n;
    while ((n = ::read(master_, buffer, sizeof(buffer))) > 0)
      out.insert(out.end(), buffer, buffer + n);
    return out;
  }
  // Reads until complete(all read so far) or the timeout (then what came).
  Bytes readUntil(const std::function<bool(const Bytes&)>& complete,
                  std::chrono::milliseconds timeout = std::chrono::milliseconds(2000)) const {
    Bytes all;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!complete(all) && std::chrono::steady_clock::now() < deadline) {
      const Bytes b = read(std::chrono::milliseconds(20));
      all.insert(all.end(), b.begin(), b.end());
    }
    return all;
  }

 private:
  int master_ = -1, slave_ = -1;
  std::string path_;
};

// The device path a user passes (like a udev link /dev/serial/by-id/usb-FTDI_...): a symlink
// to a pty's slave, re-pointed to another pty when the "adapter" is plugged back in.
class DeviceLink {
 public:
  explicit DeviceLink(const std::string& target) {
    char dir[] = "/tmp/ptz_serial_XXXXXX";
    if (::mkdtemp(dir) == nullptr) throw std::runtime_error("mkdtemp failed");
    dir_ = dir;
    path_ = dir_ + "/ttyUSB0";
    pointTo(target);
  }
  ~DeviceLink() {
    remove();
    ::rmdir(dir_.c_str());
  }
  DeviceLink(const DeviceLink&) = delete;
  DeviceLink& operator=(const DeviceLink&) = delete;

  const std::string& path() const { return path_; }
  // Atomically, as udev does: the path never dangles half-way.
  void pointTo(const std::string& target) {
    const std::string next = path_ + ".next";
    if (::symlink(target.c_str(), next.c_str()) != 0 ||
        std::rename(next.c_str(), path_.c_str()) != 0) {
      throw std::runtime_error("cannot point " + path_ + " to " + target);
    }
  }
  // The adapter is gone: so is its link.
  void remove() { ::unlink(path_.c_str()); }

 private:
  std::string dir_, path_;
};

// Splits VISCA bytes into packets at the terminator 0xFF.
inline std::vector<PtyPair::Bytes> viscaPackets(const PtyPair::Bytes& b) {
  std::vector<PtyPair::Bytes> packets(1);
  for (uint8_t x : b) {
    packets.back().push_back(x);
    if (x == 0xFF) packets.emplace_back();
  }
  packets.pop_back();
  return packets;
}

// Reads until `count` whole VISCA packets came; returns them.
inline std::vector<PtyPair::Bytes> readViscaPackets(const PtyPair& pty, size_t count) {
  const auto b = pty.readUntil([count](const PtyPair::Bytes& all) {
    size_t n = 0;
    for (uint8_t x : all) n += x == 0xFF;
    return n >= count;
  });
  return viscaPackets(b);
}

}  // namespace ptz::test
