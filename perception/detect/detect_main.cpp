// ptz-detect: STEREO_FRAME -> OBJECT_DETECTIONS + OBJECT_POSE. Always the newest fresh frame (those
// waiting are drained, older ones dropped as superseded, late ones as stale); every output carries
// the source frame's utime and seq; bad frames are dropped, counted and warned about, never fatal.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>

#include "common/freshness.hpp"
#include "common/transport.hpp"
#include "perception/detect/detector.hpp"
#include "perception/detect/stereo.hpp"
#include "ptzstereo/object_detections_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz::perception {
namespace {

void declare(Params& p) {
  addTransportParams(p);
  p.add("rig_file", "", "rig file (OpenCV YAML); empty: the built-in default rig");
  p.add("target_class", "red_ball", "class of the object of interest (OBJECT_POSE target_index)");
  p.add("filter_size_px", 3, "px", "median filter size (odd)", Range::between(1, 99));
  p.add("morph_size_px", 3, "px", "opening/closing kernel size", Range::between(1, 99));
  p.add("max_epipolar_px", 3.0, "px",
        "largest distance of a left/right match from its epipolar line", Range::above(0));
  p.add("max_area_ratio", 2.0, "", "largest left/right area ratio of a match", Range::atLeast(1));
  p.add("pixel_sigma_px", 0.3, "px", "centroid noise for the pose covariance", Range::above(0));
  p.add("min_range_m", 0.3, "m", "nearest accepted object", Range::above(0));
  p.add("max_range_m", 50.0, "m", "farthest accepted object", Range::above(0));
  p.addOrder("min_range_m", "max_range_m");
  addFreshnessParams(p, "frame", 500.0, "a STEREO_FRAME");
  p.addSection("classes",
               "list of {name, hue_min_deg, hue_max_deg, saturation_min, saturation_max, "
               "intensity_min, intensity_max, shape: circle|square|any, "
               "max_shape_distance, max_elongation, min_area_px2, max_area_px2}");
}

ptzstereo::detection_2d_t toMessage(const Region& r, const DetectorParams& dp) {
  ptzstereo::detection_2d_t d{};
  d.class_name = dp.classes[static_cast<size_t>(r.class_index)].name;
  d.centroid_x_px = r.centroid_px.x;
  d.centroid_y_px = r.centroid_px.y;
  d.area_px2 = r.area_px2;
  d.bbox_x_px = r.bbox.x;
  d.bbox_y_px = r.bbox.y;
  d.bbox_width_px = r.bbox.width;
  d.bbox_height_px = r.bbox.height;
  d.shape_distance = r.shape_distance;
  d.match_index = -1;
  return d;
}

class DetectNode {
 public:
  DetectNode(const Params& p, lcm::LCM* lcm, StereoRig rig, DetectorParams dp)
      : lcm_(lcm),
        status_(lcm, p, "ptz-detect"),
        rig_(std::move(rig)),
        rig_file_(p.getString("rig_file")),
        detector_(std::move(dp)),
        target_class_(p.getString("target_class")),
        frame_freshness_(freshnessFrom(p, "frame")),
        ch_frame_(channel(p, channels::kStereoFrame)),
        ch_detections_(channel(p, channels::kObjectDetections)),
        ch_pose_(channel(p, channels::kObjectPose)) {
    stereo_.max_epipolar_px = p.getDouble("max_epipolar_px");
    stereo_.max_area_ratio = p.getDouble("max_area_ratio");
    stereo_.pixel_sigma_px = p.getDouble("pixel_sigma_px");
    stereo_.min_range_m = p.getDouble("min_range_m");
    stereo_.max_range_m = p.getDouble("max_range_m");
    // Always the newest frame, never a backlog.
    frames_ = std::make_unique<SafeSubscription<ptzstereo::stereo_frame_t>>(
        *lcm_, ch_frame_, status_,
        [this](const std::string&, const ptzstereo::stereo_frame_t& m) { onFrame(&m); },
        Delivery::kNewest);
    status_.expectInput(ch_frame_);
  }

  int run() { return serveUntilStopped(*lcm_, status_); }

 private:
  // Checks the frame against the rig before a pixel is decoded: the rig's size and BGR on both
  // sides bound what a frame may cost.
  bool acceptable(const ptzstereo::stereo_frame_t& m) {
    std::string why;
    if (!checkStereoFrame(m, kMaxImageSidePx, &why)) {
      drop("bad_image", "frame " + std::to_string(m.seq) + ": " + why);
      return false;
    }
    if (!checkFrameMatchesRig(m, rig_.left.width, rig_.left.height, &why)) {
      const std::string rig_file =
          rig_file_.empty() ? "the built-in rig" : "rig file '" + rig_file_ + "'";
      drop("size_mismatch", "frame " + std::to_string(m.seq) + ": " + why + " (" + rig_file +
                                "): calibrate at this image size (ptz-calibrate)");
      return false;
    }
    return true;
  }

  bool decode(const ptzstereo::stereo_frame_t& m, cv::Mat* left, cv::Mat* right) {
    if (!acceptable(m)) return false;
    // Both images at once: JPEG decoding is the larger part of a frame's work.
    std::string errors[2];
    bool ok[2] = {false, false};
    cv::parallel_for_(cv::Range(0, 2), [&](const cv::Range& range) {
      for (int i = range.start; i < range.end; ++i) {
        ok[i] = decodeImage(i == 0 ? m.left : m.right, i == 0 ? left : right, &errors[i]);
      }
    });
    if (!ok[0] || !ok[1]) {
      drop("bad_image", "frame " + std::to_string(m.seq) + ": " + (ok[0] ? errors[1] : errors[0]));
      return false;
    }
    return true;
  }

  void drop(const std::string& reason, const std::string& message) {
    status_.countDropped(ch_frame_, reason);
    log_.warn(reason, "ptz-detect: dropped " + message);
  }

  void onFrame(const ptzstereo::stereo_frame_t* m) {
    const int64_t received = wallUtime();
    const bool wall_clock = captureOnWallClock(m->utime, m->publish_utime);
    const Freshness fresh =
        judgeFreshness(m->utime, m->publish_utime, received, frame_freshness_, wall_clock);
    if (fresh != Freshness::kFresh) {
      drop(freshnessReason(fresh),
           "frame " + std::to_string(m->seq) + ": " + freshnessReason(fresh) + " (published " +
               formatNumber(saturatingDiffUs(received, m->publish_utime) / 1000.0) + " ms ago)");
      return;
    }
    cv::Mat left, right;
    if (!decode(*m, &left, &right)) return;
    // Counted in once accepted: every message is either in or dropped, never both.
    status_.countIn(ch_frame_, latencyMs(m->utime, received));
    const auto t0 = std::chrono::steady_clock::now();
    // Left and right on two cores (Detector::detect is const and shares nothing mutable).
    std::vector<Region> lr, rr;
    cv::parallel_for_(cv::Range(0, 2), [&](const cv::Range& range) {
      for (int i = range.start; i < range.end; ++i)
        (i == 0 ? lr : rr) = detector_.detect(i == 0 ? left : right);
    });
    const CameraView lv = rig_.view(Side::kLeft, {m->left.pan_rad, m->left.tilt_rad, m->left.zoom});
    const CameraView rv =
        rig_.view(Side::kRight, {m->right.pan_rad, m->right.tilt_rad, m->right.zoom});
    const std::vector<StereoObject> objects = associate(lr, rr, lv, rv, stereo_);
    processing_ms_.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());

    ptzstereo::object_detections_t det{};
    det.utime = m->utime;
    det.frame_seq = m->seq;
    for (const auto& r : lr) det.left.push_back(toMessage(r, detector_.params()));
    for (const auto& r : rr) det.right.push_back(toMessage(r, detector_.params()));
    det.num_left = static_cast<int32_t>(det.left.size());
    det.num_right = static_cast<int32_t>(det.right.size());

    ptzstereo::object_pose_t pose{};
    pose.utime = m->utime;
    pose.frame_seq = m->seq;
    pose.target_index = -1;
    pose.left_ptz = {m->left.pan_rad, m->left.tilt_rad, m->left.zoom};
    pose.right_ptz = {m->right.pan_rad, m->right.tilt_rad, m->right.zoom};
    for (const auto& o : objects) {
      det.left[static_cast<size_t>(o.left)].match_index = o.right;
      det.right[static_cast<size_t>(o.right)].match_index = o.left;
      ptzstereo::object_3d_t obj{};
      obj.class_name = detector_.params().classes[static_cast<size_t>(o.class_index)].name;
      for (int r = 0; r < 3; ++r) {
        obj.position_m[r] = o.position_head_m[r];
        for (int c = 0; c < 3; ++c) obj.covariance_m2[r * 3 + c] = o.covariance_m2(r, c);
      }
      obj.left_index = o.left;
      obj.right_index = o.right;
      // Apparent radius of a disc of the region's area, back to metres at the object's range.
      const double r_px = std::sqrt(lr[static_cast<size_t>(o.left)].area_px2 / M_PI);
      obj.radius_m = r_px * (o.position_head_m - lv.position_head_m).norm() / lv.intrinsics.fx;
      // The target: the largest region of the target class (regions come largest first).
      if (obj.class_name == target_class_ &&
          (pose.target_index < 0 ||
           pose.objects[static_cast<size_t>(pose.target_index)].left_index > o.left)) {
        pose.target_index = static_cast<int32_t>(pose.objects.size());
      }
      pose.objects.push_back(obj);
    }
    pose.num_objects = static_cast<int32_t>(pose.objects.size());
    det.publish_utime = wallUtime();
    status_.publish(ch_detections_, det, latencyMs(m->utime, det.publish_utime));
    pose.publish_utime = wallUtime();
    status_.publish(ch_pose_, pose, latencyMs(m->utime, pose.publish_utime));
    status_.increment("frames_processed");
    if (pose.target_index < 0) status_.increment("frames_without_target");
    if (processing_ms_.size() >= 30) {
      status_.setCounter("processing_us_p50",
                         static_cast<int64_t>(percentile(processing_ms_, 50) * 1000));
      status_.setCounter("processing_us_p99",
                         static_cast<int64_t>(percentile(processing_ms_, 99) * 1000));
      processing_ms_.clear();
    }
  }

  lcm::LCM* lcm_;
  StatusReporter status_;
  RateLimitedLog log_;
  StereoRig rig_;
  std::string rig_file_;  // named in the size-mismatch warning
  Detector detector_;
  StereoParams stereo_;
  std::string target_class_;
  FreshnessLimits frame_freshness_;
  std::string ch_frame_, ch_detections_, ch_pose_;
  std::vector<double> processing_ms_;
  std::unique_ptr<SafeSubscription<ptzstereo::stereo_frame_t>> frames_;
};

}  // namespace
}  // namespace ptz::perception

int main(int argc, char** argv) {
  using namespace ptz;
  Params params("ptz-detect",
                "Finds coloured objects of known shape in both images of every "
                "STEREO_FRAME, pairs them along epipolar lines, triangulates them "
                "and publishes OBJECT_DETECTIONS and OBJECT_POSE.");
  perception::declare(params);
  return runProcess(argc, argv, params, [](const Params& p, lcm::LCM& lcm) {
    if (p.configPath().empty()) {
      throw ConfigError(
          "--config FILE is required (it holds the colour classes; see "
          "config/detect_default.yaml)");
    }
    perception::DetectorParams dp = perception::DetectorParams::fromConfig(
        p.section("classes"), "config file '" + p.configPath() + "'");
    dp.filter_size_px = p.getInt("filter_size_px");
    dp.morph_size_px = p.getInt("morph_size_px");
    if (dp.filter_size_px % 2 == 0) throw p.invalid("filter_size_px", "must be odd");
    perception::checkTargetClass(p, dp);
    perception::DetectNode node(p, &lcm, rigFromParams(p), std::move(dp));
    return node.run();
  });
}
