#include "ptz_driver/cameras/ptz_history.hpp"

#include <algorithm>
#include <cmath>

namespace ptz::driver {

PtzHistory::PtzHistory(double history_s, double max_extrapolation_s)
    : history_us_(std::llround(history_s * 1e6)),
      max_extrapolation_us_(std::llround(max_extrapolation_s * 1e6)) {}

bool PtzHistory::add(int64_t utime, const PtzPose& left, const PtzPose& right) {
  if (!states_.empty() && utime < states_.back().utime - history_us_) {
    // Not a late state but another time line: without this every state would be refused until
    // time passed the old newest again.
    states_.clear();
    ++restarts_;
  }
  if (!states_.empty() && utime <= states_.back().utime) return false;
  states_.push_back({utime, {left, right}});
  while (states_.size() > 2 && states_.front().utime < utime - history_us_) states_.pop_front();
  return true;
}

std::optional<int64_t> PtzHistory::newestUtime() const {
  if (states_.empty()) return std::nullopt;
  return states_.back().utime;
}

PtzLookup PtzHistory::at(Side side, int64_t utime) const {
  const auto s = static_cast<size_t>(side);
  if (states_.empty()) return {PtzPose{}, true};
  if (utime <= states_.front().utime) {
    return {states_.front().pose[s], states_.front().utime - utime > max_extrapolation_us_};
  }
  if (utime >= states_.back().utime) {
    return {states_.back().pose[s], utime - states_.back().utime > max_extrapolation_us_};
  }
  // The first state after utime, and the one before it.
  const auto after = std::upper_bound(states_.begin(), states_.end(), utime,
                                      [](int64_t t, const State& st) { return t < st.utime; });
  const State& b = *after;
  const State& a = *(after - 1);
  const double w = static_cast<double>(utime - a.utime) / static_cast<double>(b.utime - a.utime);
  const PtzPose& pa = a.pose[s];
  const PtzPose& pb = b.pose[s];
  return {PtzPose{pa.pan_rad + w * (pb.pan_rad - pa.pan_rad),
                  pa.tilt_rad + w * (pb.tilt_rad - pa.tilt_rad), pa.zoom + w * (pb.zoom - pa.zoom)},
          false};
}

}  // namespace ptz::driver
