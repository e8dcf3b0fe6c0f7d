#include "ptz_driver/cameras/stereo_pairer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "common/measure.hpp"

namespace ptz::driver {
namespace {

constexpr size_t kRecent = 64;  // frames per side, and offsets, behind the typical offset

}  // namespace

void StereoPairer::add(Side side, CapturedFrame frame, int64_t arrival_utime) {
  const auto s = static_cast<size_t>(side);
  if (first_arrival_[s] == 0) first_arrival_[s] = arrival_utime;
  last_arrival_[s] = arrival_utime;
  const int64_t t = frame.capture_utime;
  if (newest_[s] && t <= *newest_[s]) {  // out of order: it can no longer be decided in order
    ++unmatched_[s];
    return;
  }
  newest_[s] = t;
  recent_[s].push_back(t);
  if (recent_[s].size() > kRecent) recent_[s].pop_front();
  buffer_[s].push_back({std::move(frame), arrival_utime});
  if (buffer_[s].size() > params_.buffer_frames) unmatch(s);
  decide();
}

void StereoPairer::setEnded(Side side) {
  ended_[static_cast<size_t>(side)] = true;
  decide();
}

std::vector<StereoPair> StereoPairer::takePairs() {
  std::vector<StereoPair> out;
  out.swap(made_);
  return out;
}

void StereoPairer::decide() {
  const int64_t tol = params_.tolerance_us;
  for (;;) {
    const bool has_l = !buffer_[0].empty(), has_r = !buffer_[1].empty();
    if (!has_l && !has_r) return;
    if (has_l && has_r) {
      // a: the side with the oldest waiting frame; b's frames are all at or after it.
      const size_t a =
          buffer_[0].front().frame.capture_utime <= buffer_[1].front().frame.capture_utime ? 0 : 1;
      const size_t b = 1 - a;
      const int64_t ta = buffer_[a].front().frame.capture_utime;
      if (buffer_[b].front().frame.capture_utime - ta > tol) {
        unmatch(a);
        continue;
      }
      Waiting& l = buffer_[0].front();
      Waiting& r = buffer_[1].front();
      pushOffset(r.frame.capture_utime - l.frame.capture_utime);
      last_pair_arrival_ = std::max(l.arrival_utime, r.arrival_utime);
      made_.push_back(StereoPair{std::move(l.frame), std::move(r.frame),
                                 std::min(l.arrival_utime, r.arrival_utime)});
      buffer_[0].pop_front();
      buffer_[1].pop_front();
      ++pairs_;
      continue;
    }
    const size_t a = has_l ? 0 : 1, b = 1 - a;
    // The other side has nothing waiting: its later frames come after its newest one.
    const int64_t ta = buffer_[a].front().frame.capture_utime;
    if (ended_[b] || (newest_[b] && *newest_[b] >= ta + tol)) {
      unmatch(a);
      continue;
    }
    return;  // a frame of b may still come within the tolerance
  }
}

void StereoPairer::unmatch(size_t side) {
  sampleOffset(side, buffer_[side].front().frame.capture_utime);
  buffer_[side].pop_front();
  ++unmatched_[side];
}

void StereoPairer::sampleOffset(size_t side, int64_t t) {
  const auto& other = recent_[1 - side];
  if (other.empty()) return;
  int64_t nearest = other.front();
  for (int64_t o : other) {
    if (std::llabs(o - t) < std::llabs(nearest - t)) nearest = o;
  }
  pushOffset(side == 0 ? nearest - t : t - nearest);
}

void StereoPairer::pushOffset(int64_t right_minus_left_us) {
  offsets_us_.push_back(right_minus_left_us);
  if (offsets_us_.size() > kRecent) offsets_us_.pop_front();
}

std::optional<double> StereoPairer::typicalOffsetS() const {
  if (offsets_us_.empty()) return std::nullopt;
  return percentile({offsets_us_.begin(), offsets_us_.end()}, 50) * 1e-6;
}

std::string StereoPairer::noPairMessage(int64_t now_utime) const {
  if (first_arrival_[0] == 0 || first_arrival_[1] == 0) return "";
  const auto warn_us = static_cast<int64_t>(params_.no_pair_warn_s * 1e6);
  if (now_utime - last_arrival_[0] > warn_us || now_utime - last_arrival_[1] > warn_us) return "";
  const int64_t since = std::max({last_pair_arrival_, first_arrival_[0], first_arrival_[1]});
  if (now_utime - since < warn_us) return "";
  char buf[256];
  const double tolerance_s = static_cast<double>(params_.tolerance_us) * 1e-6;
  const double quiet_s = static_cast<double>(now_utime - since) * 1e-6;
  if (const auto offset = typicalOffsetS()) {
    std::snprintf(buf, sizeof buf,
                  "no stereo pair in %.1f s: right is %.3f s %s left (tolerance %.3f s); check "
                  "the clocks or raise pair_tolerance_s",
                  quiet_s, std::fabs(*offset), *offset >= 0 ? "behind" : "ahead of", tolerance_s);
  } else {
    std::snprintf(buf, sizeof buf,
                  "no stereo pair in %.1f s (tolerance %.3f s); check the clocks or raise "
                  "pair_tolerance_s",
                  quiet_s, tolerance_s);
  }
  return buf;
}

}  // namespace ptz::driver
