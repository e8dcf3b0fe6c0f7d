// ptz-depth: STEREO_FRAME (+ OBJECT_POSE for the horopter) -> POINT_CLOUD, optionally
// DISPARITY_IMAGE and PCD files. Always the newest fresh frame (a backlog is drained, stale frames
// dropped); outputs carry the source frame's utime and seq; bad frames and unwritable PCD files are
// counted and warned about, never fatal.
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cmath>
#include <memory>
#include <optional>

#include "common/freshness.hpp"
#include "common/transport/intake.hpp"
#include "perception/depth/cloud.hpp"
#include "perception/depth/depth.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/point_cloud_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz::perception {
namespace {

void declare(Params& p) {
  addTransportParams(p);
  addFrameOutputParams(p);
  declareRigParams(p);
  declareDepthParams(p);
  declareCloudParams(p);
  addFreshnessParams(p, "frame", 1000.0, "a STEREO_FRAME");
  p.add("target_max_age_s", 1.0, "s", "an OBJECT_POSE target older than this is not followed",
        Range::above(0).andAtMost(3600));
  p.add("pcd_path", "",
        "write clouds as binary PCD here ({seq} is replaced by the frame's seq); empty: none");
  p.add("pcd_every_n", 0, "", "write every n-th cloud (0: the first only)", Range::atLeast(0));
  p.add("publish_disparity", false, "publish the disparity on DISPARITY_IMAGE (grey, raw)");
  p.add("cloud_preview_rate_hz", 0.0, "Hz",
        "rate of POINT_CLOUD_PREVIEW, every k-th point of the cloud on lcm_url, for another "
        "host when the clouds stay on this one (0: none)",
        Range::between(0, 1000));
  p.add("cloud_preview_max_bytes", 24000, "bytes", "the preview's points within this many bytes",
        Range::between(1000, kLcmLargestDatagramBytes));
}

class DepthNode {
 public:
  DepthNode(const Params& p, lcm::LCM* lcm, StereoRig rig)
      : lcm_(lcm),
        status_(lcm, p, "ptz-depth"),
        bulk_out_(p, *lcm),
        cloud_preview_schedule_(p.getDouble("cloud_preview_rate_hz")),
        cloud_preview_max_bytes_(p.getInt("cloud_preview_max_bytes")),
        ch_cloud_preview_(channel(p, channels::kPointCloudPreview)),
        estimator_(std::move(rig), DepthParams::fromParams(p)),
        cloud_maker_(CloudParams::fromParams(p)),
        target_max_age_us_(static_cast<int64_t>(p.getDouble("target_max_age_s") * 1e6)),
        intake_(status_, channel(p, channels::kStereoFrame), freshnessFrom(p, "frame"),
                {estimator_.rectifier().rig().left.width, estimator_.rectifier().rig().left.height},
                p.getPath("rig_file")),
        pcd_path_(p.getString("pcd_path")),
        pcd_every_n_(p.getInt("pcd_every_n")),
        publish_disparity_(p.getBool("publish_disparity")),
        ch_frame_(channel(p, channels::kStereoFrame)),
        ch_pose_(channel(p, channels::kObjectPose)),
        ch_cloud_(channel(p, channels::kPointCloud)),
        ch_disparity_(channel(p, channels::kDisparityImage)) {
    poses_ = std::make_unique<SafeSubscription<ptzstereo::object_pose_t>>(
        *lcm_, ch_pose_, status_,
        [this](const std::string&, const ptzstereo::object_pose_t& m) { onPose(m); });
    frames_ = std::make_unique<SafeSubscription<ptzstereo::stereo_frame_t>>(
        *lcm_, ch_frame_, status_,
        [this](const std::string&, const ptzstereo::stereo_frame_t& m) { onFrame(m); },
        Delivery::kNewest);
    status_.expectInput(ch_frame_);
  }

  int run() { return serveUntilStopped(*lcm_, status_); }

 private:
  void onPose(const ptzstereo::object_pose_t& m) {
    if (m.target_index >= 0 && m.target_index < static_cast<int32_t>(m.objects.size())) {
      const auto& o = m.objects[static_cast<size_t>(m.target_index)];
      if (!std::isfinite(o.position_m[0]) || !std::isfinite(o.position_m[1]) ||
          !std::isfinite(o.position_m[2])) {
        status_.countDropped(ch_pose_, "nonfinite");
        return;
      }
      target_head_m_ = Eigen::Vector3d(o.position_m[0], o.position_m[1], o.position_m[2]);
      target_utime_ = m.utime;
    }
    status_.countIn(ch_pose_, latencyMs(m.utime, wallUtime()));
  }

  void onFrame(const ptzstereo::stereo_frame_t& m) {
    const int64_t received = wallUtime();
    cv::Mat left, right;
    if (!intake_.accept(m, received) || !intake_.decode(m, &left, &right)) return;
    const auto t0 = std::chrono::steady_clock::now();
    std::optional<Eigen::Vector3d> target;
    const int64_t target_age_us = saturatingDiffUs(m.utime, target_utime_);
    if (target_head_m_ && target_age_us <= target_max_age_us_ &&
        target_age_us >= -target_max_age_us_) {
      target = target_head_m_;
    }
    std::string why;
    if (!estimator_.process(left, right, {m.left.pan_rad, m.left.tilt_rad, m.left.zoom},
                            {m.right.pan_rad, m.right.tilt_rad, m.right.zoom}, target, &depth_,
                            &why)) {
      intake_.drop(m.seq, "unknown_geometry", why);
      return;
    }
    cloud_maker_.make(depth_.points_head_m, depth_.colours_bgr, &cloud_);
    ptzstereo::point_cloud_t& cloud = cloud_;
    processing_ms_.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    // Counted in once it made a cloud: every frame is either in or dropped, never both.
    status_.countIn(ch_frame_, latencyMs(m.utime, received));
    cloud.utime = m.utime;
    cloud.frame_seq = m.seq;
    cloud.publish_utime = wallUtime();
    status_.publishOn(bulk_out_.lcm(), ch_cloud_, cloud, latencyMs(m.utime, cloud.publish_utime));
    if (publish_disparity_) publishDisparity(m);
    ++clouds_;
    status_.increment("frames_processed");
    status_.setCounter("points_per_cloud", cloud.width * cloud.height);
    status_.increment("points_published", cloud.width * cloud.height);
    status_.setCounter("outliers_dropped_per_frame", static_cast<int64_t>(depth_.outliers_dropped));
    status_.setCounter("min_disparity_px", depth_.min_disparity_px);
    status_.setCounter("rectification_rebuilds", estimator_.rectifier().rebuilds());
    if (target) status_.increment("frames_following_target");
    if (cloud_preview_schedule_.take(m.utime)) {
      ptzstereo::point_cloud_t preview = decimateCloud(cloud, cloud_preview_max_bytes_);
      status_.publish(ch_cloud_preview_, preview, latencyMs(m.utime, preview.publish_utime));
    }
    maybeWritePcd(cloud);
    status_.setPercentilesUs("processing", &processing_ms_, 10);
  }

  void publishDisparity(const ptzstereo::stereo_frame_t& m) {
    ptzstereo::image_t img =
        encodeImage(disparityGrey(depth_, estimator_.params().matcher.num_disparities),
                    ptzstereo::image_t::ENCODING_RAW, 0);
    img.pan_rad = m.left.pan_rad;
    img.tilt_rad = m.left.tilt_rad;
    img.zoom = m.left.zoom;
    status_.publishOn(bulk_out_.lcm(), ch_disparity_, img, latencyMs(m.utime, wallUtime()));
  }

  void maybeWritePcd(const ptzstereo::point_cloud_t& cloud) {
    const std::string path = pcdPathIfDue(pcd_path_, pcd_every_n_, clouds_, cloud.frame_seq);
    if (path.empty()) return;
    std::string error;
    if (writePcd(cloud, path, &error)) {
      status_.increment("pcd_written");
      return;
    }
    status_.increment("pcd_write_errors");
    status_.setState(ptzstereo::process_status_t::STATE_WARN, error);
    log_.warn("pcd", "ptz-depth: " + error);
  }

  lcm::LCM* lcm_;
  StatusReporter status_;
  FrameOutput bulk_out_;
  RateSchedule cloud_preview_schedule_;
  int64_t cloud_preview_max_bytes_;
  std::string ch_cloud_preview_;
  RateLimitedLog log_;
  DepthEstimator estimator_;
  CloudMaker cloud_maker_;
  ptzstereo::point_cloud_t cloud_;  // its buffers kept between frames
  int64_t target_max_age_us_;
  FrameIntake intake_;
  std::string pcd_path_;
  int pcd_every_n_;
  bool publish_disparity_;
  std::string ch_frame_, ch_pose_, ch_cloud_, ch_disparity_;
  std::optional<Eigen::Vector3d> target_head_m_;
  int64_t target_utime_ = 0;
  int64_t clouds_ = 0;
  DepthFrame depth_;
  std::vector<double> processing_ms_;
  std::unique_ptr<SafeSubscription<ptzstereo::object_pose_t>> poses_;
  std::unique_ptr<SafeSubscription<ptzstereo::stereo_frame_t>> frames_;
};

}  // namespace
}  // namespace ptz::perception

int main(int argc, char** argv) {
  using namespace ptz;
  Params params("ptz-depth",
                "Dense stereo: rectifies every STEREO_FRAME with its own PTZ geometry, block "
                "matching over a horopter that follows the OBJECT_POSE target, and publishes the "
                "scene as a coloured PCL cloud in the head frame on POINT_CLOUD.");
  perception::declare(params);
  return runProcess(argc, argv, params, [](const Params& p, lcm::LCM& lcm) {
    perception::DepthNode node(p, &lcm, rigFromParams(p));
    return node.run();
  });
}
