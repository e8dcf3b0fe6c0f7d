// ptz-detect: STEREO_FRAME -> OBJECT_DETECTIONS + OBJECT_POSE + OBJECT_TRACKS. Always the newest
// fresh frame (those waiting are drained, older ones dropped as superseded, late ones as stale);
// every output carries the source frame's utime and seq; bad frames are dropped, counted and warned
// about, never fatal. The tracker gives objects identities; the target is one track, locked until
// it is gone (TARGET_SELECT changes it); OBJECT_POSE's target_index is that track's object when a
// trusted measurement updated it in this frame.
#include <opencv2/imgproc.hpp>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <utility>

#include "common/freshness.hpp"
#include "common/transport/transport.hpp"
#include "perception/detect/detector.hpp"
#include "perception/detect/jpeg_window.hpp"
#include "perception/detect/orientation.hpp"
#include "perception/detect/pyramid.hpp"
#include "perception/detect/stereo.hpp"
#include "perception/detect/target.hpp"
#include "perception/detect/tracker.hpp"
#include "perception/detect/windows.hpp"
#include "ptzstereo/object_detections_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "ptzstereo/target_select_t.hpp"

namespace ptz::perception {
namespace {

void declare(Params& p) {
  addTransportParams(p);
  declareRigParams(p);
  p.add("target_class", "red_ball",
        "class of the object of interest until TARGET_SELECT says otherwise");
  p.add("filter_size_px", 3, "px", "median filter size (odd)", Range::between(1, 99));
  p.add("morph_size_px", 3, "px", "opening/closing kernel size", Range::between(1, 99));
  p.add("max_epipolar_px", 3.0, "px",
        "largest distance of a left/right match from its epipolar line", Range::above(0));
  p.add("max_area_ratio", 2.0, "", "largest left/right area ratio of a match", Range::atLeast(1));
  p.add("pixel_sigma_px", 0.3, "px", "centroid noise for the pose covariance", Range::above(0));
  p.add("min_range_m", 0.3, "m", "nearest accepted object", Range::above(0));
  p.add("max_range_m", 50.0, "m", "farthest accepted object", Range::above(0));
  p.addOrder("min_range_m", "max_range_m");
  p.add("orientation", true,
        "estimate the yaw of objects whose class is not round (boxes) from both views' outlines");
  p.add("orientation_height_ratio", OrientationParams{}.height_ratio, "",
        "orientation: the boxes' height over their footprint's side (0: fitted)",
        Range::between(0, 100));
  p.add("orientation_margin_px", 8, "px", "orientation: crop around a box's region",
        Range::between(1, 256));
  p.add("orientation_max_per_frame", 4, "",
        "orientation: boxes fitted per frame at most (the nearest the image centres first; the "
        "rest counted orientations_skipped)",
        Range::between(0, 64));
  addFreshnessParams(p, "frame", 500.0, "a STEREO_FRAME");
  addFreshnessParams(p, "select", 2000.0, "a TARGET_SELECT request");
  const TrackerParams t;
  p.add("track_yaw_psd_rad2_s", t.yaw_psd_rad2_s, "rad^2/s",
        "tracks: a box's yaw is a random walk of this power spectral density", Range::above(0));
  p.add("track_yaw_gate_chi2", t.yaw_gate_chi2, "",
        "tracks: a measured yaw beyond this innovation^2 / variance is refused (1 dof)",
        Range::above(0));
  p.add("track_jerk_psd_m2_s5", t.jerk_psd_m2_s5, "m^2/s^5",
        "tracks: spectral density of the objects' jerk (constant-acceleration model)",
        Range::above(0));
  p.add("track_gate_chi2", t.gate_chi2, "",
        "tracks: a measurement farther from a track's prediction (Mahalanobis^2) is not its",
        Range::above(0));
  p.add("track_min_position_sigma_m", t.min_position_sigma_m, "m",
        "tracks: noise added to every triangulated position", Range::atLeast(0));
  p.add("track_confirm_hits", t.confirm_hits, "", "tracks: measurements that confirm a track",
        Range::between(1, 1000));
  p.add("track_tentative_max_gap_s", t.tentative_max_gap_s, "s",
        "tracks: an unconfirmed track unseen this long is deleted", Range::above(0));
  p.add("track_coast_s", t.coast_s, "s",
        "tracks: a confirmed track unseen this long is deleted (it coasts until then)",
        Range::above(0));
  p.add("track_recover_speed_m_s", t.recover_speed_m_s, "m/s",
        "tracks: a measurement outside every gate but within this speed times the time since a "
        "coasting track's last update restarts that track (sharp turns; 0: off)",
        Range::atLeast(0));
  p.add("track_rank_sigma_cap_m", t.rank_sigma_cap_m, "m",
        "tracks: pairs rank by Mahalanobis^2 + ln det S, det S capped at this sigma per axis",
        Range::above(0));
  p.add("track_max_radius_ratio", t.max_radius_ratio, "",
        "tracks: a radius off the track's by more than this factor is not trusted as the centre",
        Range::above(1));
  p.add("trusted_area_ratio", 1.3, "",
        "left/right area ratio (zoom-corrected) beyond which an object is not trusted as a centre",
        Range::above(1));
  p.add("pick_radius_px", 15.0, "px",
        "TARGET_SELECT by image point: the largest distance from a track's image", Range::above(0));
  const WindowParams w;
  p.add("windows", w.enabled,
        "with a confirmed track, scan windows around each track's predicted image (and a band of "
        "the image a frame, or the whole frame every window_full_scan_every frames, for new "
        "objects) instead of whole frames");
  p.add("window_full_scan_every", w.full_scan_every, "frames",
        "windows: every n-th frame is scanned whole, for new objects (1: every frame); with "
        "window_full_scan_in_bands, the image is scanned in this many bands, one a frame",
        Range::between(1, 1000));
  p.add("window_full_scan_in_bands", w.full_scan_in_bands,
        "windows: look for new objects in one band of the image's rows a frame instead of the "
        "whole image every window_full_scan_every frames (no frame costs a whole scan)");
  p.add("window_band_overlap_fraction", w.band_overlap_fraction, "",
        "windows, bands: how far (a fraction of the image's height) each band reaches into its "
        "neighbours: the tallest object sure to be whole in a band, and the largest vertical "
        "disparity at which both images' band holds it",
        Range::between(0, 1));
  p.add("window_margin_px", w.margin_px, "px",
        "windows: added on each side of a track's projected extent", Range::between(0, 4096));
  p.add("window_sigma_scale", w.sigma_scale, "",
        "windows: a track's extent is its radius plus this many sigma of its predicted position",
        Range::between(0, 100));
  p.add("full_scan_max_width_px", w.full_scan_max_width_px, "px",
        "full scans of wider images find their objects on the image reduced by 2, 4 or 8 (to this "
        "width or less), then detect at full resolution only around them (0: off)",
        Range::between(0, 4096));
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

TrackerParams trackerParams(const Params& p) {
  TrackerParams t;
  t.jerk_psd_m2_s5 = p.getDouble("track_jerk_psd_m2_s5");
  t.gate_chi2 = p.getDouble("track_gate_chi2");
  t.min_position_sigma_m = p.getDouble("track_min_position_sigma_m");
  t.confirm_hits = p.getInt("track_confirm_hits");
  t.tentative_max_gap_s = p.getDouble("track_tentative_max_gap_s");
  t.coast_s = p.getDouble("track_coast_s");
  t.max_radius_ratio = p.getDouble("track_max_radius_ratio");
  t.recover_speed_m_s = p.getDouble("track_recover_speed_m_s");
  t.rank_sigma_cap_m = p.getDouble("track_rank_sigma_cap_m");
  t.yaw_psd_rad2_s = p.getDouble("track_yaw_psd_rad2_s");
  t.yaw_gate_chi2 = p.getDouble("track_yaw_gate_chi2");
  return t;
}

WindowParams windowParams(const Params& p) {
  WindowParams w;
  w.enabled = p.getBool("windows");
  w.full_scan_every = p.getInt("window_full_scan_every");
  w.full_scan_in_bands = p.getBool("window_full_scan_in_bands");
  w.band_overlap_fraction = p.getDouble("window_band_overlap_fraction");
  w.margin_px = p.getDouble("window_margin_px");
  w.sigma_scale = p.getDouble("window_sigma_scale");
  w.full_scan_max_width_px = p.getInt("full_scan_max_width_px");
  return w;
}

// The part `rect` of an image (checked by checkStereoFrame) as BGR: a JPEG's rows and columns
// of it alone; the whole image through decodeImage (the same pixels).
bool decodeRect(const ptzstereo::image_t& m, const cv::Rect& rect, cv::Mat* out, std::string* why) {
  const bool whole = rect == cv::Rect(0, 0, m.width, m.height);
  if (whole || m.encoding != ptzstereo::image_t::ENCODING_JPEG) {
    cv::Mat image;
    if (!decodeImage(m, &image, why)) return false;
    *out = whole ? image : image(rect);
    return true;
  }
  if (!decodeJpegWindow(m.data.data(), m.data.size(), m.width, m.height, rect, out, why))
    return false;
  if (m.pixel_format == ptzstereo::image_t::PIXEL_RGB8) cv::cvtColor(*out, *out, cv::COLOR_RGB2BGR);
  return true;
}

// The parts `rects` of an image (checked by checkStereoFrame) as BGR: a JPEG's rows and columns of
// them alone, in one pass; the whole image through decodeImage (the same pixels).
bool decodeParts(const ptzstereo::image_t& m, const std::vector<cv::Rect>& rects,
                 std::vector<cv::Mat>* parts, std::string* why) {
  if (rects.size() == 1) {
    parts->resize(1);
    return decodeRect(m, rects[0], &(*parts)[0], why);
  }
  if (m.encoding == ptzstereo::image_t::ENCODING_JPEG) {
    if (!decodeJpegWindows(m.data.data(), m.data.size(), m.width, m.height, rects, parts, why))
      return false;
    if (m.pixel_format == ptzstereo::image_t::PIXEL_RGB8) {
      for (auto& p : *parts) cv::cvtColor(p, p, cv::COLOR_RGB2BGR);
    }
    return true;
  }
  cv::Mat image;
  if (!decodeImage(m, &image, why)) return false;
  parts->clear();
  for (const auto& r : rects) parts->push_back(image(r));
  return true;
}

// Rows [row0, row1) of an image (checked by checkStereoFrame, colour by checkFrameMatchesRig)
// reduced by `scale` as BGR (DecodeReduced): a JPEG scaled in its decoder from those rows'
// restart segments, raw pixels area-averaged from the message's own bytes.
bool decodeReduced(const ptzstereo::image_t& m, int scale, int row0, int row1, cv::Mat* out,
                   std::string* why) {
  if (m.encoding == ptzstereo::image_t::ENCODING_JPEG) {
    if (!decodeJpegReducedRows(JpegRestartIndex(m.data.data(), m.data.size()), m.width, m.height,
                               scale, row0, row1, out, why)) {
      return false;
    }
  } else {
    if (row0 < 0 || row0 >= row1 || row1 > m.height || row0 % scale != 0) {
      *why = "rows outside the image";
      return false;
    }
    const cv::Mat view(m.height, m.width, CV_8UC3, const_cast<uint8_t*>(m.data.data()),
                       static_cast<size_t>(m.row_stride));
    cv::resize(
        view.rowRange(row0, row1), *out,
        {reducedSize({m.width, m.height}, scale).width, (row1 + scale - 1) / scale - row0 / scale},
        0, 0, cv::INTER_AREA);
  }
  if (m.pixel_format == ptzstereo::image_t::PIXEL_RGB8) cv::cvtColor(*out, *out, cv::COLOR_RGB2BGR);
  return true;
}

// One image of a frame: what WindowScanner::detect decoded of it at full resolution is kept, so
// that a box's view for its yaw is cut from it instead of decoded again (at 1080p a JPEG's second
// pass cost more than the rest of the frame). A part of a window is exactly its decode (the
// same pixels: jpeg_window.hpp).
class FramePixels {
 public:
  explicit FramePixels(const ptzstereo::image_t& m) : m_(m) {}

  // Both ways of reading the image, for WindowScanner::detect.
  ImagePixels pixels() {
    return {[this](const std::vector<cv::Rect>& r, std::vector<cv::Mat>* out, std::string* e) {
              if (!decodeParts(m_, r, out, e)) return false;
              for (size_t i = 0; i < r.size() && i < out->size(); ++i)
                decoded_.emplace_back(r[i], (*out)[i]);
              return true;
            },
            [this](int scale, int row0, int row1, cv::Mat* out, std::string* e) {
              return decodeReduced(m_, scale, row0, row1, out, e);
            }};
  }

  // The pixels of `rect`: from a part decoded already when one holds it (*reused), else decoded.
  bool crop(const cv::Rect& rect, cv::Mat* out, bool* reused, std::string* why) const {
    for (const auto& [r, part] : decoded_) {
      if ((r & rect) == rect && part.rows == r.height && part.cols == r.width) {
        *out = part(rect - r.tl());
        *reused = true;
        return true;
      }
    }
    *reused = false;
    return decodeRect(m_, rect, out, why);
  }

 private:
  const ptzstereo::image_t& m_;
  std::vector<std::pair<cv::Rect, cv::Mat>> decoded_;
};

std::vector<std::string> classNames(const DetectorParams& dp) {
  std::vector<std::string> names;
  for (const auto& c : dp.classes) names.push_back(c.name);
  return names;
}

void copyMatrix(const Eigen::Matrix3d& m, double* out) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out[r * 3 + c] = m(r, c);
  }
}

// Rotation head <- object of a yaw about the head's y axis, its variance the y-y entry.
void copyYaw(double yaw_rad, double var_rad2, double* wxyz, double* covariance) {
  const Eigen::Vector4d q = yawQuaternionWxyz(yaw_rad);
  for (int i = 0; i < 4; ++i) wxyz[i] = q[i];
  for (int i = 0; i < 9; ++i) covariance[i] = 0;
  covariance[4] = var_rad2;
}

ptzstereo::object_track_t toMessage(const Track& t, double now_s, double yaw_psd_rad2_s) {
  ptzstereo::object_track_t m{};
  m.id = t.id;
  m.class_name = t.class_name;
  m.state = t.state == TrackState::kTentative   ? ptzstereo::object_track_t::STATE_TENTATIVE
            : t.state == TrackState::kConfirmed ? ptzstereo::object_track_t::STATE_CONFIRMED
                                                : ptzstereo::object_track_t::STATE_COASTING;
  for (int i = 0; i < 3; ++i) {
    m.position_m[i] = t.position()[i];
    m.velocity_m_s[i] = t.velocity()[i];
    m.acceleration_m_s2[i] = t.acceleration()[i];
  }
  copyMatrix(t.positionCovariance(), m.position_covariance_m2);
  copyMatrix(t.velocityCovariance(), m.velocity_covariance_m2_s2);
  m.radius_m = t.radius_m;
  m.age_s = now_s - t.first_s;
  m.since_update_s = now_s - t.last_update_s;
  m.object_index = t.object_index;
  m.untrusted_updates = t.untrusted_updates;
  m.has_orientation = t.has_yaw;
  m.orientation_wxyz[0] = 1;
  if (t.has_yaw) {
    copyYaw(t.yaw_rad, t.yawVarianceAt(now_s, yaw_psd_rad2_s), m.orientation_wxyz,
            m.orientation_covariance_rad2);
  }
  return m;
}

class DetectNode {
 public:
  DetectNode(const Params& p, lcm::LCM* lcm, StereoRig rig, DetectorParams dp)
      : lcm_(lcm),
        status_(lcm, p, "ptz-detect"),
        rig_(std::move(rig)),
        rig_file_(p.getPath("rig_file")),
        detector_(std::move(dp)),
        target_class_(p.getString("target_class")),
        frame_freshness_(freshnessFrom(p, "frame")),
        ch_frame_(channel(p, channels::kStereoFrame)),
        ch_detections_(channel(p, channels::kObjectDetections)),
        ch_pose_(channel(p, channels::kObjectPose)),
        ch_tracks_(channel(p, channels::kObjectTracks)),
        ch_select_(channel(p, channels::kTargetSelect)),
        select_freshness_(freshnessFrom(p, "select")),
        tracker_(trackerParams(p)),
        class_names_(classNames(detector_.params())),
        selector_(target_class_, class_names_, p.getDouble("pick_radius_px")),
        trusted_area_ratio_(p.getDouble("trusted_area_ratio")),
        windows_(windowParams(p), {rig_.left.width, rig_.left.height}, detector_.exactMarginPx()) {
    stereo_.max_epipolar_px = p.getDouble("max_epipolar_px");
    stereo_.max_area_ratio = p.getDouble("max_area_ratio");
    stereo_.pixel_sigma_px = p.getDouble("pixel_sigma_px");
    stereo_.min_range_m = p.getDouble("min_range_m");
    stereo_.max_range_m = p.getDouble("max_range_m");
    orientation_ = p.getBool("orientation");
    orientation_params_.height_ratio = p.getDouble("orientation_height_ratio");
    orientation_margin_px_ = p.getInt("orientation_margin_px");
    orientation_max_per_frame_ = p.getInt("orientation_max_per_frame");
    // Always the newest frame, never a backlog.
    frames_ = std::make_unique<SafeSubscription<ptzstereo::stereo_frame_t>>(
        *lcm_, ch_frame_, status_,
        [this](const std::string&, const ptzstereo::stereo_frame_t& m) { onFrame(&m); },
        Delivery::kNewest);
    selects_ = std::make_unique<SafeSubscription<ptzstereo::target_select_t>>(
        *lcm_, ch_select_, status_,
        [this](const std::string&, const ptzstereo::target_select_t& m) { onSelect(m); });
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
    if (!acceptable(*m)) return;
    const CameraView lv = rig_.view(Side::kLeft, {m->left.pan_rad, m->left.tilt_rad, m->left.zoom});
    const CameraView rv =
        rig_.view(Side::kRight, {m->right.pan_rad, m->right.tilt_rad, m->right.zoom});
    const double t_s = m->utime * 1e-6;
    const auto t0 = std::chrono::steady_clock::now();
    // Windows around the tracks' predicted images, or the whole frames; decoding only what is
    // scanned. Left and right on two cores (Detector is const and shares nothing mutable).
    ScanPlan plan = windows_.plan(tracker_.tracks(), t_s, lv, rv);
    std::vector<Region> lr, rr;
    std::string why;
    FramePixels left_pixels(m->left), right_pixels(m->right);
    const bool decoded = windows_.detect(detector_, &plan, left_pixels.pixels(),
                                         right_pixels.pixels(), &lr, &rr, &why);
    if (!decoded) {
      drop("bad_image", "frame " + std::to_string(m->seq) + ": " + why);
      return;
    }
    // Counted in once accepted: every message is either in or dropped, never both.
    status_.countIn(ch_frame_, latencyMs(m->utime, received));
    const std::vector<StereoObject> objects = associate(lr, rr, lv, rv, stereo_);
    std::vector<TrackMeasurement> measurements = trackMeasurements(
        objects, lr, rr, lv, rv, class_names_, trusted_area_ratio_, tracker_.tracks(), t_s);
    const std::vector<BoxYaw> yaws =
        estimateYaws(*m, {&left_pixels, &right_pixels}, objects, measurements, lr, rr, lv, rv);
    for (TrackMeasurement& tm : measurements) {
      if (tm.object_index < 0 || static_cast<size_t>(tm.object_index) >= yaws.size()) continue;
      const BoxYaw& y = yaws[static_cast<size_t>(tm.object_index)];
      tm.has_yaw = y.ok;
      tm.yaw_rad = y.yaw_rad;
      tm.yaw_var_rad2 = y.variance_rad2;
    }
    tracker_.update(t_s, measurements);
    const int64_t target_id = chooseTarget(t_s);
    last_views_ = {lv, rv};
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
      obj.radius_m = objectRadiusM(lr[static_cast<size_t>(o.left)], o.position_head_m, lv);
      const BoxYaw& yaw = yaws[pose.objects.size()];
      obj.has_orientation = yaw.ok;
      obj.orientation_wxyz[0] = 1;
      if (yaw.ok) {
        copyYaw(yaw.yaw_rad, yaw.variance_rad2, obj.orientation_wxyz,
                obj.orientation_covariance_rad2);
      }
      pose.objects.push_back(obj);
    }
    pose.num_objects = static_cast<int32_t>(pose.objects.size());
    // The target's object: the measurement that updated the locked track in this frame.
    if (const Track* target = tracker_.find(target_id)) pose.target_index = target->object_index;

    ptzstereo::object_tracks_t tracks{};
    tracks.utime = m->utime;
    tracks.frame_seq = m->seq;
    tracks.left_ptz = pose.left_ptz;
    tracks.right_ptz = pose.right_ptz;
    tracks.target_id = target_id;
    tracks.target_reason = selector_.reason();
    for (const auto& t : tracker_.tracks()) {
      tracks.tracks.push_back(toMessage(t, t_s, tracker_.params().yaw_psd_rad2_s));
    }
    tracks.num_tracks = static_cast<int32_t>(tracks.tracks.size());
    // ptz-control's input first: the chain does not wait for the other two to be encoded and sent.
    tracks.publish_utime = wallUtime();
    status_.publish(ch_tracks_, tracks, latencyMs(m->utime, tracks.publish_utime));
    pose.publish_utime = wallUtime();
    status_.publish(ch_pose_, pose, latencyMs(m->utime, pose.publish_utime));
    det.publish_utime = wallUtime();
    status_.publish(ch_detections_, det, latencyMs(m->utime, det.publish_utime));
    status_.setCounter("tracks_live", static_cast<int64_t>(tracker_.tracks().size()));
    status_.setCounter("tracks_started", tracker_.tracksStarted());
    status_.setCounter("tracks_recovered", tracker_.recoveries());
    status_.setCounter("track_yaws_accepted", tracker_.yawsAccepted());
    status_.setCounter("track_yaws_refused", tracker_.yawsRefused());
    status_.setCounter("tracks_refused", tracker_.tracksRefused());
    status_.setCounter("target_id", target_id);
    for (const auto& [reason, n] : tracker_.untrustedCounts())
      status_.setCounter("untrusted_" + reason, n);
    for (const auto& [name, n] : windows_.counts()) status_.setCounter(name, n);
    status_.increment("frames_processed");
    if (pose.target_index < 0) status_.increment("frames_without_target");
    if (processing_ms_.size() >= 30) {
      status_.setCounter("processing_us_p50",
                         static_cast<int64_t>(percentile(processing_ms_, 50) * 1000));
      status_.setCounter("processing_us_p99",
                         static_cast<int64_t>(percentile(processing_ms_, 99) * 1000));
      processing_ms_.clear();
    }
    if (orientation_us_.size() >= 30) {
      status_.setCounter("orientation_us_p50",
                         static_cast<int64_t>(percentile(orientation_us_, 50)));
      status_.setCounter("orientation_us_p99",
                         static_cast<int64_t>(percentile(orientation_us_, 99)));
      orientation_us_.clear();
    }
  }

  // The yaw of each object whose class has an orientation (boxes), by object; not ok for the
  // others, a region an image border cuts, or a view that does not decode.
  // The yaws of the trusted boxes (a cut, merged or half-hidden region gives none), at most
  // orientation_max_per_frame of them, nearest the left image's centre first.
  std::vector<BoxYaw> estimateYaws(const ptzstereo::stereo_frame_t& m,
                                   const std::array<const FramePixels*, 2>& pixels,
                                   const std::vector<StereoObject>& objects,
                                   const std::vector<TrackMeasurement>& measurements,
                                   const std::vector<Region>& lr, const std::vector<Region>& rr,
                                   const CameraView& lv, const CameraView& rv) {
    std::vector<BoxYaw> yaws(objects.size());
    if (!orientation_) return yaws;
    std::vector<bool> trusted(objects.size());
    for (const TrackMeasurement& tm : measurements) {
      if (tm.object_index >= 0 && static_cast<size_t>(tm.object_index) < objects.size()) {
        trusted[static_cast<size_t>(tm.object_index)] = tm.untrusted.empty();
      }
    }
    std::vector<std::pair<double, size_t>> boxes;  // distance from the image centre, index
    for (size_t i = 0; i < objects.size(); ++i) {
      const size_t ci = static_cast<size_t>(objects[i].class_index);
      if (!trusted[i] || !classHasOrientation(detector_.params().classes[ci])) continue;
      const cv::Point2d c = lr[static_cast<size_t>(objects[i].left)].centroid_px;
      boxes.emplace_back(std::hypot(c.x - m.left.width / 2.0, c.y - m.left.height / 2.0), i);
    }
    std::sort(boxes.begin(), boxes.end());
    const size_t most = static_cast<size_t>(orientation_max_per_frame_);
    if (boxes.size() > most) {
      status_.increment("orientations_skipped", static_cast<int64_t>(boxes.size() - most));
      boxes.resize(most);
    }
    for (const auto& [distance_px, i] : boxes) {
      const StereoObject& o = objects[i];
      const size_t ci = static_cast<size_t>(o.class_index);
      const Region& l = lr[static_cast<size_t>(o.left)];
      const Region& r = rr[static_cast<size_t>(o.right)];
      const cv::Size lsize(m.left.width, m.left.height), rsize(m.right.width, m.right.height);
      const auto t0 = std::chrono::steady_clock::now();
      cv::Mat lcrop, rcrop;
      std::string why;
      // Enough margin that the crop's pixels are the full scan's (the detector's filters).
      const int margin_px = std::max(orientation_margin_px_, detector_.exactMarginPx());
      const cv::Rect lc = boxCrop(l.bbox, lsize, margin_px);
      const cv::Rect rc = boxCrop(r.bbox, rsize, margin_px);
      bool lreused = false, rreused = false;
      if (regionCut(l.bbox, lsize) || regionCut(r.bbox, rsize) ||
          !pixels[0]->crop(lc, &lcrop, &lreused, &why) ||
          !pixels[1]->crop(rc, &rcrop, &rreused, &why)) {
        status_.increment("orientations_failed");
        continue;
      }
      status_.increment("orientation_views_decoded", (lreused ? 0 : 1) + (rreused ? 0 : 1));
      yaws[i] = estimateBoxYaw(makeBoxView(detector_, ci, lcrop, lc.tl(), l.bbox, lv),
                               makeBoxView(detector_, ci, rcrop, rc.tl(), r.bbox, rv),
                               o.position_head_m, orientation_params_);
      orientation_us_.push_back(
          std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
      status_.increment(yaws[i].ok ? "orientations_estimated" : "orientations_failed");
    }
    return yaws;
  }

  // The selector's choice after this frame's tracker update; a new choice is said on stderr.
  int64_t chooseTarget(double t_s) {
    const int64_t before = selector_.targetId();
    const std::string reason_before = selector_.reason();
    const int64_t id = selector_.choose(t_s, tracker_.tracks());
    if (id != before) status_.increment("target_changes");
    if (selector_.reason() != reason_before) {
      std::fprintf(stderr, "ptz-detect: target: %s\n", selector_.reason().c_str());
    }
    return id;
  }

  void refuseSelect(const std::string& why) {
    status_.countDropped(ch_select_, "refused");
    log_.warn("select",
              "ptz-detect: TARGET_SELECT refused: " + why + "; the target stays " +
                  (selector_.targetId() >= 0 ? "track " + std::to_string(selector_.targetId())
                                             : std::string("none")));
  }

  void onSelect(const ptzstereo::target_select_t& m) {
    const int64_t received = wallUtime();
    const Freshness fresh =
        judgeFreshness(m.utime, m.publish_utime, received, select_freshness_, true);
    if (fresh != Freshness::kFresh) {
      status_.countDropped(ch_select_, freshnessReason(fresh));
      log_.warn("select",
                std::string("ptz-detect: dropped a ") + freshnessReason(fresh) + " TARGET_SELECT");
      return;
    }
    TargetRequest r;
    switch (m.mode) {
      case ptzstereo::target_select_t::MODE_CLASS:
        r.mode = TargetRequest::Mode::kClass;
        r.class_name = m.class_name;
        break;
      case ptzstereo::target_select_t::MODE_TRACK_ID:
        r.mode = TargetRequest::Mode::kTrackId;
        r.track_id = m.track_id;
        break;
      case ptzstereo::target_select_t::MODE_IMAGE_POINT:
        if (m.camera != ptzstereo::target_select_t::CAMERA_LEFT &&
            m.camera != ptzstereo::target_select_t::CAMERA_RIGHT) {
          return refuseSelect("camera " + std::to_string(m.camera) + " is neither 0 nor 1");
        }
        if (!last_views_) return refuseSelect("no frame seen yet");
        r.mode = TargetRequest::Mode::kImagePoint;
        r.camera = m.camera == ptzstereo::target_select_t::CAMERA_LEFT ? Side::kLeft : Side::kRight;
        r.pixel = {m.x_px, m.y_px};
        break;
      default:
        return refuseSelect("mode " + std::to_string(m.mode) + " is none of 0, 1, 2");
    }
    std::string why;
    const CameraView none;
    const bool ok = selector_.request(r, tracker_.tracks(), last_views_ ? last_views_->first : none,
                                      last_views_ ? last_views_->second : none, &why);
    if (!ok) return refuseSelect(why);
    status_.countIn(ch_select_, latencyMs(m.utime, received));
    log_.warn("selected", "ptz-detect: target: " + selector_.reason());
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
  std::string ch_frame_, ch_detections_, ch_pose_, ch_tracks_, ch_select_;
  FreshnessLimits select_freshness_;
  Tracker tracker_;
  std::vector<std::string> class_names_;  // the detector's, by class index
  TargetSelector selector_;
  double trusted_area_ratio_;
  std::optional<std::pair<CameraView, CameraView>> last_views_;  // of the newest frame
  WindowScanner windows_;
  std::vector<double> processing_ms_;
  bool orientation_;
  OrientationParams orientation_params_;
  int orientation_margin_px_;
  int orientation_max_per_frame_;
  std::vector<double> orientation_us_;
  std::unique_ptr<SafeSubscription<ptzstereo::stereo_frame_t>> frames_;
  std::unique_ptr<SafeSubscription<ptzstereo::target_select_t>> selects_;
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
