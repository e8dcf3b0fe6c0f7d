// One ONVIF PTZ camera as a PtzHead. HTTP is blocking, so an OnvifSession runs on a worker
// thread and the driver thread never waits on the camera (but in stop(), which is asked to):
// command() leaves the newest setpoint for the worker (an older one not yet sent is dropped),
// inquire() asks for a GetStatus at most status_rate_hz, receive() takes what the worker got, and
// fd() (an eventfd) is readable when it has something. A fault, an HTTP error or a timeout is
// counted and said in problem(); the worker then sends no move until the camera has answered the
// start-up again (tried again after 0.1 s, then twice as long each time, at most every second).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "ptz_driver/heads/common/head.hpp"
#include "ptz_driver/heads/onvif/head/onvif_session.hpp"

namespace ptz::driver {

class OnvifHead : public PtzHead {
 public:
  // now_s: the local clock, ptz-driver's (the wall clock) by default. Nothing is sent before
  // start().
  OnvifHead(OnvifModel model, OnvifHeadSettings settings, std::function<double()> now_s = {});
  ~OnvifHead() override;
  OnvifHead(const OnvifHead&) = delete;
  OnvifHead& operator=(const OnvifHead&) = delete;

  void start(double now_s) override;
  void command(const PtzPose& pose, double now_s) override;
  // Stop(pan_tilt, zoom) next on the worker; true when the camera confirmed it within timeout_s.
  bool stop(double now_s, double timeout_s) override;
  void inquire(double now_s, double timeout_s) override;
  void receive(double now_s) override;

  std::optional<PtzPose> measured() const override { return measured_; }
  double measuredAtS() const override { return measured_at_s_; }
  int fd() const override { return event_fd_; }
  HeadStats& stats() override { return stats_; }
  std::string problem(double now_s) const override;

  // As of the last receive(): the start-up done and the camera answering since.
  bool ready() const { return ready_; }
  double clockOffsetS() const { return clock_offset_s_; }
  const std::string& profileToken() const { return profile_; }
  const OnvifModel& model() const { return model_; }

 private:
  // What the worker hands the driver thread.
  struct Event {
    OnvifOutcome outcome;
    std::optional<OnvifStatus> status;
    bool started = false;  // the start-up succeeded
    int64_t sent = 0;      // requests sent for it
    double clock_offset_s = 0;
    std::string profile;
  };
  void work();
  void post(Event e);  // under lock_

  OnvifModel model_;
  OnvifHeadSettings settings_;
  std::function<double()> now_s_;
  int event_fd_ = -1;
  std::thread worker_;

  std::mutex lock_;  // guards what the worker shares with the driver thread, below
  std::condition_variable wake_;
  bool quit_ = false;
  std::optional<PtzPose> setpoint_;  // absolute: the newest not yet sent; continuous: the target
  double pan_rate_rad_s_ = 0, tilt_rate_rad_s_ = 0;  // continuous: how fast the target moves
  bool status_wanted_ = false;
  int64_t stops_asked_ = 0, stops_done_ = 0;
  bool stop_confirmed_ = false;
  std::vector<Event> events_;

  // The driver thread's own.
  std::optional<PtzPose> last_command_;
  double last_command_s_ = 0;
  double pan_rate_filtered_ = 0, tilt_rate_filtered_ = 0;
  HeadStats stats_;
  std::optional<PtzPose> measured_;
  double measured_at_s_ = 0;
  double last_inquiry_s_ = -1e300;
  bool ready_ = false;
  std::string error_;  // the last failure while not ready
  double clock_offset_s_ = 0;
  std::string profile_;
};

// The cameras' password: the first line of `file`, else the environment variable
// PTZ_ONVIF_PASSWORD, else "" (requests unsigned). Never a flag's value (ps shows those), never
// printed. ConfigError when the file cannot be read.
std::string onvifHeadPassword(const std::string& file);

}  // namespace ptz::driver
