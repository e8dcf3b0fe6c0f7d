// ptz-sim: renders the stereo pair and models the PTZ motors; speaks the same channels as
// ptz-camera + ptz-driver. The clocks, the setpoints and the states are SimRun's (sim_run.hpp);
// here: flags, subscriptions, the frame loop, publishing and the status.
#include <cstdio>
#include <memory>
#include <string>

#include "common/freshness.hpp"
#include "common/transport/intake.hpp"
#include "common/transport/transport.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "sim/onvif/onvif_server.hpp"
#include "sim/sim_messages.hpp"
#include "sim/sim_run.hpp"
#include "sim/visca_server.hpp"

namespace ptz::sim {
namespace {

class SimNode {
 public:
  SimNode(const Params& p, lcm::LCM* lcm, const SimClock& clock)
      : p_(p),
        lcm_(lcm),
        status_(lcm, p, "ptz-sim"),
        bulk_out_(p, *lcm),
        preview_(p),
        encoding_(imageEncodingFrom(p)),
        jpeg_quality_(p.getInt("jpeg_quality")),
        setpoint_fresh_(status_, freshnessFrom(p, "setpoint"), "setpoint", "setpoint_",
                        CaptureClock::kWall),
        ch_frame_(channel(p, channels::kStereoFrame)),
        ch_state_(channel(p, channels::kPtzState)),
        ch_truth_(channel(p, channels::kSimTruth)),
        ch_setpoint_(channel(p, channels::kPtzSetpoint)),
        run_(simulatorFromParams(p), clock, [this](ptzstereo::ptz_state_t* m) { publishState(m); }),
        serve_([this](int timeout_ms) {
          if (StopFlag::stopRequested()) return false;
          handleNewest(*lcm_, timeout_ms);
          status_.maybePublish();
          return true;
        }) {
    const std::string visca_model = viscaModelPath(p);
    const std::string onvif_model = onvifModelPath(p);
    if (!visca_model.empty()) {
      visca_ = std::make_unique<ViscaCameras>(driver::ViscaModel::load(visca_model),
                                              p.getInt("visca_port"), &run_);
    } else if (!onvif_model.empty()) {
      std::array<driver::OnvifCameraSettings, 2> cameras;
      const std::string password = onvifPassword(p.getString("onvif_password_file"));
      for (size_t i = 0; i < 2; ++i) {
        cameras[i].user = p.getString("onvif_user");
        cameras[i].password = password;
        cameras[i].clock_offset_s = p.getDouble("onvif_clock_offset_s");
        cameras[i].serial = i == 0 ? "PTZSIM-LEFT" : "PTZSIM-RIGHT";
      }
      OnvifServerOptions options;
      options.first_port = p.getInt("onvif_port");
      options.discovery = p.getBool("onvif_discovery");
      options.http_digest = p.getBool("onvif_http_digest");
      if (options.http_digest && password.empty()) {
        throw ConfigError("parameter 'onvif_http_digest' needs a password (onvif_password_file)");
      }
      onvif_ = std::make_unique<OnvifCameras>(
          driver::OnvifModel::load(onvif_model), cameras, options,
          [this](const OnvifCameras::Step& step) {
            run_.withMotorsNow([this, &step](Simulator& sim, double t_s) {
              const auto sp = step({sim.plant().pose(Side::kLeft), sim.plant().pose(Side::kRight)});
              int clamped = 0, rejected = 0;
              if (!sp) return;
              sim.command(t_s, (*sp)[0], (*sp)[1], &clamped, &rejected);
              run_.noteServedCommand();
            });
          });
    }
    if (visca_ || onvif_) {
      if (run_.lockstep()) {  // the controller's answer seen, not applied: the cameras' commands
                              // are
        setpoints_ = std::make_unique<SafeSubscription<ptzstereo::ptz_setpoint_t>>(
            *lcm_, ch_setpoint_, status_,
            [this](const std::string& ch, const ptzstereo::ptz_setpoint_t& m) {
              status_.countIn(ch, -1);
              run_.noteControllerAnswer(m.frame_seq);
            });
      }
    } else {
      setpoints_ = std::make_unique<SafeSubscription<ptzstereo::ptz_setpoint_t>>(
          *lcm_, ch_setpoint_, status_,
          [this](const std::string& ch, const ptzstereo::ptz_setpoint_t& m) { onSetpoint(ch, m); },
          Delivery::kNewest);
    }
  }

  int run() {
    const int max_frames = p_.getInt("frames");
    const double duration_s = p_.getDouble("duration_s");
    const double frame_period_s = 1.0 / p_.getDouble("frame_rate_hz");
    if (visca_) visca_->start();
    if (onvif_) onvif_->start();
    for (int64_t n = 0; !StopFlag::stopRequested(); ++n) {
      const double t_frame = n * frame_period_s;
      if ((max_frames > 0 && n >= max_frames) || (duration_s > 0 && t_frame > duration_s)) break;
      if (run_.lockstep()) {
        run_.advanceWithStates(t_frame);
      } else if (!run_.waitForFrame(t_frame, serve_)) {
        status_.increment("frames_skipped_late");
        log_.warn("late", "ptz-sim: frame " + std::to_string(n) +
                              " skipped: rendering falls behind the frame rate (" +
                              formatNumber(1.0 / frame_period_s) + " Hz)");
        continue;
      }
      publishFrame();
      if (run_.lockstep() && run_.awaitAnswer(n, serve_) == Answer::kTimedOut) {
        status_.increment("lockstep_timeouts");
      }
      reportVisca();
      status_.maybePublish();
    }
    if (visca_) visca_->stop();
    if (onvif_) onvif_->stop();
    reportVisca();
    status_.publishLast();
    std::printf("ptz-sim: %lld frames published, %lld skipped late, %lld setpoints applied\n",
                static_cast<long long>(status_.counter("frames_published")),
                static_cast<long long>(status_.counter("frames_skipped_late")),
                static_cast<long long>(status_.counter("setpoints_applied")));
    return 0;
  }

 private:
  void reportVisca() {
    if (onvif_) {
      // As the VISCA cameras count theirs: what the ONVIF cameras could not read.
      const OnvifServerCounters c = onvif_->counters();
      status_.setCounter("onvif_requests", c.requests);
      status_.setCounter("onvif_bad_requests", c.bad_requests);
      status_.setCounter("onvif_soap_faults", c.soap_faults);
      status_.setCounter("onvif_auth_refused", c.auth_refused);
      status_.setCounter("onvif_connections_refused", c.connections_refused);
      status_.setCounter("onvif_connections_timed_out", c.connections_timed_out);
      status_.setCounter("onvif_setpoints_applied", onvif_->setpointsApplied());
      const DiscoveryCounters d = onvif_->discoveryCounters();
      status_.setCounter("onvif_probes_answered", d.answered);
      status_.setCounter("onvif_probes_ignored", d.ignored);
      status_.setCounter("onvif_probes_dropped", d.oversize + d.malformed);
    }
    if (!visca_) return;
    status_.setCounter("visca_packets", visca_->packets());
    status_.setCounter("visca_malformed", visca_->malformed());
    status_.setCounter("visca_setpoints_applied", visca_->setpointsApplied());
  }

  void publishState(ptzstereo::ptz_state_t* m) {
    if (visca_ || onvif_) return;  // ptz-driver publishes the state it reads from the cameras
    m->publish_utime = wallUtime();
    status_.publish(ch_state_, *m);
  }

  void publishFrame() {
    SimRun::Capture c = run_.capture();
    ptzstereo::stereo_frame_t msg = makeFrameMessage(c.frame, c.utime, encoding_, jpeg_quality_);
    const int64_t now = wallUtime();
    msg.publish_utime = now;
    // A frame LCM did not take (no route: a link went down) is not published; it is counted as
    // STEREO_FRAME.publish_failures, and the run's numbers count its time as lost.
    if (status_.publishOn(bulk_out_.lcm(), ch_frame_, msg,
                          run_.lockstep() ? -1 : (now - c.utime) / 1000.0)) {
      status_.increment("frames_published");
    }
    preview_.maybePublish(status_, *lcm_, c.utime, c.frame.index, c.frame.left, c.frame.left_pose,
                          c.frame.right, c.frame.right_pose, !run_.lockstep());
    c.truth.publish_utime = wallUtime();
    status_.publish(ch_truth_, c.truth);
  }

  void onSetpoint(const std::string& ch, const ptzstereo::ptz_setpoint_t& m) {
    // Realtime: judged by the capture time of the frame it answers (an answer to an old frame is
    // old); lockstep: SimRun drops an answer to another frame.
    if (!run_.lockstep() &&
        !setpoint_fresh_.admit(ch, m.utime, m.publish_utime, m.frame_seq, wallUtime())) {
      return;
    }
    const SetpointOutcome r = run_.applySetpoint(m);
    if (!r.dropped.empty()) {
      status_.countDropped(ch, r.dropped);
      return;
    }
    status_.countIn(ch, run_.lockstep() ? -1 : (wallUtime() - m.utime) / 1000.0);
    // Once a controller has spoken, its silence is news (a lost link, a dead host); before, the
    // rig may be running open loop on purpose.
    if (!run_.lockstep() && !setpoints_expected_) {
      status_.expectInput(ch, 1.0, 5.0);
      setpoints_expected_ = true;
    }
    status_.increment("setpoints_applied");
    if (r.clamped) {
      status_.increment("setpoint_values_clamped", r.clamped);
      log_.warn("clamped", "ptz-sim: setpoint outside the limits; clamped");
    }
    if (r.rejected) {
      status_.increment("setpoint_values_rejected", r.rejected);
      log_.warn("rejected", "ptz-sim: setpoint with non-finite values; those axes hold");
    }
  }

  const Params& p_;
  lcm::LCM* lcm_;
  StatusReporter status_;
  FrameOutput bulk_out_;
  PreviewOutput preview_;
  RateLimitedLog log_;
  int8_t encoding_;
  int jpeg_quality_;
  FreshnessGate setpoint_fresh_;
  std::string ch_frame_, ch_state_, ch_truth_, ch_setpoint_;
  SimRun run_;
  SimRun::Serve serve_;
  std::unique_ptr<ViscaCameras> visca_;
  std::unique_ptr<OnvifCameras> onvif_;
  std::unique_ptr<SafeSubscription<ptzstereo::ptz_setpoint_t>> setpoints_;
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
  addTransportParams(params);
  addFrameOutputParams(params);
  addPreviewParams(params);
  sim::declareSimClockParams(params);
  addImageEncodingParams(params);
  sim::declareSimSceneParams(params);
  return runProcess(argc, argv, params, [](const Params& p, lcm::LCM& lcm) {
    const sim::SimClock clock = sim::SimClock::fromParams(p);
    imageEncodingFrom(p);  // throws for a bad encoding or quality
    sim::SimNode node(p, &lcm, clock);
    return node.run();
  });
}
