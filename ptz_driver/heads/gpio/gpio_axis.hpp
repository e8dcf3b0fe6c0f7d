// One axis of a GPIO DC-motor head: an H-bridge (direction line, optional second direction line
// for IN1/IN2 bridges, enable line driven with software PWM), a quadrature encoder and a limit
// switch at each end (active low). Stepped with explicit times, so tests are deterministic: the
// owner calls step(now_s) when it said it should (PWM edges, control ticks) and feeds it the line
// events in time order.
#pragma once

#include <cstdint>
#include <limits>
#include <string>

#include "ptz_driver/heads/gpio/quadrature.hpp"
#include "ptz_driver/io/gpio_lines.hpp"

namespace ptz::driver {

struct AxisConfig {
  std::string name = "pan";       // errors name it ("left pan")
  std::string param_prefix = "";  // the parameters of its lines ("left_pan_")
  AxisLines lines;
  double counts_per_rad = 1000;                // x4 counts per radian of the axis, up toward max
  double soft_min_rad = -1, soft_max_rad = 1;  // the plant limits: never driven beyond
  double min_switch_rad = -1.1;                // where the min switch closes (the homing reference)
  double max_switch_rad = 1.1;
  double kp_duty_per_rad = 4;  // duty = kp * error - kd * speed
  double kd_duty_s_per_rad = 0.15;
  double deadband_rad = 0.002;        // |error| below this: motor off (no hunting)
  double max_duty = 1, min_duty = 0;  // min_duty: what the motor needs to start turning
  double pwm_hz = 1000, control_hz = 500;
  double homing_speed_rad_s = 0.3;
  double homing_timeout_s = 20;
  double homing_max_lag_rad = 0.2;  // further behind the homing ramp: motor or encoder wrong
};

class GpioAxis {
 public:
  enum class State { kIdle, kBackoff, kSeek, kReady, kStopped, kFault };

  // Requests its lines (ConfigError naming the parameter of a line that cannot be had).
  GpioAxis(AxisConfig config, GpioLines& lines);

  // Homing: toward the min switch at homing speed until it closes (off it first if it is
  // closed), the position there is min_switch_rad, then to 0. Starting on the max switch is
  // fine: it seeks toward min as usual, and the max switch must open within the distance
  // between the switches.
  void startHoming(double now_s);
  // A target position (clamped to the soft limits); ignored until homed; resumes after stop.
  void setTarget(double target_rad);
  // Enable low, direction lines low, and no drive until the next setTarget. Interrupts homing.
  void stop();
  // An edge on one of this axis's lines (false: not one of its lines).
  bool handle(const LineEvent& event);
  // Controller (when due), limits and PWM at now_s; sets the lines. Returns when to step next.
  double step(double now_s);

  State state() const { return state_; }
  bool homed() const { return homed_; }
  double positionRad() const { return (decoder_.count() - zero_count_) / config_.counts_per_rad; }
  double speedRadS() const { return speed_rad_s_; }
  double duty() const { return duty_; }  // signed, as last limited
  int64_t counts() const { return decoder_.count(); }
  int64_t illegalTransitions() const { return decoder_.illegal(); }
  int64_t limitBlocks() const { return limit_blocks_; }  // steps a switch or soft limit held
  const std::string& error() const { return error_; }
  const AxisConfig& config() const { return config_; }

 private:
  double rawRad() const { return decoder_.count() / config_.counts_per_rad; }
  void fault(const std::string& why);
  void faultLag();
  void seek(double now_s);
  void control(double now_s);
  void updateSpeed(double now_s);
  double limitDuty(double duty);
  void drive(bool on, bool positive);

  AxisConfig config_;
  GpioLines& lines_;
  QuadratureDecoder decoder_;
  State state_ = State::kIdle;
  bool homed_ = false;
  int64_t zero_count_ = 0;
  bool switch_seen_ = false;  // the min switch's closing edge, seen during the seek
  int64_t switch_count_ = 0;
  double phase_start_raw_ = 0;  // where the backoff or the seek began
  // The seek began on the max switch: until it has opened and the axis is kSwitchClearRad past
  // where it did (a switch bounces as it opens), max closed is not an edge.
  bool leaving_max_ = false, max_opened_ = false;
  double max_open_raw_ = 0;
  bool min_closed_ = false, max_closed_ = false;
  double target_rad_ = 0;  // in the homed frame, or raw (counts / cpr) while homing
  double goal_rad_ = 0;    // where a ramp (homing speed) ends
  bool ramp_ = false;
  double homing_start_s_ = 0;
  double duty_ = 0;
  double speed_rad_s_ = 0, speed_ref_s_ = 0;
  int64_t speed_ref_count_ = 0;
  double next_control_s_ = 0, period_start_s_ = 0, pulse_start_s_ = 0, on_until_s_ = 0;
  bool started_ = false;
  int out_enable_ = -1, out_dir_ = -1;  // what was last written (-1: nothing yet)
  int64_t limit_blocks_ = 0;
  std::string error_;
};

}  // namespace ptz::driver
