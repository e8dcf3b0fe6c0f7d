#include "ptz_driver/heads/common/head_book.hpp"

#include <poll.h>

#include <algorithm>
#include <chrono>

namespace ptz::driver {

bool HeadBook::inquiryDue(double now_s, double timeout_s) {
  if (inquiry_sent_s_ < 0) return true;
  if (now_s - inquiry_sent_s_ < timeout_s) return false;
  ++stats_.timeouts;
  inquiry_sent_s_ = -1;
  return true;
}

void HeadBook::roundTrip(double sent_s, double now_s) {
  stats_.round_trip_ms.push_back((now_s - sent_s) * 1000);
  measured_at_s_ = (sent_s + now_s) / 2;
}

void HeadBook::error(const std::string& name) {
  ++stats_.errors;
  stats_.last_error = name;
}

void HeadBook::bufferFull(double now_s) {
  ++stats_.buffer_full;
  buffer_full_since_s_ = now_s;
}

bool waitUntil(int fd, double timeout_s, const std::function<void()>& receive,
               const std::function<bool()>& done) {
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::microseconds(static_cast<int64_t>(timeout_s * 1e6));
  while (!done()) {
    const auto left_ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                             deadline - std::chrono::steady_clock::now())
                             .count();
    if (left_ms <= 0) return done();
    pollfd pfd{fd, POLLIN, 0};
    ::poll(&pfd, 1, static_cast<int>(std::min<int64_t>(left_ms, 5)));
    receive();
  }
  return true;
}

}  // namespace ptz::driver
