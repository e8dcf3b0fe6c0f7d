#include "ptz_driver/cameras/trigger.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "common/measure.hpp"

namespace ptz::driver {
namespace {

const std::array<const char*, 2> kSide = {"left", "right"};

std::string ms(double us) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f ms", us * 1e-3);
  return buf;
}

}  // namespace

int64_t TriggerParams::windowUs() const {
  const double w = window_s > 0 ? window_s : 0.25 / rate_hz;
  return std::llround(w * 1e6);
}

void declareTriggerParams(Params& p) {
  p.add("trigger_chip", "",
        "GPIO chip of a hardware trigger line for both cameras (name, number, /dev path or "
        "label; sim: a simulated chip; empty: no trigger, frames paired by their own times)");
  p.add("trigger_line", -1, "", "offset of the trigger output on trigger_chip (-1: none)",
        Range::between(-1, 4095));
  p.add("trigger_rate_hz", 30.0, "Hz", "trigger pulses a second (the cameras' frame rate)",
        Range::between(1, 1000));
  p.add("trigger_pulse_s", 0.001, "s", "how long each pulse is active (at most half the period)",
        Range::above(0));
  p.add("trigger_active_low", false, "pulses drive the line low (idle high)");
  p.add("trigger_window_s", 0.0, "s",
        "a frame whose capture time (grab or V4L2 buffer time minus latency) is this near a "
        "pulse answers it (0: a quarter of the period; below half the period)",
        Range::atLeast(0));
}

TriggerParams triggerParamsFrom(const Params& p, const std::array<bool, 2>& live) {
  TriggerParams t;
  t.chip = p.getString("trigger_chip");
  if (!t.enabled()) return t;
  t.line = p.getInt("trigger_line");
  t.rate_hz = p.getDouble("trigger_rate_hz");
  t.pulse_s = p.getDouble("trigger_pulse_s");
  t.active_low = p.getBool("trigger_active_low");
  t.window_s = p.getDouble("trigger_window_s");
  t.own_latency = {p.getDouble("left_latency_s") >= 0, p.getDouble("right_latency_s") >= 0};
  // Each number is within its declared range; what depends on another:
  if (t.line < 0) {
    throw p.invalid("trigger_line", "must be the offset of the trigger output on '" + t.chip + "'");
  }
  const double period_s = 1 / t.rate_hz;
  // At most half: a pulse whose edge came up to half a period late still ends before the next.
  if (t.pulse_s > period_s / 2) {
    throw p.invalid("trigger_pulse_s",
                    "must be at most half the period (" + formatNumber(period_s / 2) + " s)");
  }
  if (t.window_s >= period_s / 2) {
    throw p.invalid("trigger_window_s",
                    "must be below half the period (" + formatNumber(period_s / 2) + " s)");
  }
  for (size_t s = 0; s < 2; ++s) {
    if (!live[s]) {
      throw ConfigError("parameter 'trigger_chip' is set, but " + std::string(kSide[s]) +
                        "_source is a recording: only live cameras can be triggered");
    }
  }
  return t;
}

void TriggerLog::add(int64_t utime) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!times_.empty() && utime <= times_.back()) {
    times_.clear();
    ++epoch_;
  }
  times_.push_back(utime);
  if (times_.size() > capacity_) times_.pop_front();
  ++pulses_;
}

std::optional<TriggerLog::Nearest> TriggerLog::nearest(int64_t utime) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (times_.empty()) return std::nullopt;
  auto it = std::lower_bound(times_.begin(), times_.end(), utime);
  int64_t best = it == times_.end() ? times_.back() : *it;
  if (it != times_.begin() && std::llabs(utime - *std::prev(it)) <= std::llabs(utime - best)) {
    best = *std::prev(it);
  }
  return Nearest{best, utime - best, epoch_};
}

int64_t TriggerLog::pulses() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return pulses_;
}

int64_t TriggerLog::clockSteps() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return epoch_;
}

PulseClock realPulseClock() {
  PulseClock c;
  c.now_s = gpioClockS;
  c.sleep_until_s = gpioSleepUntilS;
  c.wall_utime = wallUtime;
  return c;
}

TriggerPulser::TriggerPulser(GpioLines& lines, const TriggerParams& params, TriggerLog& log,
                             PulseClock clock)
    : lines_(lines),
      params_(params),
      log_(log),
      clock_(std::move(clock)),
      period_s_(1 / params.rate_hz) {
  drive(false);
}

TriggerPulser::~TriggerPulser() {
  stop();
}

void TriggerPulser::drive(bool active) {
  lines_.set(params_.line, active != params_.active_low);
}

void TriggerPulser::start() {
  stop_ = false;
  thread_ = std::thread([this] {
    while (!stop_) run(1);
  });
}

void TriggerPulser::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  drive(false);
}

void TriggerPulser::run(int64_t periods) {
  if (start_s_ < 0) start_s_ = clock_.now_s();
  for (int64_t i = 0; i < periods; ++i) period(next_++);
}

void TriggerPulser::period(int64_t k) {
  const double t_s = start_s_ + static_cast<double>(k) * period_s_;
  clock_.sleep_until_s(t_s);
  const double late_s = clock_.now_s() - t_s;
  if (late_s > period_s_ / 2) {
    // Too late to be told apart from the next period's pulse: this one is not sent.
    ++missed_;
    return;
  }
  const int64_t before_utime = clock_.wall_utime();
  drive(true);
  const double edge_s = clock_.now_s();
  {
    std::lock_guard<std::mutex> lock(lateness_mutex_);
    lateness_s_.push_back(edge_s - t_s);
    if (lateness_s_.size() > 10000) lateness_s_.pop_front();
  }
  log_.add((before_utime + clock_.wall_utime()) / 2);
  // Full width from the edge, however late it came.
  clock_.sleep_until_s(edge_s + params_.pulse_s);
  drive(false);
}

std::vector<double> TriggerPulser::takeEdgeLatenessS() {
  std::lock_guard<std::mutex> lock(lateness_mutex_);
  std::vector<double> out(lateness_s_.begin(), lateness_s_.end());
  lateness_s_.clear();
  return out;
}

std::optional<int64_t> TriggerMatcher::match(Side side, int64_t capture_utime, int64_t now_utime) {
  const auto s = static_cast<size_t>(side);
  if (now_utime < newest_arrival_utime_) {  // the wall clock was stepped back: start over
    for (auto& r : recent_) r.clear();
  }
  newest_arrival_utime_ = now_utime;
  const std::optional<TriggerLog::Nearest> n = log_.nearest(capture_utime);
  if (n && n->epoch != last_epoch_[s]) {  // the pulses started again after a step
    last_pulse_[s].reset();
    last_epoch_[s] = n->epoch;
  }
  Verdict v = Verdict::kMatched;
  if (!n) {
    v = Verdict::kNoPulseYet;
  } else if (std::llabs(n->offset_us) > window_us_) {
    v = Verdict::kFar;
  } else if (last_pulse_[s] && n->pulse_utime <= *last_pulse_[s]) {
    v = Verdict::kRepeat;  // a pulse answers one frame: a second is not following the trigger
  }
  auto& recent = recent_[s];
  recent.push_back({now_utime, n ? n->offset_us : 0, v});
  while (!recent.empty() && recent.front().arrival_utime < now_utime - recent_us_) {
    recent.pop_front();
  }
  if (v != Verdict::kMatched) {
    ++unmatched_[s];
    return std::nullopt;
  }
  ++matched_[s];
  last_pulse_[s] = n->pulse_utime;
  return n->pulse_utime;
}

std::string TriggerLineHealth::update(int64_t now_utime, int64_t io_errors, int64_t missed_periods,
                                      bool* error) {
  if (io_errors > io_errors_) io_error_utime_ = now_utime;
  if (missed_periods > missed_) missed_utime_ = now_utime;
  io_errors_ = io_errors;
  missed_ = missed_periods;
  std::string out;
  *error = false;
  if (io_error_utime_ && now_utime - *io_error_utime_ < hold_us_) {
    *error = true;
    out = "trigger line " + std::to_string(line_) + ": " + std::to_string(io_errors) +
          " writes failed";
  }
  if (missed_utime_ && now_utime - *missed_utime_ < hold_us_) {
    out += (out.empty() ? "" : "; ") + std::string("trigger: ") + std::to_string(missed_periods) +
           " periods missed (the machine was busy: run under chrt -f)";
  }
  return out;
}

std::string TriggerMatcher::problem(int64_t now_utime, bool* error) const {
  std::string out;
  *error = false;
  for (size_t s = 0; s < 2; ++s) {
    std::map<Verdict, int64_t> count;
    int64_t total = 0;
    std::vector<double> far_us;
    for (const auto& seen : recent_[s]) {
      if (seen.arrival_utime < now_utime - recent_us_) continue;
      ++total;
      ++count[seen.verdict];
      if (seen.verdict == Verdict::kFar) far_us.push_back(std::fabs(double(seen.offset_us)));
    }
    const int64_t matched = count[Verdict::kMatched];
    if (matched == total) continue;
    const bool most_not = 2 * matched < total;
    *error = *error || most_not;
    char head[160];
    std::snprintf(head, sizeof head,
                  "%s camera: %lld of %lld frames in the last %.1f s answered no trigger pulse (",
                  kSide[s], static_cast<long long>(total - matched), static_cast<long long>(total),
                  static_cast<double>(recent_us_) * 1e-6);
    std::vector<std::string> why;
    if (count[Verdict::kFar] > 0) {
      why.push_back(std::to_string(count[Verdict::kFar]) + " none within " +
                    ms(static_cast<double>(window_us_)) + ", median distance " +
                    ms(percentile(far_us, 50)));
    }
    if (count[Verdict::kRepeat] > 0) {
      why.push_back(std::to_string(count[Verdict::kRepeat]) + " a second frame for one pulse");
    }
    if (count[Verdict::kNoPulseYet] > 0) {
      why.push_back(std::to_string(count[Verdict::kNoPulseYet]) + " before the first pulse");
    }
    std::string m = head;
    for (size_t i = 0; i < why.size(); ++i) m += (i ? "; " : "") + why[i];
    m += ")";
    if (most_not) {
      m += std::string(": is it in external-trigger mode and wired to the trigger line, and is ") +
           (own_latency_[s] ? std::string(kSide[s]) + "_latency_s" : "latency_s") +
           " its delay from the pulse?";
    }
    out += (out.empty() ? "" : "; ") + m;
  }
  return out;
}

void TriggerMatcher::addCounters(std::map<std::string, int64_t>* counters) const {
  for (size_t s = 0; s < 2; ++s) {
    const std::string side = kSide[s];
    (*counters)["trigger_matched_" + side] = matched_[s];
    (*counters)["trigger_unmatched_" + side] = unmatched_[s];
    std::vector<double> offsets_us;
    for (const auto& seen : recent_[s]) {
      if (seen.verdict == Verdict::kMatched &&
          seen.arrival_utime >= newest_arrival_utime_ - recent_us_) {
        offsets_us.push_back(static_cast<double>(seen.offset_us));
      }
    }
    // How far after its pulse a frame's capture time falls: what to add to its latency.
    if (!offsets_us.empty()) {
      (*counters)["trigger_offset_us_p50_" + side] = std::llround(percentile(offsets_us, 50));
    }
  }
  (*counters)["trigger_clock_steps"] = log_.clockSteps();
}

}  // namespace ptz::driver
