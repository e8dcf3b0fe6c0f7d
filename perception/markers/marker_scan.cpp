#include "perception/markers/marker_scan.hpp"

#include <opencv2/core/utility.hpp>

#include <algorithm>
#include <cmath>

namespace ptz::perception {
namespace {

// libapriltag finds quads on the image reduced by 2: a part starting on even pixels keeps that
// grid, so a tag's corners do not move with the part.
cv::Rect evenCut(const cv::Rect& r, const cv::Size& image) {
  cv::Rect e(r.x & ~1, r.y & ~1, r.width + (r.x & 1), r.height + (r.y & 1));
  return e & cv::Rect(0, 0, image.width, image.height);
}

}  // namespace

MarkerScanner::MarkerScanner(std::vector<MarkerClass> classes, MarkerScanParams params,
                             cv::Size image)
    : classes_(std::move(classes)), p_(params), size_(image) {
  if (classes_.empty()) return;
  for (auto& d : detectors_) d = std::make_unique<MarkerDetector>(classes_, p_.detector);
}

bool MarkerScanner::isMarkerObject(const std::string& class_name) const {
  const std::string prefix = class_name.substr(0, class_name.find('#'));
  for (const auto& c : classes_) {
    if (c.name == prefix) return true;
  }
  return false;
}

bool MarkerScanner::scan(const std::vector<Track>& tracks, double t_s, const CameraView& left,
                         const CameraView& right, const WindowParams& windows,
                         const CropPixels crop[2], MarkerScan* out, std::string* why) {
  *out = {};
  if (!enabled()) return true;
  const CameraView* views[2] = {&left, &right};
  std::vector<cv::Rect> rects[2];
  for (const Track& t : tracks) {
    if (!isMarkerObject(t.class_name)) continue;
    for (int s = 0; s < 2; ++s) {
      cv::Rect r;
      if (trackWindow(*views[s], t, t_s, windows, &r)) {
        r = evenCut(r, size_);
        if (!r.empty()) rects[s].push_back(r);
      }
    }
  }
  for (auto& r : rects) r = mergeRects(r);
  const int n = std::max(1, p_.bands);
  const int k = next_band_;
  next_band_ = (next_band_ + 1) % n;
  const int overlap = static_cast<int>(std::ceil(p_.band_overlap_fraction * size_.height));
  const int row0 = std::max(0, k * size_.height / n - overlap);
  const int row1 = std::min(size_.height, (k + 1) * size_.height / n + overlap);
  const cv::Rect band = evenCut(cv::Rect(0, row0, size_.width, row1 - row0), size_);
  ++counts_["marker_bands_scanned"];
  counts_["marker_windows"] += static_cast<int64_t>(rects[0].size() + rects[1].size());

  std::string whys[2];
  bool ok[2] = {true, true};
  int unclaimed[2] = {0, 0};
  cv::parallel_for_(cv::Range(0, 2), [&](const cv::Range& range) {
    for (int s = range.start; s < range.end; ++s) {
      MarkerDetector& d = *detectors_[s];
      std::vector<MarkerSighting>& seen = out->sightings[s];
      for (const cv::Rect& r : rects[s]) {
        cv::Mat pixels;
        if (!crop[s](r, &pixels, &whys[s])) {
          ok[s] = false;
          return;
        }
        for (const auto& m : d.detect(pixels, r.tl(), &unclaimed[s], 1)) seen.push_back(m);
      }
      cv::Mat pixels;
      if (!crop[s](band, &pixels, &whys[s])) {
        ok[s] = false;
        return;
      }
      for (const auto& m : d.detect(pixels, band.tl(), &unclaimed[s], p_.band_decimate)) {
        // Found in a window already (the window's is at full resolution).
        const bool twice = std::any_of(seen.begin(), seen.end(), [&](const MarkerSighting& w) {
          return w.class_index == m.class_index && w.id == m.id &&
                 cv::norm(w.centre_px - m.centre_px) < 3;
        });
        if (!twice) seen.push_back(m);
      }
    }
  });
  for (int s = 0; s < 2; ++s) {
    if (!ok[s]) {
      *why = std::string(sideName(s == 0 ? Side::kLeft : Side::kRight)) + ": " + whys[s];
      return false;
    }
  }
  counts_["marker_ids_unclaimed"] += unclaimed[0] + unclaimed[1];
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
