// A pan-tilt head of two GPIO DC-motor axes (gpio_axis.hpp). Zoom is not motorised on such
// heads: the head reports the fixed zoom it was configured with. In the real backend a control
// thread steps both axes on the monotonic clock, waking at every PWM edge and control tick;
// without that thread the owner calls step() with its own times (tests, deterministic).
#pragma once

#include <array>
#include <atomic>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "ptz_driver/heads/common/head.hpp"
#include "ptz_driver/heads/gpio/gpio_axis.hpp"
#include "ptz_driver/io/gpio_lines.hpp"

namespace ptz::driver {

struct GpioHeadConfig {
  std::string name = "left";
  AxisConfig pan, tilt;
  double zoom = 1;  // reported as measured: the head has no zoom motor
};

class GpioHead : public PtzHead {
 public:
  // Requests the lines of both axes (ConfigError naming the parameter of a line that cannot be
  // had). threaded: a control thread steps the axes in real time (gpioClockS()).
  GpioHead(GpioHeadConfig config, std::unique_ptr<GpioLines> lines, bool threaded);
  ~GpioHead() override;  // the thread ends and the motors stop
  GpioHead(const GpioHead&) = delete;
  GpioHead& operator=(const GpioHead&) = delete;

  // Homes both axes (in the background: measured() has a value once both found their switch).
  void start(double now_s) override;
  void command(const PtzPose& pose, double now_s) override;
  // Enable and direction lines low at once, and the axes stay there until the next command.
  bool stop(double now_s, double timeout_s) override;
  void inquire(double, double) override {}  // the encoders are always read
  void receive(double) override {}

  std::optional<PtzPose> measured() const override;
  // The time of the step that read the encoders (on the wall clock when threaded).
  double measuredAtS() const override;
  int fd() const override { return -1; }  // the driver polls on its own clock
  // errors: axes whose homing failed or was interrupted, and failed line reads/writes;
  // malformed: illegal encoder transitions.
  HeadStats& stats() override;

  // One step at now_s: line events, both axes' control and PWM. Returns when the next is due.
  double step(double now_s);
  GpioAxis::State state(int axis) const;
  double positionRad(int axis) const;  // raw until homed
  // How late (< 0: early) each step of the control thread ran against when it was due: the
  // jitter of the PWM edges. Since the last call.
  std::vector<double> takeWakeLatenessS();
  // How far the line writes of each step of the control thread may lie from when they were due:
  // written between its wake-up and its end, so late by at most end - due, or early by at most
  // due - wake-up. The bound on each PWM edge's error. Since the last call.
  std::vector<double> takeEdgeErrorBoundsS();
  // Threaded: blocks until done() holds, looking again after each step of the control thread
  // (the only thing that moves the head), at most timeout_s; returns done().
  bool waitForStep(const std::function<bool()>& done, double timeout_s) const;

 private:
  double nowS(double given_s) const;
  void run();

  GpioHeadConfig config_;
  std::unique_ptr<GpioLines> lines_;  // before the axes, which use it
  std::array<std::unique_ptr<GpioAxis>, 2> axes_;
  mutable std::mutex mutex_;
  std::vector<LineEvent> events_;
  double measured_at_s_ = 0;
  int64_t foreign_events_ = 0;
  std::vector<double> lateness_s_;
  std::vector<double> edge_error_bound_s_;
  HeadStats stats_;
  bool threaded_;
  std::atomic<bool> quit_{false};
  std::thread thread_;
  mutable std::mutex step_mutex_;  // apart from mutex_: done() may call measured()
  mutable std::condition_variable stepped_;
};

}  // namespace ptz::driver
