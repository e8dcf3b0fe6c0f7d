// Plays the heads' end of a serial line in a thread: whatever the driver (or a head) writes to
// the pty goes to an emulator at the time since the server started, its answers go back.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "support/hardware/pty_pair.hpp"

namespace ptz::test {

// Emulator: ViscaChainEmulator or PelcoDBusEmulator (feed(data, size, now_s) -> bytes back).
template <class Emulator>
class SerialServer {
 public:
  SerialServer(const PtyPair& pty, Emulator* emulator)
      : pty_(pty), emulator_(emulator), start_(std::chrono::steady_clock::now()) {
    thread_ = std::thread([this] { run(); });
  }
  ~SerialServer() { stop(); }
  void stop() {
    running_ = false;
    if (thread_.joinable()) thread_.join();
  }
  double nowS() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  // Runs f with the emulator while the server does not touch it.
  template <class F>
  auto with(F f) {
    std::lock_guard<std::mutex> lock(mutex_);
    return f(*emulator_);
  }
  // Whether done(emulator) came true within timeout (what was written may still be on its way
  // to the emulator when the writer returns).
  template <class F>
  bool waitFor(F done, std::chrono::milliseconds timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    return fed_.wait_for(lock, timeout, [&] { return done(*emulator_); });
  }

 private:
  void run() {
    while (running_) {
      const auto in = pty_.read(std::chrono::milliseconds(2));
      {
        std::lock_guard<std::mutex> lock(mutex_);
        pty_.write(emulator_->feed(in.data(), in.size(), nowS()));
      }
      fed_.notify_all();  // waitFor looks again after every turn of the emulator
    }
  }

  const PtyPair& pty_;
  Emulator* emulator_;
  std::chrono::steady_clock::time_point start_;
  std::atomic<bool> running_{true};
  std::mutex mutex_;
  std::condition_variable fed_;
  std::thread thread_;
};

}  // namespace ptz::test
