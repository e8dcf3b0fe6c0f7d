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

}  // namespace

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
    if (c < 0 || !windows_too) continue;
    for (int s = 0; s < 2; ++s) {
      cv::Rect r;
      if (!trackWindow(*views[s], t, t_s, windows, &r)) continue;
      r = evenCut(r, size_);
      if (!r.empty()) of_class[s][static_cast<size_t>(c)].push_back(r);
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
    band = evenCut(cv::Rect(0, row0, size_.width, row1 - row0), size_);
    ++counts_["marker_bands_scanned"];
  }
  counts_["marker_windows"] += static_cast<int64_t>(rects[0].size() + rects[1].size());

  std::string whys[2];
  bool ok[2] = {true, true};
  int unclaimed[2] = {0, 0}, cut[2] = {0, 0};
  cv::parallel_for_(cv::Range(0, 2), [&](const cv::Range& range) {
    for (int s = range.start; s < range.end; ++s) {
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
      if (band.empty()) continue;
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
