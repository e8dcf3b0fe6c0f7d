#include "perception/detection/windows.hpp"

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>

#include "perception/detection/pyramid.hpp"

namespace ptz::perception {
namespace {

// The second camera's thread of one calling thread.
class Lane {
 public:
  Lane() : thread_([this] { loop(); }) {}
  ~Lane() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    thread_.join();
  }
  void start(const std::function<void(int)>* fn) {
    std::lock_guard<std::mutex> lock(mutex_);
    job_ = fn, error_ = nullptr;
    wake_.notify_all();
  }
  std::exception_ptr wait() {
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return job_ == nullptr; });
    return error_;
  }

 private:
  void loop();

  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(int)>* job_ = nullptr;
  std::exception_ptr error_;
  bool stop_ = false;
  std::thread thread_;  // last: it starts on the members above
};

thread_local bool in_both = false;  // inside forBothCameras: a nested call runs in turn

void Lane::loop() {
  in_both = true;
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    wake_.wait(lock, [this] { return stop_ || job_ != nullptr; });
    if (stop_) return;
    const std::function<void(int)>* fn = job_;
    lock.unlock();
    std::exception_ptr error;
    try {
      (*fn)(1);
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    error_ = error, job_ = nullptr;
    done_.notify_all();
  }
}

}  // namespace

void forBothCameras(const std::function<void(int side)>& fn) {
  if (in_both) {
    fn(0);
    fn(1);
    return;
  }
  thread_local Lane lane;
  in_both = true;
  lane.start(&fn);
  std::exception_ptr mine;
  try {
    fn(0);
  } catch (...) {
    mine = std::current_exception();
  }
  const std::exception_ptr theirs = lane.wait();
  in_both = false;
  if (mine) std::rethrow_exception(mine);
  if (theirs) std::rethrow_exception(theirs);
}

bool projectSphere(const CameraView& view, const Eigen::Vector3d& p_head, double radius_m,
                   double margin_px, cv::Rect* rect) {
  return projectBox(view, p_head, Eigen::Vector3d::Constant(radius_m), margin_px, rect);
}

bool projectBox(const CameraView& view, const Eigen::Vector3d& p_head,
                const Eigen::Vector3d& half_m, double margin_px, cv::Rect* rect) {
  const Eigen::Vector3d c = view.toCamera(p_head);
  if (!c.allFinite() || !half_m.allFinite() || half_m.minCoeff() < 0) return false;
  // Not near the camera's plane: the nearest corner 1 cm ahead at least.
  if (c.z() - half_m.z() < 0.01) return false;
  double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d corner =
        c + half_m.cwiseProduct(Eigen::Vector3d(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1));
    const Eigen::Vector2d px = view.projectCamera(corner);
    if (!px.allFinite()) return false;
    x0 = std::min(x0, px.x());
    y0 = std::min(y0, px.y());
    x1 = std::max(x1, px.x());
    y1 = std::max(y1, px.y());
  }
  x0 -= margin_px;
  y0 -= margin_px;
  x1 += margin_px;
  y1 += margin_px;
  // Far outside any image: not a window (and no overflow in the int rectangle).
  constexpr double kFar = 1 << 20;
  if (x0 < -kFar || y0 < -kFar || x1 > kFar || y1 > kFar) return false;
  const int ix0 = static_cast<int>(std::floor(x0)), iy0 = static_cast<int>(std::floor(y0));
  *rect = cv::Rect(ix0, iy0, static_cast<int>(std::ceil(x1)) - ix0 + 1,
                   static_cast<int>(std::ceil(y1)) - iy0 + 1);
  return true;
}

bool trackWindow(const CameraView& view, const Track& track, double t_s, const WindowParams& p,
                 cv::Rect* rect) {
  if (track.radius_m <= 0) return false;
  // In the camera's frame the k-sigma ellipsoid's bounding box is k sqrt(C_ii) along each axis:
  // the depth's larger uncertainty does not widen the window across the image. The process noise
  // of one frame is small beside the margin.
  const Eigen::Matrix3d R = view.rotation_head_camera.transpose();
  const Eigen::Matrix3d cov = R * track.positionCovarianceAt(t_s) * R.transpose();
  const Eigen::Vector3d sigma = cov.diagonal().cwiseMax(0.0).cwiseSqrt();
  return projectBox(view, track.positionAt(t_s),
                    Eigen::Vector3d::Constant(track.radius_m) + p.sigma_scale * sigma, p.margin_px,
                    rect);
}

std::vector<cv::Rect> mergeRects(std::vector<cv::Rect> rects) {
  bool merged = true;
  while (merged) {
    merged = false;
    for (size_t i = 0; i < rects.size() && !merged; ++i) {
      for (size_t j = i + 1; j < rects.size(); ++j) {
        // Touching counts: a region on the seam would be cut in both.
        const cv::Rect a(rects[i].x - 1, rects[i].y - 1, rects[i].width + 2, rects[i].height + 2);
        if ((a & rects[j]).empty()) continue;
        rects[i] |= rects[j];
        rects.erase(rects.begin() + static_cast<ptrdiff_t>(j));
        merged = true;
        break;
      }
    }
  }
  return rects;
}

WindowScanner::WindowScanner(WindowParams params, cv::Size image_size, int exact_margin_px,
                             std::vector<std::string> classes)
    : p_(params), size_(image_size), margin_px_(exact_margin_px), classes_(std::move(classes)) {
  for (const char* k :
       {"frames_scanned_full", "frames_scanned_windowed", "windows_grown",
        "windows_cut_to_full_scan", "windows_unbounded", "full_scans_disabled",
        "full_scans_no_tracks", "full_scans_periodic", "full_scans_behind", "full_scans_cover",
        "full_scans_cut", "frames_scanned_pyramid", "pyramid_fallbacks_cut",
        "pyramid_fallbacks_cover", "pyramid_windows_grown", "bands_scanned"}) {
    counts_[k] = 0;
  }
}

std::string WindowScanner::refuse(const std::vector<cv::Rect>& windows) const {
  double area = 0;
  for (const auto& w : windows) area += w.area();
  if (area > p_.max_cover_fraction * size_.area()) return "cover";
  return "";
}

ScanPlan WindowScanner::plan(const std::vector<Track>& tracks, double t_s, const CameraView& left,
                             const CameraView& right) {
  ScanPlan plan;
  if (!p_.enabled) {
    plan.reason = "disabled";
    return plan;
  }
  std::vector<cv::Rect> lw, rw;
  bool any = false;
  for (const auto& t : tracks) {
    if (t.state == TrackState::kTentative) continue;
    if (!classes_.empty() &&
        std::find(classes_.begin(), classes_.end(), t.class_name) == classes_.end()) {
      any = true;  // another scanner's object: the frame stays windowed, with its band
      continue;
    }
    cv::Rect l, r;
    if (!trackWindow(left, t, t_s, p_, &l) || !trackWindow(right, t, t_s, p_, &r)) {
      // A coasting track unseen for a while: its uncertainty reaches behind a camera and bounds
      // no window; the bands (or the periodic full scan) look for it, as for a new object.
      if (t.state == TrackState::kCoasting) {
        ++plan.unbounded;
        continue;
      }
      plan.reason = "behind";
      return plan;
    }
    // A window wholly outside an image has nothing to scan there (the bands or the periodic full
    // scan look);
    // one across the border is cut to the image: the crop's edge is then the image's, exact.
    const cv::Rect image(0, 0, size_.width, size_.height);
    if (!(l & image).empty()) lw.push_back(l & image);
    if (!(r & image).empty()) rw.push_back(r & image);
    any = true;
  }
  if (!any) {
    plan.reason = "no_tracks";
  } else if (!bands() && since_full_ + 1 >= p_.full_scan_every) {
    plan.reason = "periodic";
  } else {
    plan.left = mergeRects(lw);
    plan.right = mergeRects(rw);
    if (bands()) {
      // Every windowed plan takes the next band (an empty one too: n bands of fewer rows).
      plan.band = bandRows(next_band_, pyramidScale(size_.width, p_.full_scan_max_width_px));
      next_band_ = (next_band_ + 1) % p_.full_scan_every;
    }
    plan.reason = refuse(plan.left);
    if (plan.reason.empty()) plan.reason = refuse(plan.right);
    plan.full = !plan.reason.empty();
  }
  return plan;
}

bool WindowScanner::detectSide(const Detector& detector, const std::vector<cv::Rect>& windows,
                               const DecodeParts& decode, std::vector<Region>* regions, bool* cut,
                               std::string* why) const {
  regions->clear();
  *cut = false;
  if (windows.empty()) return true;  // no track in this camera's view: nothing to decode
  const int margin = margin_px_;
  const cv::Rect image(0, 0, size_.width, size_.height);
  std::vector<cv::Rect> crops;
  for (const auto& w : windows) {
    crops.push_back(
        cv::Rect(w.x - margin, w.y - margin, w.width + 2 * margin, w.height + 2 * margin) & image);
  }
  // One decode per side: a JPEG's rows are entropy-decoded once, down to the last crop's.
  std::vector<cv::Mat> parts;
  if (!decode(crops, &parts, why)) return false;
  if (parts.size() != crops.size()) {
    *why = "the windows' pixels are not one part per window";
    return false;
  }
  for (size_t i = 0; i < windows.size(); ++i) {
    if (parts[i].size() != crops[i].size() || parts[i].type() != CV_8UC3) {
      *why = "the window's pixels are not the window's size or BGR";
      return false;
    }
    bool c = false;
    const std::vector<Region> found =
        detector.detectWindow(parts[i], crops[i].tl(), windows[i], size_, &c);
    regions->insert(regions->end(), found.begin(), found.end());
    *cut = *cut || c;
  }
  // A full scan's order: by class, then largest first.
  std::stable_sort(regions->begin(), regions->end(), [](const Region& a, const Region& b) {
    return a.class_index != b.class_index ? a.class_index < b.class_index : a.area_px2 > b.area_px2;
  });
  return true;
}

cv::Rect WindowScanner::bandRows(int k, int scale) const {
  const int64_t n = p_.full_scan_every, h = size_.height;
  const int overlap = static_cast<int>(std::ceil(p_.band_overlap_fraction * size_.height));
  int y0 = std::max(0, static_cast<int>(k * h / n) - overlap);
  y0 -= y0 % scale;  // whole reduced rows: those of the whole image reduced
  int y1 = std::min(size_.height, static_cast<int>((k + 1) * h / n) + overlap);
  y1 = std::min(size_.height, (y1 + scale - 1) / scale * scale);
  return cv::Rect(0, y0, size_.width, y1 - y0);
}

bool WindowScanner::bandWindows(const Detector& detector, int scale, const cv::Rect& band,
                                const ImagePixels& pixels, const std::vector<cv::Rect>& tracked,
                                std::vector<cv::Rect>* windows, std::string* why) const {
  const cv::Size small(reducedSize(size_, scale).width,
                       (band.br().y + scale - 1) / scale - band.y / scale);
  cv::Mat pixels_of_band;
  if (scale > 1 && pixels.reduced) {
    if (!pixels.reduced(scale, band.y, band.br().y, &pixels_of_band, why)) return false;
  } else {
    std::vector<cv::Mat> parts;
    if (!pixels.parts({band}, &parts, why)) return false;
    if (parts.size() != 1 || parts[0].size() != band.size() || parts[0].type() != CV_8UC3) {
      *why = "the band's pixels are not the band's size or BGR";
      return false;
    }
    pixels_of_band = parts[0];
    if (scale > 1) cv::resize(parts[0], pixels_of_band, small, 0, 0, cv::INTER_AREA);
  }
  if (pixels_of_band.size() != small || pixels_of_band.type() != CV_8UC3) {
    *why = "the reduced band is not the reduced size or BGR";
    return false;
  }
  // Candidates as a pyramid level's (scale 1: the area limits widened, no shape test): the exact
  // regions come from the windows around them, so a band's cut edge or a candidate's shape there
  // decides nothing.
  std::vector<Region> candidates = detector.detectReduced(pixels_of_band, scale);
  const int reduced_height = reducedSize(size_, scale).height;
  std::vector<Region> untracked;
  for (Region c : candidates) {
    // Inside a track's window already (its box scaled back, a reduced pixel's slack around):
    // that window's scan finds it exactly. One only touching a window is kept: the window's scan
    // keeps only what is inside it, and merged with it, its own window holds it.
    const cv::Rect full((c.bbox.x - 1) * scale, (c.bbox.y + band.y / scale - 1) * scale,
                        (c.bbox.width + 2) * scale, (c.bbox.height + 2) * scale);
    if (std::any_of(tracked.begin(), tracked.end(),
                    [&](const cv::Rect& w) { return (w & full) == full; })) {
      continue;
    }
    // One that may go on across the band's edge (the filters reach margin_px_ from it): its
    // window runs to the image's edge that way, so it need not be cut and grown for it.
    const bool up = band.y > 0 && c.bbox.y <= margin_px_;
    const bool down =
        band.br().y < size_.height && c.bbox.br().y >= pixels_of_band.rows - margin_px_;
    const int y0 = up ? 0 : c.bbox.y + band.y / scale;
    const int y1 = down ? reduced_height : c.bbox.br().y + band.y / scale;
    c.bbox.y = y0;
    c.bbox.height = y1 - y0;
    untracked.push_back(c);
  }
  *windows = pyramidWindows(untracked, scale, pyramidMarginPx(scale, margin_px_), size_);
  return true;
}

std::vector<cv::Rect> WindowScanner::grow(const std::vector<cv::Rect>& windows) const {
  std::vector<cv::Rect> grown;
  for (const auto& w : windows) {
    const int dx = static_cast<int>(std::ceil(w.width * (p_.grow_factor - 1) / 2));
    const int dy = static_cast<int>(std::ceil(w.height * (p_.grow_factor - 1) / 2));
    grown.push_back(cv::Rect(w.x - dx, w.y - dy, w.width + 2 * dx, w.height + 2 * dy) &
                    cv::Rect(0, 0, size_.width, size_.height));
  }
  return mergeRects(grown);
}

bool WindowScanner::fullSide(const Detector& detector, const DecodeParts& decode,
                             std::vector<Region>* regions, std::string* why) const {
  std::vector<cv::Mat> image;
  if (!decode({cv::Rect(0, 0, size_.width, size_.height)}, &image, why)) return false;
  if (image.size() != 1 || image[0].size() != size_ || image[0].type() != CV_8UC3) {
    *why = "the image is not the frame's size or BGR";
    return false;
  }
  *regions = detector.detect(image[0]);
  return true;
}

bool WindowScanner::detect(const Detector& detector, ScanPlan* plan, const ImagePixels& left,
                           const ImagePixels& right, std::vector<Region>* left_regions,
                           std::vector<Region>* right_regions, std::string* why) {
  const DecodeParts* decode[2] = {&left.parts, &right.parts};
  const ImagePixels* pixels[2] = {&left, &right};
  std::vector<Region>* out[2] = {left_regions, right_regions};
  std::vector<cv::Rect>* windows[2] = {&plan->left, &plan->right};
  std::string errors[2];
  bool ok[2] = {true, true}, cut[2] = {false, false};
  const auto both = forBothCameras;
  const auto failed = [&] {
    if (ok[0] && ok[1]) return false;
    *why = ok[0] ? "right image: " + errors[1] : "left image: " + errors[0];
    return true;
  };
  if (!plan->full && !plan->band.empty()) {
    const int scale = pyramidScale(size_.width, p_.full_scan_max_width_px);
    std::vector<cv::Rect> found[2];
    both([&](int i) {
      ok[i] =
          bandWindows(detector, scale, plan->band, *pixels[i], *windows[i], &found[i], &errors[i]);
    });
    if (failed()) return false;
    for (int i = 0; i < 2; ++i) {
      windows[i]->insert(windows[i]->end(), found[i].begin(), found[i].end());
      *windows[i] = mergeRects(*windows[i]);
    }
    plan->reason = refuse(plan->left);
    if (plan->reason.empty()) plan->reason = refuse(plan->right);
    plan->full = !plan->reason.empty();
  }
  if (!plan->full) {
    both([&](int i) {
      ok[i] = detectSide(detector, *windows[i], *decode[i], out[i], &cut[i], &errors[i]);
    });
    if (failed()) return false;
    for (int i = 0; i < 2 && !plan->full; ++i) {
      if (!cut[i]) continue;
      // An object larger than its window (closer, or zoomed in): grow the side's windows once.
      ++counts_["windows_grown"];
      *windows[i] = grow(*windows[i]);
      bool still_cut = !refuse(*windows[i]).empty();
      if (!still_cut) {
        ok[i] = detectSide(detector, *windows[i], *decode[i], out[i], &cut[i], &errors[i]);
        if (failed()) return false;
        still_cut = cut[i];
      }
      if (still_cut) {
        ++counts_["windows_cut_to_full_scan"];
        plan->full = true;
        plan->reason = "cut";
      }
    }
  }
  if (plan->full) {
    plan->left.clear();
    plan->right.clear();
    plan->band = {};
    const int scale = pyramidScale(size_.width, p_.full_scan_max_width_px);
    std::string fallback[2];
    int grown[2] = {0, 0};
    both([&](int i) {
      if (scale > 1) {
        ok[i] =
            pyramidSide(detector, scale, *pixels[i], out[i], &fallback[i], &grown[i], &errors[i]);
        if (!ok[i] || fallback[i].empty()) return;
      }
      ok[i] = fullSide(detector, *decode[i], out[i], &errors[i]);
    });
    if (failed()) return false;
    ++counts_["frames_scanned_full"];
    ++counts_["full_scans_" + plan->reason];
    if (scale > 1) {
      counts_["pyramid_windows_grown"] += grown[0] + grown[1];
      plan->pyramid = fallback[0].empty() && fallback[1].empty();
      // One reason a frame: cut before cover.
      const std::string reason = fallback[0] == "cut" || fallback[1] == "cut" ? "cut"
                                 : fallback[0].empty()                        ? fallback[1]
                                                                              : fallback[0];
      ++counts_[plan->pyramid ? "frames_scanned_pyramid" : "pyramid_fallbacks_" + reason];
    }
    since_full_ = 0;
  } else {
    ++counts_["frames_scanned_windowed"];
    counts_["windows_unbounded"] += plan->unbounded;
    since_full_ = std::min(since_full_ + 1, p_.full_scan_every);
    if (!plan->band.empty()) ++counts_["bands_scanned"];
  }
  return true;
}

bool WindowScanner::detectBand(const Detector& detector, const cv::Rect& band,
                               const std::vector<cv::Rect> tracked[2], const ImagePixels& left,
                               const ImagePixels& right, std::vector<Region>* left_regions,
                               std::vector<Region>* right_regions, std::string* why) {
  left_regions->clear();
  right_regions->clear();
  if (band.empty()) return true;
  const ImagePixels* pixels[2] = {&left, &right};
  std::vector<Region>* out[2] = {left_regions, right_regions};
  std::string errors[2];
  bool ok[2] = {true, true}, cut[2] = {false, false};
  const int scale = pyramidScale(size_.width, p_.full_scan_max_width_px);
  forBothCameras([&](int i) {
    std::vector<cv::Rect> found;
    ok[i] = bandWindows(detector, scale, band, *pixels[i], tracked[i], &found, &errors[i]);
    if (!ok[i] || found.empty()) return;
    found = mergeRects(found);
    ok[i] = detectSide(detector, found, pixels[i]->parts, out[i], &cut[i], &errors[i]);
    if (!ok[i] || !cut[i]) return;
    // An object larger than its window: grown once; still cut, the next band or the windows of
    // its track (once one starts) see it whole.
    ok[i] = detectSide(detector, grow(found), pixels[i]->parts, out[i], &cut[i], &errors[i]);
    if (ok[i] && cut[i]) out[i]->clear();
  });
  if (!ok[0] || !ok[1]) {
    *why = ok[0] ? "right image: " + errors[1] : "left image: " + errors[0];
    return false;
  }
  for (int i = 0; i < 2; ++i) {
    if (cut[i]) ++counts_["band_windows_cut"];
  }
  ++counts_["bands_scanned"];
  return true;
}

}  // namespace ptz::perception
