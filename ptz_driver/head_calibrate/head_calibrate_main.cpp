// ptz-head-calibrate: measures the angle map a PTZ head's model file should hold (pan and tilt
// units per degree, zoom position -> zoom ratio) from how the scene moves in STEREO_FRAME while
// it moves both heads in their own units, and writes the model file with it. ONVIF and VISCA
// heads (parameters as ptz-driver's); the rig file is the ruler. Run it instead of ptz-driver.
#include <poll.h>

#include <opencv2/imgproc.hpp>

#include <cstdio>

#include "common/transport/intake.hpp"
#include "common/transport/transport.hpp"
#include "ptz_driver/head_calibrate/head_calibration.hpp"
#include "ptz_driver/head_calibrate/unit_map_files.hpp"
#include "ptz_driver/heads/common/heads_stop.hpp"
#include "ptz_driver/heads/head_factory.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz::driver {
namespace {

void declareParams(Params& p) {
  addTransportParams(p);
  declareRigParams(p);
  declareBackendParams(p);
  addFreshnessParams(p, "frame", 1000.0, "a STEREO_FRAME");
  p.add("output", "", "the model file written (the backend's model file with the map measured)");
  p.add("move_deg", 3.0, "deg", "pan and tilt moves of 1 and 2 times this either side of home",
        Range::between(0.2, 20));
  p.add("zoom_step_ratio", 1.1, "", "neighbouring zoom positions at most this zoom ratio apart",
        Range::between(1.01, 2));
  p.add("zoom_positions_min", 16, "", "the zoom range in at least this many steps",
        Range::between(2, 1000));
  p.add("zoom_table_tolerance", 0.005, "",
        "then positions are added between where the table, interpolated, may miss the lens by "
        "more than this part of the zoom ratio",
        Range::between(1e-4, 0.5));
  p.add("zoom_max_units", 0.0, "",
        "the zoom measured up to this position (VISCA: where the rig's zoom table ends); 0: the "
        "model file's last",
        Range::atLeast(0));
  p.add("settle_s", 0.4, "s", "a position is measured once the image held still this long",
        Range::between(0.05, 10));
  p.add("settle_px", 0.2, "px", "still: the scene moved at most this (mean) meanwhile",
        Range::between(0.001, 5));
  p.add("arrive_fraction", 0.01, "",
        "and the head said it is within this part of the move from its target",
        Range::between(1e-4, 1));
  p.add("move_timeout_s", 20.0, "s",
        "a head not there and still within this long, or no usable frame for this long, fails "
        "the run",
        Range::between(1, 600));
}

HeadCalibrationSettings settingsFrom(const Params& p) {
  HeadCalibrationSettings s;
  s.move_rad = p.getDouble("move_deg") * M_PI / 180;
  s.zoom_step_ratio = p.getDouble("zoom_step_ratio");
  s.zoom_positions_min = p.getInt("zoom_positions_min");
  s.zoom_table_tolerance = p.getDouble("zoom_table_tolerance");
  s.settle_s = p.getDouble("settle_s");
  s.settle_px = p.getDouble("settle_px");
  s.arrive_fraction = p.getDouble("arrive_fraction");
  s.move_timeout_s = p.getDouble("move_timeout_s");
  return s;
}

std::string templatePath(const Params& p) {
  const bool onvif = p.getString("backend") == "onvif";
  return p.getExistingPath(onvif ? "onvif_model" : "visca_model");
}

UnitMapGuess guessFrom(const Params& p, const std::string& template_path) {
  UnitMapGuess g = guessFromModelFile(p.getString("backend"), template_path);
  const double top = p.getDouble("zoom_max_units");
  if (top > 0 && p.getString("backend") == "onvif") {
    throw p.invalid("zoom_max_units", "is for VISCA heads: an ONVIF model's zoom runs 0..1");
  }
  if (top > 0) g.zoom_max_units = top;
  return g;
}

class HeadCalibrateNode {
 public:
  HeadCalibrateNode(const Params& p, lcm::LCM* lcm, const StereoRig& rig)
      : lcm_(lcm),
        status_(lcm, p, "ptz-head-calibrate"),
        backend_(p.getString("backend")),
        template_(templatePath(p)),
        output_(p.getPath("output")),
        ch_frame_(channel(p, channels::kStereoFrame)),
        intake_(status_, ch_frame_, freshnessFrom(p, "frame"), {rig.left.width, rig.left.height},
                p.getPath("rig_file")),
        guess_(guessFrom(p, template_)),
        calibration_(rig, guess_, settingsFrom(p)),
        heads_(makeUnitHeads(p)),
        frame_timeout_s_(p.getDouble("move_timeout_s")) {
    if (output_.empty()) throw p.invalid("output", "is required: the model file to write");
    frames_ = std::make_unique<SafeSubscription<ptzstereo::stereo_frame_t>>(
        *lcm_, ch_frame_, status_,
        [this](const std::string&, const ptzstereo::stereo_frame_t& m) { onFrame(m); },
        Delivery::kNewest);
    status_.expectInput(ch_frame_);
  }

  int run() {
    HeadsStop stopper({heads_[0].get(), heads_[1].get()}, 0.3, &nowS, [](size_t i) {
      std::fprintf(stderr, "ptz-head-calibrate: the %s head did not confirm the stop\n",
                   i == 0 ? "left" : "right");
    });
    for (auto& h : heads_) h->start(nowS());
    command();
    status_.publishNow();
    last_frame_s_ = nowS();
    while (!StopFlag::stopRequested() && calibration_.state() == HeadCalibration::State::kRunning) {
      if (nowS() - last_frame_s_ > frame_timeout_s_) {
        std::fprintf(stderr,
                     "ptz-head-calibrate: failed: no usable %s for %.0f s (is ptz-camera or "
                     "ptz-sim running, on this lcm_url?)\n",
                     ch_frame_.c_str(), frame_timeout_s_);
        stopper.stop();
        status_.publishLast();
        return 1;
      }
      pollfd fds[3] = {{lcm_->getFileno(), POLLIN, 0},
                       {heads_[0]->fd(), POLLIN, 0},
                       {heads_[1]->fd(), POLLIN, 0}};
      ::poll(fds, 3, 20);
      if (fds[0].revents & POLLIN) handleNewest(*lcm_, 0);
      for (auto& h : heads_) {
        h->receive(nowS());
        h->inquire(nowS(), 0.5);
      }
      // Re-sent, as ptz-driver does each tick: a head whose request failed drops the move it
      // held (the camera may not have taken it), and hears it again here.
      if (nowS() - last_command_s_ >= kCommandPeriodS) command();
      status_.maybePublish();
    }
    stopper.stop();
    status_.publishLast();
    if (calibration_.state() == HeadCalibration::State::kFailed) {
      std::fprintf(stderr, "ptz-head-calibrate: failed: %s\n", calibration_.error().c_str());
      for (size_t i = 0; i < 2; ++i) {
        const std::string problem = heads_[i]->problem(nowS());
        if (!problem.empty()) {
          std::fprintf(stderr, "ptz-head-calibrate: the %s head: %s\n", i == 0 ? "left" : "right",
                       problem.c_str());
        }
        const HeadStats& st = heads_[i]->stats();
        if (st.timeouts + st.errors + st.malformed > 0) {
          std::fprintf(stderr,
                       "ptz-head-calibrate: the %s head: %lld timeouts, %lld errors, %lld "
                       "malformed of %lld requests (the last: %s)\n",
                       i == 0 ? "left" : "right", static_cast<long long>(st.timeouts),
                       static_cast<long long>(st.errors), static_cast<long long>(st.malformed),
                       static_cast<long long>(st.sent), st.last_error.c_str());
        }
      }
      return 1;
    }
    if (calibration_.state() != HeadCalibration::State::kDone) {
      std::fprintf(stderr, "ptz-head-calibrate: stopped before the map was measured\n");
      return 1;
    }
    writeModelFile(backend_, template_, guess_, calibration_.result(), output_);
    std::fprintf(stderr, "ptz-head-calibrate: wrote %s\n", output_.c_str());
    return 0;
  }

 private:
  static double nowS() { return wallUtime() * 1e-6; }

  void command() {
    last_command_s_ = nowS();
    const UnitPose& u = calibration_.target();
    for (auto& h : heads_) h->command(PtzPose{u.pan, u.tilt, 1 + u.zoom}, nowS());
  }

  void onFrame(const ptzstereo::stereo_frame_t& m) {
    const int64_t received = wallUtime();
    if (!intake_.accept(m, received)) return;
    cv::Mat left, right;
    if (!intake_.decode(m, &left, &right)) return;
    status_.countIn(ch_frame_, latencyMs(m.utime, received));
    last_frame_s_ = received * 1e-6;
    cv::cvtColor(left, left, cv::COLOR_BGR2GRAY);
    cv::cvtColor(right, right, cv::COLOR_BGR2GRAY);
    std::array<std::optional<UnitPose>, 2> measured;
    for (size_t i = 0; i < 2; ++i) {
      if (const auto pose = heads_[i]->measured()) {
        measured[i] = UnitPose{pose->pan_rad, pose->tilt_rad, pose->zoom - 1};
      }
    }
    const UnitPose before = calibration_.target();
    calibration_.onFrame(left, right, received * 1e-6, measured);
    for (const auto& line : calibration_.takeLog()) {
      std::fprintf(stderr, "ptz-head-calibrate: %s\n", line.c_str());
    }
    const UnitPose& after = calibration_.target();
    if (after.pan != before.pan || after.tilt != before.tilt || after.zoom != before.zoom) {
      command();
    }
  }

  lcm::LCM* lcm_;
  StatusReporter status_;
  std::string backend_, template_, output_, ch_frame_;
  FrameIntake intake_;
  UnitMapGuess guess_;
  HeadCalibration calibration_;
  std::array<std::unique_ptr<PtzHead>, 2> heads_;
  static constexpr double kCommandPeriodS = 0.1;
  double frame_timeout_s_, last_frame_s_ = 0, last_command_s_ = 0;
  std::unique_ptr<SafeSubscription<ptzstereo::stereo_frame_t>> frames_;
};

}  // namespace
}  // namespace ptz::driver

int main(int argc, char** argv) {
  using namespace ptz;
  Params params("ptz-head-calibrate",
                "Measures a PTZ head's angle map (pan and tilt units per degree, zoom position "
                "to zoom ratio) from the scene's motion in STEREO_FRAME while it moves both "
                "heads, and writes their model file with it (backends onvif, visca_ip, "
                "visca_serial).");
  driver::declareParams(params);
  return runProcess(argc, argv, params, [](const Params& p, lcm::LCM& lcm) {
    driver::HeadCalibrateNode node(p, &lcm, rigFromParams(p));
    return node.run();
  });
}
