// Waiting on LCM messages in tests: handle until a condition holds or a deadline passes.
#pragma once

#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace ptz::test {

// Multicast inside the test's private network namespace (see run_in_netns.sh).
constexpr const char* kTestUrl = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304";

// Handles messages until done() or the timeout; returns done().
inline bool handleUntil(lcm::LCM& lcm, const std::function<bool()>& done,
                        std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return done();
    lcm.handleTimeout(static_cast<int>(std::min<int64_t>(left.count(), 50)));
  }
  return true;
}

// Handles messages until none arrived for `quiet` (the publisher has finished).
inline void drain(lcm::LCM& lcm, std::chrono::milliseconds quiet) {
  while (lcm.handleTimeout(static_cast<int>(quiet.count())) > 0) {
  }
}

inline uint64_t fnv1a(const std::vector<uint8_t>& bytes, uint64_t h = 1469598103934665603ULL) {
  for (uint8_t b : bytes) h = (h ^ b) * 1099511628211ULL;
  return h;
}

}  // namespace ptz::test
