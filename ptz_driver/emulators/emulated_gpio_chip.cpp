#include "ptz_driver/emulators/emulated_gpio_chip.hpp"

#include <algorithm>
#include <cmath>

#include "common/config.hpp"

namespace ptz::driver {
namespace {

// A and B (A leads B going up) of count k: 00, 10, 11, 01.
bool levelA(int64_t k) {
  return ((k % 4) + 4) % 4 == 1 || ((k % 4) + 4) % 4 == 2;
}
bool levelB(int64_t k) {
  return ((k % 4) + 4) % 4 >= 2;
}
int64_t countAt(double rad, double counts_per_rad) {
  return static_cast<int64_t>(std::floor(rad * counts_per_rad));
}

}  // namespace

EmulatedGpioChip::EmulatedGpioChip(std::vector<EmulatedAxisSpec> axes, double start_s,
                                   double substep_s)
    : now_s_(start_s), substep_s_(substep_s) {
  for (auto& spec : axes) {
    Axis a;
    a.spec = spec;
    a.position_rad = a.max_rad = a.min_rad = spec.start_rad;
    const int64_t k = countAt(spec.start_rad, spec.counts_per_rad);
    const AxisLines& l = spec.lines;
    for (int out : {l.dir, l.dir2, l.enable}) {
      if (out >= 0) lines_[out].output = true;
    }
    lines_[l.encoder_a].level = levelA(k);
    lines_[l.encoder_b].level = levelB(k);
    lines_[l.limit_min].level = spec.start_rad > spec.min_switch_rad;  // open: pulled up
    lines_[l.limit_max].level = spec.start_rad < spec.max_switch_rad;
    axes_.push_back(a);
  }
}

void EmulatedGpioChip::addOutput(int offset) {
  std::lock_guard<std::mutex> lock(mutex_);
  lines_[offset].output = true;
}

EmulatedGpioChip::Line& EmulatedGpioChip::line(int offset, const std::string& name) {
  const auto it = lines_.find(offset);
  if (it == lines_.end() || it->second.requested) {
    throw ConfigError("parameter '" + name + "': the simulated GPIO chip has no line " +
                      std::to_string(offset) + " to give");
  }
  it->second.requested = true;
  return it->second;
}

void EmulatedGpioChip::requestOutput(int offset, const std::string& name, bool idle_high) {
  std::lock_guard<std::mutex> lock(mutex_);
  Line& l = line(offset, name);
  if (!l.output) throw ConfigError("parameter '" + name + "': simulated line is an input");
  l.level = idle_high;
}

void EmulatedGpioChip::requestEvents(int offset, Bias, const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (line(offset, name).output)
    throw ConfigError("parameter '" + name + "': simulated line is an output");
}

void EmulatedGpioChip::set(int offset, bool high) {
  std::lock_guard<std::mutex> lock(mutex_);
  tick();
  const auto it = lines_.find(offset);
  if (it == lines_.end() || !it->second.requested || !it->second.output) {
    ++io_errors_;
    return;
  }
  if (high && !it->second.level) ++it->second.rising;
  it->second.level = high;
}

bool EmulatedGpioChip::get(int offset) {
  std::lock_guard<std::mutex> lock(mutex_);
  tick();
  const auto it = lines_.find(offset);
  if (it == lines_.end() || !it->second.requested) {
    ++io_errors_;
    return false;
  }
  return it->second.level;
}

void EmulatedGpioChip::readEvents(std::vector<LineEvent>* out) {
  std::lock_guard<std::mutex> lock(mutex_);
  tick();
  out->insert(out->end(), events_.begin(), events_.end());
  events_.clear();
}

int64_t EmulatedGpioChip::ioErrors() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return io_errors_;
}

void EmulatedGpioChip::advanceTo(double t_s) {
  std::lock_guard<std::mutex> lock(mutex_);
  advance(t_s);
}

void EmulatedGpioChip::useClock(std::function<double()> clock) {
  std::lock_guard<std::mutex> lock(mutex_);
  clock_ = std::move(clock);
  now_s_ = clock_();
}

void EmulatedGpioChip::tick() {
  if (clock_) advance(clock_());
}

void EmulatedGpioChip::advance(double t_s) {
  while (now_s_ < t_s) {
    const double h_s = std::min(substep_s_, t_s - now_s_);
    step_events_.clear();
    for (auto& a : axes_) integrate(a, h_s);
    for (auto& [offset, l] : lines_) {
      if (l.output && l.level) l.high_s += h_s;
    }
    now_s_ += h_s;
    // Within a step the edges of all lines, in the order they happened.
    std::stable_sort(step_events_.begin(), step_events_.end(),
                     [](const LineEvent& x, const LineEvent& y) { return x.time_s < y.time_s; });
    for (const auto& e : step_events_) {
      if (lines_[e.line].requested) events_.push_back(e);
    }
  }
}

void EmulatedGpioChip::integrate(Axis& a, double h_s) {
  const EmulatedAxisSpec& s = a.spec;
  const AxisLines& l = s.lines;
  double drive = 0;  // -1, 0, +1: the bridge's output
  if (lines_[l.enable].level) {
    const bool up = lines_[l.dir].level;
    const bool shorted = l.dir2 >= 0 && lines_[l.dir2].level == up;  // IN1 = IN2: brake
    drive = shorted ? 0 : (up ? 1 : -1);
    if (s.reversed) drive = -drive;
  }
  // First order, solved exactly over the step.
  const double target = drive * s.max_speed_rad_s;
  const double decay = std::exp(-h_s / s.time_constant_s);
  const double p0 = a.position_rad;
  double p1 = p0 + target * h_s + (a.speed_rad_s - target) * s.time_constant_s * (1 - decay);
  a.speed_rad_s = target + (a.speed_rad_s - target) * decay;
  if (p1 <= s.min_stop_rad || p1 >= s.max_stop_rad) {
    p1 = std::clamp(p1, s.min_stop_rad, s.max_stop_rad);
    a.speed_rad_s = 0;
  }
  a.position_rad = p1;
  a.max_rad = std::max(a.max_rad, p1);
  a.min_rad = std::min(a.min_rad, p1);
  auto at = [&](double rad) {  // when the shaft passed rad within the step
    const double f = p1 == p0 ? 1.0 : std::clamp((rad - p0) / (p1 - p0), 0.0, 1.0);
    return now_s_ + h_s * f;
  };
  // One edge per count passed: A or B, whichever changes between the two counts.
  const int64_t k0 = countAt(p0, s.counts_per_rad), k1 = countAt(p1, s.counts_per_rad);
  const int64_t dir = k1 > k0 ? 1 : -1;
  for (int64_t k = k0; k != k1; k += dir) {
    const int64_t next = k + dir;
    const double boundary_rad = static_cast<double>(std::max(k, next)) / s.counts_per_rad;
    const bool a_changes = levelA(k) != levelA(next);
    const int changed = a_changes ? l.encoder_a : l.encoder_b;
    const bool level = a_changes ? levelA(next) : levelB(next);
    lines_[changed].level = level;
    step_events_.push_back({changed, level, at(boundary_rad)});
  }
  // Switches pull their lines low at and beyond their positions.
  const std::pair<int, bool> switches[2] = {{l.limit_min, p1 > s.min_switch_rad},
                                            {l.limit_max, p1 < s.max_switch_rad}};
  const double switch_rad[2] = {s.min_switch_rad, s.max_switch_rad};
  for (int i = 0; i < 2; ++i) {
    Line& sw = lines_[switches[i].first];
    if (sw.level == switches[i].second) continue;
    sw.level = switches[i].second;
    step_events_.push_back({switches[i].first, sw.level, at(switch_rad[i])});
  }
}

double EmulatedGpioChip::nowS() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return now_s_;
}
double EmulatedGpioChip::positionRad(size_t axis) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return axes_.at(axis).position_rad;
}
double EmulatedGpioChip::speedRadS(size_t axis) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return axes_.at(axis).speed_rad_s;
}
double EmulatedGpioChip::maxPositionRad(size_t axis) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return axes_.at(axis).max_rad;
}
double EmulatedGpioChip::minPositionRad(size_t axis) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return axes_.at(axis).min_rad;
}
bool EmulatedGpioChip::level(int offset) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = lines_.find(offset);
  return it != lines_.end() && it->second.level;
}
double EmulatedGpioChip::highTimeS(int offset) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = lines_.find(offset);
  return it == lines_.end() ? 0 : it->second.high_s;
}
int64_t EmulatedGpioChip::risingEdges(int offset) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = lines_.find(offset);
  return it == lines_.end() ? 0 : it->second.rising;
}

EmulatedGpioChip::OutputTally EmulatedGpioChip::tally(int offset) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = lines_.find(offset);
  if (it == lines_.end()) return {now_s_, 0, 0};
  return {now_s_, it->second.high_s, it->second.rising};
}

void EmulatedGpioChip::setSwitch(size_t axis, bool max_end, double position_rad) {
  std::lock_guard<std::mutex> lock(mutex_);
  Axis& a = axes_.at(axis);
  (max_end ? a.spec.max_switch_rad : a.spec.min_switch_rad) = position_rad;
}

void EmulatedGpioChip::injectEvent(int offset, bool rising) {
  std::lock_guard<std::mutex> lock(mutex_);
  events_.push_back({offset, rising, now_s_});
}

}  // namespace ptz::driver
