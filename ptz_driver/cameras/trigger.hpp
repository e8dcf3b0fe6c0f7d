// A hardware trigger line for a stereo pair: ptz-camera pulses one GPIO output at the frame rate,
// both cameras (in external-trigger mode, wired to it) expose on the pulse's leading edge, and
// each frame is stamped with the time of the pulse it answers. Both images of a pair then carry
// the same capture time, exact to the pulse, whatever each camera's own transfer delay. A camera
// that does not follow the pulses (not in trigger mode, not wired) is named, not paired.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "common/config.hpp"
#include "common/rig.hpp"  // Side
#include "ptz_driver/io/gpio_lines.hpp"

namespace ptz::driver {

struct TriggerParams {
  std::string chip;  // empty: no trigger line
  int line = -1;
  double rate_hz = 30;
  double pulse_s = 0.001;
  bool active_low = false;
  double window_s = 0;  // a frame this near a pulse answers it (0: a quarter of the period)
  std::array<bool, 2> own_latency{false, false};  // left/right_latency_s set (for the hint)
  bool enabled() const { return !chip.empty(); }
  int64_t windowUs() const;
};

void declareTriggerParams(Params& p);
// Throws ConfigError naming the parameter. `live` says whether each source is a live camera:
// recordings carry their own capture times and cannot be triggered.
TriggerParams triggerParamsFrom(const Params& p, const std::array<bool, 2>& live);

// The pulses sent, in wall-clock microseconds (what frames are stamped in): written by the
// pulser's thread, read by the camera.
class TriggerLog {
 public:
  explicit TriggerLog(size_t capacity = 1024) : capacity_(capacity) {}
  // A pulse not after the previous one means the wall clock was stepped back (NTP): the log
  // starts again from it (a new epoch), as frames are stamped on the stepped clock too.
  void add(int64_t utime);
  // The pulse nearest to utime, its signed distance (utime - pulse) and the log's epoch;
  // nullopt before any pulse.
  struct Nearest {
    int64_t pulse_utime = 0, offset_us = 0, epoch = 0;
  };
  std::optional<Nearest> nearest(int64_t utime) const;
  int64_t pulses() const;
  int64_t clockSteps() const;  // times the log started again

 private:
  mutable std::mutex mutex_;
  std::deque<int64_t> times_;
  size_t capacity_;
  int64_t pulses_ = 0, epoch_ = 0;
};

// The clocks the pulser keeps; tests inject one whose sleeping moves simulated time.
struct PulseClock {
  std::function<double()> now_s;  // monotonic
  std::function<void(double)> sleep_until_s;
  std::function<int64_t()> wall_utime;  // what frames are stamped in
};
PulseClock realPulseClock();  // CLOCK_MONOTONIC (gpioClockS), clock_nanosleep, the wall clock

// Drives the line: active for pulse_s from the start of every period, otherwise inactive. A period
// whose start was missed by more than half a period (the machine was busy) is skipped and
// counted rather than pulsed late, so that a late pulse is never taken for a frame's. Each
// pulse is logged at the middle of the wall-clock readings just before and after its edge.
class TriggerPulser {
 public:
  // The line must already be requested as an output of `lines`.
  TriggerPulser(GpioLines& lines, const TriggerParams& params, TriggerLog& log, PulseClock clock);
  ~TriggerPulser();
  void start();  // on a thread of its own
  void stop();   // joins it; the line is left inactive
  // Pulses `periods` periods on the calling thread (tests with a simulated clock).
  void run(int64_t periods);
  int64_t missedPeriods() const { return missed_; }
  // How late each edge came after its period's start (the jitter a camera sees), since the last
  // call; at most the last 10000.
  std::vector<double> takeEdgeLatenessS();

 private:
  void period(int64_t k);
  void drive(bool active);

  GpioLines& lines_;
  TriggerParams params_;
  TriggerLog& log_;
  PulseClock clock_;
  double start_s_ = -1, period_s_;
  int64_t next_ = 0;
  std::atomic<int64_t> missed_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
  std::mutex lateness_mutex_;
  std::deque<double> lateness_s_;
};

// The pulser's own troubles for the status: failed writes to the line (an error) and periods it
// missed (a warning), each reported for hold_s after the last one.
class TriggerLineHealth {
 public:
  TriggerLineHealth(int line, double hold_s)
      : line_(line), hold_us_(static_cast<int64_t>(hold_s * 1e6)) {}
  // The counts so far at now_utime: "" or the problems; *error when writes failed.
  std::string update(int64_t now_utime, int64_t io_errors, int64_t missed_periods, bool* error);

 private:
  int line_;
  int64_t hold_us_;
  int64_t io_errors_ = 0, missed_ = 0;
  std::optional<int64_t> io_error_utime_, missed_utime_;
};

// Which pulse each live frame answers: the nearest one, when its capture time (grab or V4L2
// buffer time minus the camera's latency) lies within the window of it. Keeps what the status
// needs to say about each side.
class TriggerMatcher {
 public:
  // own_latency: whether each camera has its own latency parameter (for the status's hint).
  TriggerMatcher(const TriggerLog& log, int64_t window_us, double recent_s,
                 std::array<bool, 2> own_latency = {false, false})
      : log_(log),
        window_us_(window_us),
        recent_us_(static_cast<int64_t>(recent_s * 1e6)),
        own_latency_(own_latency) {}
  // The pulse's time, or nullopt (then the frame is not used): no pulse near, or the side's
  // previous frame already answered that pulse.
  std::optional<int64_t> match(Side side, int64_t capture_utime, int64_t now_utime);
  // "" or, for each side with recent frames that answered no pulse: "right camera: 24 of 46
  // frames in the last 2.0 s answered no trigger pulse (...)". error: most of a side's did not.
  std::string problem(int64_t now_utime, bool* error) const;
  void addCounters(std::map<std::string, int64_t>* counters) const;

 private:
  enum class Verdict { kMatched, kNoPulseYet, kFar, kRepeat };
  struct Seen {
    int64_t arrival_utime, offset_us;
    Verdict verdict;
  };
  const TriggerLog& log_;
  int64_t window_us_, recent_us_;
  std::array<bool, 2> own_latency_;
  std::array<std::deque<Seen>, 2> recent_;
  std::array<std::optional<int64_t>, 2> last_pulse_;
  std::array<int64_t, 2> last_epoch_{0, 0};
  int64_t newest_arrival_utime_ = 0;
  std::array<int64_t, 2> matched_{0, 0}, unmatched_{0, 0};
};

}  // namespace ptz::driver
