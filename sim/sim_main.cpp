// ptz-sim: renders the stereo pair and models the PTZ motors; speaks the same channels as
// ptz-camera + ptz-driver. Clocks: realtime, or lockstep (sim time advances one frame once the
// frame's consumer answered with a setpoint naming it, or after a timeout).
#include <poll.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <mutex>
#include <thread>

#include "common/freshness.hpp"
#include "common/transport/transport.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "sim/sim_messages.hpp"
#include "sim/simulator.hpp"
#include "sim/visca_server.hpp"

namespace ptz::sim {
namespace {

// Sim time 0 of a lockstep run, so that two runs give identical messages.
constexpr int64_t kLockstepEpochUtime = 1'700'000'000'000'000;

void declare(Params& p) {
  addTransportParams(p);
  addFrameOutputParams(p);
  addPreviewParams(p);
  addPlantParams(p);
  declareRigParams(p);
  p.add("clock", "realtime", "realtime or lockstep");
  p.add("frame_rate_hz", 30.0, "Hz", "stereo frame rate (sim time)", Range::between(0.1, 1000));
  p.add("frames", 0, "", "stop after this many frames (0: no limit)", Range::atLeast(0));
  p.add("duration_s", 0.0, "s", "stop after this much sim time (0: no limit)", Range::atLeast(0));
  addImageEncodingParams(p);
  p.add("noise_sigma", 2.0, "grey levels", "standard deviation of the pixel noise",
        Range::between(0, 255));
  p.add("seed", 1, "", "seed of the pixel noise", Range::atLeast(0));
  p.add("state_rate_hz", 100.0, "Hz", "PTZ_STATE rate (sim time)", Range::between(1, 10000));
  p.add("lockstep_timeout_ms", 1000.0, "ms", "lockstep: advance anyway after this wall time",
        Range::above(0));
  addFreshnessParams(p, "setpoint", 500.0, "realtime: a PTZ_SETPOINT answering a frame");
  p.add("visca_port", 0, "",
        "realtime: serve the heads as VISCA-over-IP cameras on 127.0.0.1 at this UDP port "
        "(left) and the next (right) instead of PTZ_SETPOINT and PTZ_STATE (0: off)",
        Range::between(0, 65534));
  p.add("visca_model", "", "VISCA camera model file the heads pretend to be (visca_port)");
  p.addSection("scene",
               "backdrop_distance_m (8), floor_height_m (1.4), texture_m_per_texel (0.01), "
               "texture_seed (7)");
  p.addSection("objects",
               "list of {name, class, shape: sphere|box, radius_m | half_extents_m, yaw_rad and "
               "yaw_rate_rad_s (box, about the head's y axis), color_bgr, "
               "textured (0; 1: the colour modulated by the surface texture, for dense stereo), "
               "trajectory: static|line|circle|figure_eight|random_walk|arc, centre_m, "
               "amplitude_m, period_s, phase_rad, seed, arc_rad}");
  p.addSection("chessboard", "{inner_cols, inner_rows, square_m, centre_m, rotation_vector}");
  p.addSection("scenario",
               "read by the scenario runner (test/scenarios/README.md), not by ptz-sim: "
               "{description, target_class, sim_args, detect_args, control_args, checks}");
}

class SimNode {
 public:
  SimNode(const Params& p, lcm::LCM* lcm)
      : p_(p),
        lcm_(lcm),
        status_(lcm, p, "ptz-sim"),
        bulk_out_(p, *lcm),
        preview_(p),
        lockstep_(p.getString("clock") == "lockstep"),
        frame_period_s_(1.0 / p.getDouble("frame_rate_hz")),
        state_period_s_(1.0 / p.getDouble("state_rate_hz")),
        encoding_(imageEncodingFrom(p)),
        setpoint_freshness_(freshnessFrom(p, "setpoint")),
        ch_frame_(channel(p, channels::kStereoFrame)),
        ch_state_(channel(p, channels::kPtzState)),
        ch_truth_(channel(p, channels::kSimTruth)),
        ch_setpoint_(channel(p, channels::kPtzSetpoint)) {
    const std::string where =
        p.configPath().empty() ? "flags" : "config file '" + p.configPath() + "'";
    Scene scene =
        Scene::fromConfig(p.section("scene"), p.section("objects"), p.section("chessboard"), where);
    sim_ = std::make_unique<Simulator>(rigFromParams(p), std::move(scene), plantParamsFrom(p),
                                       p.getDouble("noise_sigma"),
                                       static_cast<unsigned>(p.getInt("seed")));
    if (p.getInt("visca_port") > 0) {
      // Real cameras do not speak LCM: ptz-driver commands them and publishes PTZ_STATE.
      if (lockstep_) throw ConfigError("parameter 'visca_port' needs clock realtime");
      if (p.getString("visca_model").empty()) {
        throw ConfigError("parameter 'visca_port' needs 'visca_model' (a VISCA model file)");
      }
      visca_ =
          std::make_unique<ViscaServer>(driver::ViscaModel::load(p.getExistingPath("visca_model")),
                                        "127.0.0.1", p.getInt("visca_port"));
    } else {
      setpoints_ = std::make_unique<SafeSubscription<ptzstereo::ptz_setpoint_t>>(
          *lcm_, ch_setpoint_, status_,
          [this](const std::string& ch, const ptzstereo::ptz_setpoint_t& m) { onSetpoint(ch, m); },
          Delivery::kNewest);
    }
    start_steady_ = std::chrono::steady_clock::now();
  }

  ~SimNode() { stopVisca(); }

  int run() {
    const int max_frames = p_.getInt("frames");
    const double duration_s = p_.getDouble("duration_s");
    // The cameras answer on their own thread, as real ones do, not between two renders.
    if (visca_) visca_thread_ = std::thread([this] { serveVisca(); });
    for (int64_t n = 0; !StopFlag::stopRequested(); ++n) {
      const double t_frame = n * frame_period_s_;
      if ((max_frames > 0 && n >= max_frames) || (duration_s > 0 && t_frame > duration_s)) break;
      if (lockstep_) {
        advanceWithStates(t_frame);
      } else if (!waitRealtime(t_frame)) {
        continue;  // too late for this frame: skip it
      }
      publishFrame();
      if (lockstep_) awaitAnswer(n);
      reportVisca();
      status_.maybePublish();
    }
    stopVisca();
    reportVisca();
    status_.publishLast();
    std::printf("ptz-sim: %lld frames published, %lld setpoints applied\n",
                static_cast<long long>(status_.counter("frames_published")),
                static_cast<long long>(status_.counter("setpoints_applied")));
    return 0;
  }

 private:
  // The wall-clock time of sim instant t_s. In real time: the wall clock now, less how long ago
  // t_s was on the steady clock, so stamps follow the wall clock's steps and NTP's slewing (what
  // every other process judges freshness by) instead of drifting from it over a long run.
  int64_t simUtime(double t_s) const {
    if (lockstep_) return kLockstepEpochUtime + std::llround(t_s * 1e6);
    return wallUtime() + std::llround((t_s - realtimeNow()) * 1e6);
  }
  double realtimeNow() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_steady_).count();
  }

  // Advances the motors to t_s, publishing PTZ_STATE at every state period on the way.
  void advanceWithStates(double t_s) {
    const std::lock_guard<std::mutex> lock(sim_mutex_);
    while (next_state_t_ <= t_s) {
      sim_->advanceTo(next_state_t_);
      publishState();
      next_state_t_ += state_period_s_;
    }
    sim_->advanceTo(t_s);
  }

  // Realtime: serve setpoints and states until the frame's time; false if it is long past.
  bool waitRealtime(double t_frame) {
    for (;;) {
      const double now = realtimeNow();
      if (now >= t_frame) {
        // Setpoints that arrived meanwhile act now, even when the frames run late.
        handleNewest(*lcm_, 0);
        if (now - t_frame > frame_period_s_) {
          status_.increment("frames_skipped_late");
          return false;
        }
        advanceWithStates(t_frame);
        return true;
      }
      const double until = std::min(t_frame, next_state_t_);
      if (now >= next_state_t_) {
        advanceWithStates(now);
        continue;
      }
      waitForInput(std::max(1, static_cast<int>((until - now) * 1000)));
      status_.maybePublish();
    }
  }

  void waitForInput(int timeout_ms) { handleNewest(*lcm_, timeout_ms); }

  // The VISCA cameras: every datagram is answered as it comes, with the motors at that moment.
  void serveVisca() {
    while (!visca_quit_) {
      pollfd fds[2] = {{visca_->fd(Side::kLeft), POLLIN, 0}, {visca_->fd(Side::kRight), POLLIN, 0}};
      if (::poll(fds, 2, 20) <= 0) continue;
      const std::lock_guard<std::mutex> lock(sim_mutex_);
      const double t_apply = std::max(sim_->time(), realtimeNow());
      sim_->advanceTo(t_apply);
      const std::array<PtzPose, 2> now = {sim_->plant().pose(Side::kLeft),
                                          sim_->plant().pose(Side::kRight)};
      if (visca_->serve(now, &visca_setpoints_)) {
        int clamped = 0, rejected = 0;
        sim_->command(t_apply, visca_setpoints_[0], visca_setpoints_[1], &clamped, &rejected);
        ++visca_setpoints_applied_;
      }
      visca_packets_ = visca_->packets();
      visca_malformed_ = visca_->malformed();
    }
  }

  void stopVisca() {
    visca_quit_ = true;
    if (visca_thread_.joinable()) visca_thread_.join();
  }

  void reportVisca() {
    if (!visca_) return;
    status_.setCounter("visca_packets", visca_packets_);
    status_.setCounter("visca_malformed", visca_malformed_);
    status_.setCounter("visca_setpoints_applied", visca_setpoints_applied_);
  }

  void publishState() {
    if (visca_) return;  // ptz-driver publishes the state it reads from the cameras
    ptzstereo::ptz_state_t msg = makeStateMessage(sim_->plant(), simUtime(sim_->time()));
    msg.setpoint_utime = last_setpoint_utime_;
    msg.publish_utime = wallUtime();
    status_.publish(ch_state_, msg);
  }

  void publishFrame() {
    SimFrame frame;
    ptzstereo::sim_truth_t truth;
    int64_t utime = 0;  // one stamp for the frame, its truth and its preview
    {                   // the instant of capture; the motors may move on while it renders
      const std::lock_guard<std::mutex> lock(sim_mutex_);
      frame = sim_->snapshot();
      utime = simUtime(frame.t_s);
      truth = makeTruthMessage(*sim_, frame, utime);
    }
    sim_->render(&frame);
    setVisibility(frame, &truth);
    current_frame_t_ = frame.t_s;
    ptzstereo::stereo_frame_t msg =
        makeFrameMessage(frame, utime, encoding_, p_.getInt("jpeg_quality"));
    const int64_t now = wallUtime();
    msg.publish_utime = now;
    // A frame LCM did not take (no route: a link went down) is not published; it is counted as
    // STEREO_FRAME.publish_failures, and the run's numbers count its time as lost.
    if (status_.publishOn(bulk_out_.lcm(), ch_frame_, msg,
                          lockstep_ ? -1 : (now - utime) / 1000.0)) {
      status_.increment("frames_published");
    }
    preview_.maybePublish(status_, *lcm_, utime, frame.index, frame.left, frame.left_pose,
                          frame.right, frame.right_pose, !lockstep_);
    truth.publish_utime = wallUtime();
    status_.publish(ch_truth_, truth);
  }

  void awaitAnswer(int64_t seq) {
    awaiting_seq_ = seq;
    answered_ = false;
    const auto deadline =
        std::chrono::steady_clock::now() +
        std::chrono::microseconds(static_cast<int64_t>(p_.getDouble("lockstep_timeout_ms") * 1000));
    while (!answered_ && !StopFlag::stopRequested()) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                            deadline - std::chrono::steady_clock::now())
                            .count();
      if (left <= 0) {
        status_.increment("lockstep_timeouts");
        break;
      }
      handleNewest(*lcm_, static_cast<int>(std::min<int64_t>(left, 100)));
      status_.maybePublish();
    }
    awaiting_seq_ = -1;
  }

  void onSetpoint(const std::string& ch, const ptzstereo::ptz_setpoint_t& m) {
    const ptzstereo::ptz_setpoint_t* msg = &m;
    double t_apply;
    if (lockstep_) {
      if (msg->frame_seq >= 0 && msg->frame_seq != awaiting_seq_) {
        status_.countDropped(ch, "setpoint_stale");
        return;
      }
      // The answer to frame n is issued at that frame's capture time; tau delays it.
      t_apply = msg->frame_seq >= 0 ? current_frame_t_ : sim_->time();
    } else {
      // Judged by the capture time of the frame it answers: a setpoint for an old frame is old.
      const Freshness fresh =
          judgeFreshness(msg->utime, msg->publish_utime, wallUtime(), setpoint_freshness_);
      if (fresh != Freshness::kFresh) {
        status_.countDropped(ch, std::string("setpoint_") + freshnessReason(fresh));
        log_.warn("fresh", std::string("ptz-sim: dropped a ") + freshnessReason(fresh) +
                               " setpoint (frame " + std::to_string(msg->frame_seq) + ")");
        return;
      }
      t_apply = std::max(sim_->time(), realtimeNow());
      advanceWithStates(t_apply);
    }
    int clamped = 0, rejected = 0;
    const PtzPose l{msg->left.pan_rad, msg->left.tilt_rad, msg->left.zoom};
    const PtzPose r{msg->right.pan_rad, msg->right.tilt_rad, msg->right.zoom};
    sim_->command(t_apply, l, r, &clamped, &rejected);
    status_.countIn(ch, lockstep_ ? -1 : (wallUtime() - msg->utime) / 1000.0);
    // Once a controller has spoken, its silence is news (a lost link, a dead host); before, the
    // rig may be running open loop on purpose.
    if (!lockstep_ && !setpoints_expected_) {
      status_.expectInput(ch, 1.0, 5.0);
      setpoints_expected_ = true;
    }
    status_.increment("setpoints_applied");
    if (clamped) status_.increment("setpoint_values_clamped", clamped);
    if (rejected) {
      status_.increment("setpoint_values_rejected", rejected);
      log_.warn("rejected", "ptz-sim: setpoint with non-finite values; those axes hold");
    }
    if (clamped) log_.warn("clamped", "ptz-sim: setpoint outside the limits; clamped");
    last_setpoint_utime_ = msg->utime;
    if (msg->frame_seq == awaiting_seq_) answered_ = true;
  }

  const Params& p_;
  lcm::LCM* lcm_;
  StatusReporter status_;
  FrameOutput bulk_out_;
  PreviewOutput preview_;
  RateLimitedLog log_;
  bool lockstep_;
  double frame_period_s_, state_period_s_;
  int8_t encoding_;
  FreshnessLimits setpoint_freshness_;
  std::string ch_frame_, ch_state_, ch_truth_, ch_setpoint_;
  std::unique_ptr<Simulator> sim_;
  std::unique_ptr<SafeSubscription<ptzstereo::ptz_setpoint_t>> setpoints_;
  std::unique_ptr<ViscaServer> visca_;
  std::array<PtzPose, 2> visca_setpoints_{PtzPose{0, 0, 1}, PtzPose{0, 0, 1}};
  // The motors are shared with the VISCA thread (visca_port): while it runs, every use of the plant
  // holds sim_mutex_; the renderers are the main thread's alone.
  std::mutex sim_mutex_;
  std::thread visca_thread_;
  std::atomic<bool> visca_quit_{false};
  std::atomic<int64_t> visca_packets_{0}, visca_malformed_{0}, visca_setpoints_applied_{0};
  std::chrono::steady_clock::time_point start_steady_;
  double next_state_t_ = 0;
  double current_frame_t_ = 0;
  int64_t awaiting_seq_ = -1;
  bool answered_ = false;
  int64_t last_setpoint_utime_ = 0;
  bool setpoints_expected_ = false;
};

}  // namespace
}  // namespace ptz::sim

int main(int argc, char** argv) {
  using namespace ptz;
  Params params("ptz-sim",
                "Simulated PTZ stereo rig: renders STEREO_FRAME, models the motors "
                "(PT1 + dead time), publishes PTZ_STATE and SIM_TRUTH, applies "
                "PTZ_SETPOINT.");
  sim::declare(params);
  return runProcess(argc, argv, params, [](const Params& p, lcm::LCM& lcm) {
    const std::string clock = p.getString("clock");
    if (clock != "realtime" && clock != "lockstep") {
      throw p.invalid("clock", "must be realtime or lockstep");
    }
    imageEncodingFrom(p);  // throws for a bad encoding or quality
    sim::SimNode node(p, &lcm);
    return node.run();
  });
}
