#include "sim/sim_run.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <utility>

#include "common/freshness.hpp"
#include "common/measure.hpp"
#include "common/plant.hpp"
#include "common/rig.hpp"
#include "sim/state_messages.hpp"

namespace ptz::sim {

void declareSimClockParams(Params& p) {
  addPlantParams(p);
  declareRigParams(p);
  p.add("clock", "realtime", "realtime or lockstep");
  p.add("frame_rate_hz", 30.0, "Hz", "stereo frame rate (sim time)", Range::between(0.1, 1000));
  p.add("frames", 0, "", "stop after this many frames (0: no limit)", Range::atLeast(0));
  p.add("duration_s", 0.0, "s", "stop after this much sim time (0: no limit)", Range::atLeast(0));
}

void declareSimSceneParams(Params& p) {
  p.add("noise_sigma", 2.0, "grey levels", "standard deviation of the pixel noise",
        Range::between(0, 255));
  p.add("seed", 1, "", "seed of the pixel noise", Range::atLeast(0));
  p.add("state_rate_hz", 100.0, "Hz", "PTZ_STATE rate (sim time)", Range::between(1, 10000));
  p.add("lockstep_timeout_ms", 1000.0, "ms", "lockstep: advance anyway after this wall time",
        Range::above(0));
  p.add("lockstep_served_wait_ms", 60.0, "ms",
        "lockstep with VISCA or ONVIF cameras: after the controller's setpoint, wait this long "
        "for ptz-driver's command (an unchanged one is not sent again)",
        Range::between(1, 10000));
  addFreshnessParams(p, "setpoint", 500.0, "realtime: a PTZ_SETPOINT answering a frame");
  p.add("visca_port", 0, "",
        "serve the heads as VISCA-over-IP cameras on 127.0.0.1 at this UDP port "
        "(left) and the next (right) instead of PTZ_SETPOINT and PTZ_STATE (0: off)",
        Range::between(0, 65534));
  p.add("visca_model", "", "VISCA camera model file the heads pretend to be (visca_port)");
  p.add("onvif_port", 0, "",
        "serve the heads as ONVIF cameras (HTTP/SOAP) on 127.0.0.1 at this TCP port "
        "(left) and the next (right) instead of PTZ_SETPOINT and PTZ_STATE (0: off)",
        Range::between(0, 65534));
  p.add("onvif_model", "", "ONVIF camera model file the heads pretend to be (onvif_port)");
  p.add("onvif_user", "admin", "ONVIF user name (with a password: WS-UsernameToken digest)");
  p.add("onvif_password_file", "",
        "file whose first line is the ONVIF password (else env PTZ_SIM_ONVIF_PASSWORD; neither: "
        "no authentication)");
  p.add("onvif_discovery", true,
        "the ONVIF cameras answer WS-Discovery probes (UDP 3702, group 239.255.255.250)");
  p.add("onvif_http_digest", false,
        "the ONVIF cameras demand HTTP digest authentication (MD5) besides WS-UsernameToken; needs "
        "a password");
  p.add("onvif_clock_offset_s", 0.0, "s",
        "the ONVIF cameras' clock minus the host's (clients must correct for it)",
        Range::between(-1e9, 1e9));
  p.addSection(
      "scene",
      "backdrop_distance_m (8), floor_height_m (1.4), texture_m_per_texel (0.01), "
      "texture_seed (7), light (off): {brightness_s and brightness (keyframes of the "
      "scene's brightness, linear between), mains_hz and flicker_depth (lamps flickering "
      "at twice the mains' frequency, dipping by the depth), vignetting (the corners' "
      "light lost, as the radius squared, 0 .. 0.9), auto_exposure_target (the mean grey "
      "the cameras' exposure steers to; 0: off), auto_exposure_time_constant_s (0.5), "
      "auto_exposure_max_gain (8), tint_bgr (the light's colour, gains on the channels, "
      "[1, 1, 1]), auto_white_balance_time_constant_s (the cameras' grey-world white "
      "balance; 0: off), direction_s and direction (keyframes of the direction toward the "
      "light, head frame, y down: [[x, y, z], ...], each normalised, interpolated between; "
      "[-0.3, -0.8, -0.5]: above, left of and behind the cameras), shadows (false; true: the "
      "objects' shadows on the floor), shadow_depth (0.55: the share of the light a shadow "
      "takes, 0 .. 1)}, posters (at most 16 on the backdrop, the later in front): "
      "[{centre_m: [x, y] and size_m: [width, height] on the backdrop plane, color_bgr "
      "(reflectance) or image (a photograph stretched over it; relative to the config "
      "file's folder), brightness (1; a lit window 3, 0 .. 10)}], camera (an instant): "
      "{exposure_s (0 .. 0.2: motion blur over the exposure, centred on each frame's time), "
      "blur_samples (5, 2 .. 16: renders averaged over it)}");
  p.addSection("objects",
               "list of {name, class, shape: sphere|box|person, radius_m | half_extents_m | "
               "height_m (person, 1.75), yaw_rad (box, person) and yaw_rate_rad_s (box, about the "
               "head's y axis), pitch_rad and roll_rad (box, then about its x and z), tags (box: "
               "[{family, id, size_m, centre_m, yaw_deg, pitch_deg}], markers printed on its "
               "faces), prints (box: [{picture: face, size_m, centre_m, yaw_deg, pitch_deg}]), "
               "color_bgr (a person's shirt), "
               "textured (0; 1: the colour modulated by the surface texture, for dense stereo), "
               "trajectory: static|line|circle|figure_eight|random_walk|arc, centre_m, "
               "amplitude_m, period_s, phase_rad, seed, arc_rad}");
  p.addSection("chessboard", "{inner_cols, inner_rows, square_m, centre_m, rotation_vector}");
  p.addSection("scenario",
               "read by the scenario runner (test/scenarios/README.md), not by ptz-sim: "
               "{description, target_class, sim_args, detect_args, control_args, checks}");
}

std::unique_ptr<Simulator> simulatorFromParams(const Params& p) {
  const std::string where =
      p.configPath().empty() ? "flags" : "config file '" + p.configPath() + "'";
  const std::string config_dir =
      p.configPath().empty() ? "" : std::filesystem::path(p.configPath()).parent_path().string();
  Scene scene = Scene::fromConfig(p.section("scene"), p.section("objects"), p.section("chessboard"),
                                  where, config_dir);
  return std::make_unique<Simulator>(rigFromParams(p), std::move(scene), plantParamsFrom(p),
                                     p.getDouble("noise_sigma"),
                                     static_cast<unsigned>(p.getInt("seed")));
}

std::string viscaModelPath(const Params& p) {
  if (p.getInt("visca_port") <= 0) return "";
  // Real cameras do not speak LCM: ptz-driver commands them and publishes PTZ_STATE.
  if (p.getString("visca_model").empty()) {
    throw ConfigError("parameter 'visca_port' needs 'visca_model' (a VISCA model file)");
  }
  return p.getExistingPath("visca_model");
}

std::string onvifModelPath(const Params& p) {
  if (p.getInt("onvif_port") <= 0) return "";
  if (p.getInt("visca_port") > 0) {
    throw ConfigError("parameters 'onvif_port' and 'visca_port' exclude each other (one plant)");
  }
  if (p.getString("onvif_model").empty()) {
    throw ConfigError("parameter 'onvif_port' needs 'onvif_model' (an ONVIF model file)");
  }
  return p.getExistingPath("onvif_model");
}

SimClock SimClock::fromParams(const Params& p) {
  const std::string clock = p.getString("clock");
  if (clock != "realtime" && clock != "lockstep") {
    throw p.invalid("clock", "must be realtime or lockstep");
  }
  SimClock c;
  c.lockstep = clock == "lockstep";
  c.frame_period_s = 1.0 / p.getDouble("frame_rate_hz");
  c.state_period_s = 1.0 / p.getDouble("state_rate_hz");
  c.lockstep_timeout_ms = p.getDouble("lockstep_timeout_ms");
  c.served_heads = p.getInt("visca_port") > 0 || p.getInt("onvif_port") > 0;
  c.lockstep_served_wait_ms = p.getDouble("lockstep_served_wait_ms");
  return c;
}

SimRun::SimRun(std::unique_ptr<Simulator> sim, const SimClock& clock, StateSink publish_state)
    : sim_(std::move(sim)),
      clock_(clock),
      publish_state_(std::move(publish_state)),
      start_steady_(std::chrono::steady_clock::now()) {}

int64_t SimRun::simUtime(double t_s) const {
  if (clock_.lockstep) return kLockstepEpochUtime + std::llround(t_s * 1e6);
  return wallUtime() + std::llround((t_s - realtimeNow()) * 1e6);
}

double SimRun::realtimeNow() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_steady_).count();
}

void SimRun::advanceWithStates(double t_s) {
  const std::lock_guard<std::mutex> lock(motors_);
  while (next_state_t_ <= t_s) {
    sim_->advanceTo(next_state_t_);
    ptzstereo::ptz_state_t state = makeStateMessage(sim_->plant(), simUtime(sim_->time()));
    state.setpoint_utime = last_setpoint_utime_;
    publish_state_(&state);
    next_state_t_ += clock_.state_period_s;
  }
  sim_->advanceTo(t_s);
}

bool SimRun::waitForFrame(double t_frame_s, const Serve& serve) {
  for (;;) {
    const double now = realtimeNow();
    if (now >= t_frame_s) {
      // Setpoints that arrived meanwhile act now, even when the frames run late.
      serve(0);
      if (now - t_frame_s > clock_.frame_period_s) return false;
      advanceWithStates(t_frame_s);
      return true;
    }
    if (now >= next_state_t_) {
      advanceWithStates(now);
      continue;
    }
    const double until = std::min(t_frame_s, next_state_t_);
    serve(std::max(1, static_cast<int>((until - now) * 1000)));
  }
}

Answer SimRun::awaitAnswer(int64_t seq, const Serve& serve) {
  awaiting_seq_ = seq;
  answered_ = false;
  const auto deadline =
      std::chrono::steady_clock::now() +
      std::chrono::microseconds(static_cast<int64_t>(clock_.lockstep_timeout_ms * 1000));
  Answer answer = Answer::kAnswered;
  const auto served_wait =
      std::chrono::microseconds(static_cast<int64_t>(clock_.lockstep_served_wait_ms * 1000));
  const auto done = [&] {
    if (!clock_.served_heads) return answered_;
    return answered_ && (served_commands_ > commands_at_answer_ ||
                         std::chrono::steady_clock::now() >= answered_at_ + served_wait);
  };
  while (!done()) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                          deadline - std::chrono::steady_clock::now())
                          .count();
    if (left <= 0) {
      answer = Answer::kTimedOut;
      break;
    }
    // Served heads: the cameras' commands come on other threads, so LCM is polled in short slices.
    const int64_t slice_ms = clock_.served_heads ? 2 : 100;
    if (!serve(static_cast<int>(std::min<int64_t>(left, slice_ms)))) {
      answer = Answer::kStopped;
      break;
    }
  }
  awaiting_seq_ = -1;
  return answer;
}

SimRun::Capture SimRun::capture() {
  Capture c;
  {  // the instant of capture; the motors may move on while it renders
    const std::lock_guard<std::mutex> lock(motors_);
    c.frame = sim_->snapshot();
    c.utime = simUtime(c.frame.t_s);
    c.truth = makeTruthMessage(*sim_, c.frame, c.utime);
  }
  sim_->render(&c.frame);
  setVisibility(c.frame, &c.truth);
  current_frame_t_ = c.frame.t_s;
  return c;
}

SetpointOutcome SimRun::applySetpoint(const ptzstereo::ptz_setpoint_t& m) {
  SetpointOutcome out;
  double t_apply;
  if (clock_.lockstep) {
    if (m.frame_seq >= 0 && m.frame_seq != awaiting_seq_) {
      out.dropped = "setpoint_stale";
      return out;
    }
    // The answer to frame n is issued at that frame's capture time; tau delays it.
    t_apply = m.frame_seq >= 0 ? current_frame_t_ : sim_->time();
  } else {
    t_apply = std::max(sim_->time(), realtimeNow());
    advanceWithStates(t_apply);
  }
  const PtzPose left{m.left.pan_rad, m.left.tilt_rad, m.left.zoom};
  const PtzPose right{m.right.pan_rad, m.right.tilt_rad, m.right.zoom};
  {
    const std::lock_guard<std::mutex> lock(motors_);
    sim_->command(t_apply, left, right, &out.clamped, &out.rejected);
  }
  last_setpoint_utime_ = m.utime;
  if (m.frame_seq == awaiting_seq_) answered_ = true;
  return out;
}

void SimRun::noteControllerAnswer(int64_t frame_seq) {
  if (frame_seq != awaiting_seq_ || answered_) return;
  answered_ = true;
  commands_at_answer_ = served_commands_;
  answered_at_ = std::chrono::steady_clock::now();
}

void SimRun::withMotorsNow(const std::function<void(Simulator& sim, double t_s)>& f) {
  const std::lock_guard<std::mutex> lock(motors_);
  const double t_s = clock_.lockstep ? sim_->time() : std::max(sim_->time(), realtimeNow());
  sim_->advanceTo(t_s);
  f(*sim_, t_s);
}

}  // namespace ptz::sim
