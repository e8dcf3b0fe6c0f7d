// GpioLines on a real chip through libgpiod 1.6 (the kernel's v1 character-device uAPI): one
// request per line, edge events read without blocking from each line's descriptor.
#include <gpiod.h>
#include <poll.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <map>
#include <set>

#include "common/config.hpp"
#include "ptz_driver/io/gpio_event_merger.hpp"
#include "ptz_driver/io/gpio_lines.hpp"

namespace ptz::driver {
namespace {

double seconds(const timespec& t) {
  return static_cast<double>(t.tv_sec) + t.tv_nsec * 1e-9;
}

double clockS(clockid_t id) {
  timespec t{};
  clock_gettime(id, &t);
  return seconds(t);
}

// How long after stamping an edge the kernel may take to queue it (its interrupt thread runs at
// real-time priority: normally tens of microseconds). Edges are delivered that much later.
constexpr double kQueueDelayS = 200e-6;

class GpiodLines : public GpioLines {
 public:
  GpiodLines(const std::string& chip, const std::string& consumer, const std::string& param)
      : chip_name_(chip), consumer_(consumer) {
    errno = 0;
    chip_ = gpiod_chip_open_lookup(chip.c_str());
    if (!chip_) {
      const int e = errno;
      throw ConfigError(
          "parameter '" + param + "': cannot open GPIO chip '" + chip + "': " +
          (e == 0 || e == ENOENT ? std::string("no such chip") : std::string(std::strerror(e))) +
          " (gpiodetect lists the chips of this machine)");
    }
  }
  ~GpiodLines() override {
    for (auto& [offset, line] : lines_) {
      // Outputs end idle: motors off, a trigger line inactive.
      if (!events_.count(offset)) gpiod_line_set_value(line, idle_high_.count(offset) ? 1 : 0);
      gpiod_line_release(line);
    }
    gpiod_chip_close(chip_);
  }

  using GpioLines::requestOutput;
  void requestOutput(int offset, const std::string& name, bool idle_high) override {
    gpiod_line* line = lineOf(offset, name);
    if (gpiod_line_request_output(line, consumer_.c_str(), idle_high ? 1 : 0) < 0)
      failRequest(offset, name);
    lines_[offset] = line;
    if (idle_high) idle_high_.insert(offset);
  }

  void requestEvents(int offset, Bias bias, const std::string& name) override {
    gpiod_line* line = lineOf(offset, name);
    const int flags = bias == Bias::kPullUp     ? GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_UP
                      : bias == Bias::kDisabled ? GPIOD_LINE_REQUEST_FLAG_BIAS_DISABLE
                                                : 0;
    if (gpiod_line_request_both_edges_events_flags(line, consumer_.c_str(), flags) < 0)
      failRequest(offset, name);
    lines_[offset] = line;
    events_[offset] = line;
    pollfds_.push_back({gpiod_line_event_get_fd(line), POLLIN, 0});
    poll_offsets_.push_back(offset);
  }

  void set(int offset, bool high) override {
    const auto it = lines_.find(offset);
    if (it == lines_.end() || gpiod_line_set_value(it->second, high ? 1 : 0) < 0) ++io_errors_;
  }

  bool get(int offset) override {
    const auto it = lines_.find(offset);
    const int v = it == lines_.end() ? -1 : gpiod_line_get_value(it->second);
    if (v < 0) ++io_errors_;
    return v > 0;
  }

  void readEvents(std::vector<LineEvent>* out) override {
    if (pollfds_.empty()) return;
    // The cutoff first (gpio_event_merger.hpp): the lines are read one after the other. The
    // kernel stamps an edge in its interrupt handler but queues it from the interrupt thread a
    // little later, so the cutoff is that much earlier.
    const double wall = clockS(CLOCK_REALTIME), mono = clockS(CLOCK_MONOTONIC);
    const double cutoff_s = mono - kQueueDelayS;
    if (::poll(pollfds_.data(), pollfds_.size(), 0) > 0) {
      for (size_t i = 0; i < pollfds_.size(); ++i) {
        if (!(pollfds_[i].revents & POLLIN)) continue;
        gpiod_line_event ev[16];  // the kernel keeps at most 16 per line (v1 uAPI)
        const int n = gpiod_line_event_read_fd_multiple(pollfds_[i].fd, ev, 16);
        if (n < 0) ++io_errors_;
        for (int k = 0; k < n; ++k) {
          // Since Linux 5.7 the timestamps are CLOCK_MONOTONIC, before that CLOCK_REALTIME:
          // take the nearer one and move it onto the monotonic clock.
          double t = seconds(ev[k].ts);
          if (std::abs(t - wall) < std::abs(t - mono)) t -= wall - mono;
          merger_.add({poll_offsets_[i], ev[k].event_type == GPIOD_LINE_EVENT_RISING_EDGE, t});
        }
      }
    }
    merger_.take(cutoff_s, out);  // also what earlier batches held back
  }

  int64_t ioErrors() const override { return io_errors_; }

 private:
  gpiod_line* lineOf(int offset, const std::string& name) {
    const unsigned count = gpiod_chip_num_lines(chip_);
    gpiod_line* line =
        offset >= 0 ? gpiod_chip_get_line(chip_, static_cast<unsigned>(offset)) : nullptr;
    if (!line || lines_.count(offset)) {
      throw ConfigError("parameter '" + name + "': GPIO chip '" + chip_name_ + "' has no line " +
                        std::to_string(offset) + " to give (it has lines 0.." +
                        std::to_string(static_cast<int>(count) - 1) + ", each used once)");
    }
    return line;
  }

  [[noreturn]] void failRequest(int offset, const std::string& name) {
    const int e = errno;
    gpiod_line* line = gpiod_chip_get_line(chip_, static_cast<unsigned>(offset));
    const char* user = line ? gpiod_line_consumer(line) : nullptr;
    throw ConfigError("parameter '" + name + "': cannot request line " + std::to_string(offset) +
                      " of GPIO chip '" + chip_name_ + "': " + std::strerror(e) +
                      (user ? std::string(" (used by '") + user + "')" : std::string()));
  }

  std::string chip_name_, consumer_;
  gpiod_chip* chip_ = nullptr;
  std::map<int, gpiod_line*> lines_, events_;
  std::vector<pollfd> pollfds_;
  std::vector<int> poll_offsets_;
  GpioEventMerger merger_;
  std::set<int> idle_high_;
  // Counted on the thread that drives a line, read by the status on another.
  std::atomic<int64_t> io_errors_{0};
};

}  // namespace

double gpioClockS() {
  return clockS(CLOCK_MONOTONIC);
}

void gpioSleepUntilS(double t_s) {
  timespec t{};
  t.tv_sec = static_cast<time_t>(std::floor(t_s));
  t.tv_nsec = static_cast<long>((t_s - std::floor(t_s)) * 1e9);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr) == EINTR) {
  }
}

std::unique_ptr<GpioLines> openGpiodChip(const std::string& chip, const std::string& consumer,
                                         const std::string& param) {
  return std::make_unique<GpiodLines>(chip, consumer, param);
}

}  // namespace ptz::driver
