#include "perception/markers/marker_scan.hpp"

#include <algorithm>
#include <cmath>

namespace ptz::perception {
namespace {

// Both detectors threshold by tiles of 4 px (libapriltag's, and ArUco's port of it; libapriltag
// at a decimation of 2 on the image halved): a part starting on the whole image's grid of 8 px
// keeps those tiles, so a tag's corners do not move with the part (they moved by up to 0.4 px).
cv::Rect gridCut(const cv::Rect& r, const cv::Size& image) {
  const int x = r.x & ~7, y = r.y & ~7;
  const cv::Rect e(x, y, r.width + (r.x - x), r.height + (r.y - y));
  return e & cv::Rect(0, 0, image.width, image.height);
}

// Whether a tag lies inside the part it was found in, 2 px clear of the part's edges where they are
// not the image's: a tag the edge cuts is still read, its lost corner guessed from its edges.
bool whole(const MarkerSighting& m, const cv::Rect& part, const cv::Size& image) {
  constexpr double kClearPx = 2;
  for (const auto& c : m.corners_px) {
    if ((part.x > 0 && c.x < part.x + kClearPx) || (part.y > 0 && c.y < part.y + kClearPx) ||
        (part.br().x < image.width && c.x > part.br().x - 1 - kClearPx) ||
        (part.br().y < image.height && c.y > part.br().y - 1 - kClearPx)) {
      return false;
    }
  }
  return true;
}

// The ids of a tagged track's tags: a bundle's all, a single tag's from its name ("aruco#5").
std::vector<int> tagIds(const MarkerClass& c, const std::string& track_name) {
  std::vector<int> ids;
  if (c.isBundle()) {
    for (const MarkerTag& t : c.bundle) ids.push_back(t.id);
    return ids;
  }
  const size_t hash = track_name.find('#');
  if (hash == std::string::npos) return ids;
  try {
    ids.push_back(std::stoi(track_name.substr(hash + 1)));
  } catch (const std::exception&) {
  }
  return ids;
}

}  // namespace

bool MarkerScanner::tagWindows(const CameraView& view, const Track& t, const MarkerClass& c,
                               double t_s, const WindowParams& windows,
                               std::vector<cv::Rect>* out) const {
  out->clear();
  if (!t.rotation.ok || t_s - t.rotation.t_s > RotationEstimate::kMaxExtrapolationS) return false;
  const Eigen::Matrix3d R = t.rotation.rotationAt(t_s).toRotationMatrix();
  const Eigen::Matrix3d cov_rot = t.rotation.covarianceAt(t_s, p_.rotation);
  const double sigma_rot = std::sqrt(std::max(0.0, cov_rot.diagonal().maxCoeff()));
  const Eigen::Matrix3d cam_head = view.rotation_head_camera.transpose();
  const Eigen::Matrix3d cov_pos = cam_head * t.positionCovarianceAt(t_s) * cam_head.transpose();
  const double sigma_pos = std::sqrt(std::max(0.0, std::max(cov_pos(0, 0), cov_pos(1, 1))));
  const Eigen::Vector3d origin = t.positionAt(t_s);
  const double k = windows.sigma_scale, fx = view.intrinsics.fx;
  for (int id : tagIds(c, t.class_name)) {
    const std::vector<Eigen::Vector3d> corners = c.corners(id);
    if (corners.size() != 4) continue;
    Eigen::Vector3d cam[4];
    double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY, pad = 0;
    bool in_front = true;
    for (size_t i = 0; i < 4 && in_front; ++i) {
      cam[i] = view.toCamera(origin + R * corners[i]);
      in_front = cam[i].allFinite() && cam[i].z() > 0.05;
      if (!in_front) break;
      const Eigen::Vector2d px = view.projectCamera(cam[i]);
      if (!px.allFinite()) in_front = false;
      x0 = std::min(x0, px.x()), x1 = std::max(x1, px.x());
      y0 = std::min(y0, px.y()), y1 = std::max(y1, px.y());
      pad = std::max(pad, k * (sigma_pos + sigma_rot * corners[i].norm()) * fx / cam[i].z());
    }
    if (!in_front) continue;
    // Facing the camera (z into the tag, away from the camera), within the rotation's k sigma.
    const Eigen::Vector3d normal = (cam[1] - cam[0]).cross(cam[3] - cam[0]).normalized();
    const Eigen::Vector3d centre = (cam[0] + cam[2]) / 2;
    if (normal.dot(centre.normalized()) < kMinFacingCos - k * sigma_rot) continue;
    // The tag's white border and the detector's edge of clear pixels (whole()).
    pad += 0.25 * std::max(x1 - x0, y1 - y0) + 4;
    const cv::Rect r(
        cv::Point(static_cast<int>(std::floor(x0 - pad)), static_cast<int>(std::floor(y0 - pad))),
        cv::Point(static_cast<int>(std::ceil(x1 + pad)) + 1,
                  static_cast<int>(std::ceil(y1 + pad)) + 1));
    const cv::Rect cut = r & cv::Rect(0, 0, size_.width, size_.height);
    if (!cut.empty()) out->push_back(cut);
  }
  return !out->empty();  // none: the whole object's window (the orientation may be wrong)
}

bool MarkerScanner::lost(const CameraView& view, const Track& t, double t_s,
                         const WindowParams& windows) const {
  // A new track's speed is not known yet (its window is wide for it): only one that coasts is lost.
  if (t.state != TrackState::kCoasting) return false;
  WindowParams bare = windows;
  bare.margin_px = 0;
  cv::Rect window, object;
  return trackWindow(view, t, t_s, bare, &window) &&
         projectSphere(view, t.positionAt(t_s), t.radius_m, 0, &object) &&
         window.area() > p_.window_max_object_areas * std::max(1, object.area());
}

MarkerScanner::MarkerScanner(std::vector<MarkerClass> classes, MarkerScanParams params,
                             cv::Size image)
    : classes_(std::move(classes)), p_(params), size_(image) {
  if (classes_.empty()) return;
  for (auto& d : detectors_) d = std::make_unique<MarkerDetector>(classes_, p_.detector);
}

bool MarkerScanner::isMarkerObject(const std::string& class_name) const {
  return classOf(class_name) >= 0;
}

int MarkerScanner::classOf(const std::string& class_name) const {
  const std::string prefix = class_name.substr(0, class_name.find('#'));
  for (size_t i = 0; i < classes_.size(); ++i) {
    if (classes_[i].name == prefix) return static_cast<int>(i);
  }
  return -1;
}

bool MarkerScanner::scan(const std::vector<Track>& tracks, double t_s, const CameraView& left,
                         const CameraView& right, const WindowParams& windows,
                         const CropPixels crop[2], MarkerScan* out, std::string* why,
                         ScanParts parts) {
  *out = {};
  if (!enabled()) return true;
  const bool windows_too = parts != ScanParts::kNew, band_too = parts != ScanParts::kWindows;
  const CameraView* views[2] = {&left, &right};
  // Windows by class (a tracked tag is looked for by its own detector alone: ArUco costs 6-8
  // times libapriltag), merged within a class.
  std::vector<std::vector<cv::Rect>> of_class[2];
  for (auto& side : of_class) side.resize(classes_.size());
  for (const Track& t : tracks) {
    const int c = classOf(t.class_name);
    if (c < 0) continue;
    // A lost track's windows (mostly its uncertainty, in either view: a pose needs both) are
    // searched with the band, after the frame's messages: their cost is a new object's.
    const bool is_lost = lost(left, t, t_s, windows) || lost(right, t, t_s, windows);
    if (is_lost ? !band_too : !windows_too) continue;
    for (int s = 0; s < 2; ++s) {
      cv::Rect r;
      if (!trackWindow(*views[s], t, t_s, windows, &r)) continue;
      if (is_lost) ++counts_["marker_windows_lost"];
      // Around the tags that face the camera where the track's orientation is known, else around
      // the whole object.
      std::vector<cv::Rect> tags;
      if (is_lost ||
          !tagWindows(*views[s], t, classes_[static_cast<size_t>(c)], t_s, windows, &tags)) {
        tags = {r};
      } else {
        ++counts_["marker_tag_windows"];
      }
      for (cv::Rect& w : tags) {
        w = gridCut(w, size_);
        if (!w.empty()) of_class[s][static_cast<size_t>(c)].push_back(w);
      }
    }
  }
  // A window as large as much of the image (a track long unseen) is left to the band: a window is
  // searched at full resolution, a band reduced.
  std::vector<std::pair<int, cv::Rect>> rects[2];
  const double image_area = static_cast<double>(size_.area());
  for (int s = 0; s < 2; ++s) {
    for (size_t c = 0; c < classes_.size(); ++c) {
      for (const cv::Rect& r : mergeRects(of_class[s][c])) {
        if (r.area() > windows.max_cover_fraction * image_area) {
          ++counts_["marker_windows_left_to_bands"];
        } else {
          rects[s].emplace_back(static_cast<int>(c), r);
        }
      }
    }
  }
  cv::Rect band;
  if (band_too) {
    const int n = std::max(1, p_.bands);
    const int k = next_band_;
    next_band_ = (next_band_ + 1) % n;
    const int overlap = static_cast<int>(std::ceil(p_.band_overlap_fraction * size_.height));
    const int row0 = std::max(0, k * size_.height / n - overlap);
    const int row1 = std::min(size_.height, (k + 1) * size_.height / n + overlap);
    band = gridCut(cv::Rect(0, row0, size_.width, row1 - row0), size_);
    ++counts_["marker_bands_scanned"];
  }
  counts_["marker_windows"] += static_cast<int64_t>(rects[0].size() + rects[1].size());

  std::string whys[2];
  bool ok[2] = {true, true};
  int unclaimed[2] = {0, 0}, cut[2] = {0, 0};
  forBothCameras([&](int s) {
    MarkerDetector& d = *detectors_[s];
    std::vector<MarkerSighting>& seen = out->sightings[s];
    for (const auto& [c, r] : rects[s]) {
      cv::Mat pixels;
      if (!crop[s](r, &pixels, &whys[s])) {
        ok[s] = false;
        return;
      }
      for (const auto& m : d.detect(pixels, r.tl(), &unclaimed[s], 1, c)) {
        if (whole(m, r, size_)) {
          seen.push_back(m);
        } else {
          ++cut[s];
        }
      }
    }
    if (band.empty()) return;
    cv::Mat pixels;
    if (!crop[s](band, &pixels, &whys[s])) {
      ok[s] = false;
      return;
    }
    for (const auto& m : d.detect(pixels, band.tl(), &unclaimed[s], p_.band_decimate)) {
      if (!whole(m, band, size_)) {  // whole in the next band (bands overlap)
        ++cut[s];
        continue;
      }
      // Found in a window already (the window's is at full resolution).
      const bool twice = std::any_of(seen.begin(), seen.end(), [&](const MarkerSighting& w) {
        return w.class_index == m.class_index && w.id == m.id &&
               cv::norm(w.centre_px - m.centre_px) < 3;
      });
      if (!twice) seen.push_back(m);
    }
  });
  for (int s = 0; s < 2; ++s) {
    if (!ok[s]) {
      *why = std::string(sideName(s == 0 ? Side::kLeft : Side::kRight)) + ": " + whys[s];
      return false;
    }
  }
  counts_["marker_ids_unclaimed"] += unclaimed[0] + unclaimed[1];
  counts_["marker_cut_by_part"] += cut[0] + cut[1];
  counts_["marker_refused_hamming"] =
      detectors_[0]->refusedHamming() + detectors_[1]->refusedHamming();
  counts_["marker_refused_margin"] =
      detectors_[0]->refusedMargin() + detectors_[1]->refusedMargin();
  counts_["marker_refused_small"] = detectors_[0]->refusedSmall() + detectors_[1]->refusedSmall();
  // Bounded work a frame: a sheet of tags in view makes no more objects than this.
  for (auto& seen : out->sightings) {
    if (seen.size() > kMaxSightings) {
      counts_["marker_sightings_capped"] += static_cast<int64_t>(seen.size() - kMaxSightings);
      seen.resize(kMaxSightings);
    }
  }
  counts_["marker_sightings"] +=
      static_cast<int64_t>(out->sightings[0].size() + out->sightings[1].size());
  std::vector<std::string> failed;
  out->objects =
      markerObjects(classes_, out->sightings[0], out->sightings[1], left, right, p_.pose, &failed);
  for (const auto& f : failed) ++counts_["marker_pose_failed_" + f];
  counts_["marker_objects"] += static_cast<int64_t>(out->objects.size());
  return true;
}

}  // namespace ptz::perception
