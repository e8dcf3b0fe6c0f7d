#include "perception/people/people_scan.hpp"

#include <opencv2/imgproc.hpp>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <tuple>

#include "perception/detection/stereo.hpp"

namespace ptz::perception {
namespace {

constexpr double kWindowBoxScale = 1.1;

double overlap(const cv::Rect2d& a, const cv::Rect2d& b) {
  const double i = (a & b).area();
  return i / std::max(1e-9, a.area() + b.area() - i);
}

}  // namespace

void hogMultiScale(const cv::HOGDescriptor& hog, const cv::Mat& img, cv::Size stride, double scale0,
                   int final_threshold, std::vector<cv::Rect>* found,
                   std::vector<double>* weights) {
  found->clear();
  weights->clear();
  // The levels as OpenCV's detectMultiScale takes them (the last, too small, left out).
  std::vector<double> levels;
  double scale = 1;
  for (int i = 0; i < hog.nlevels; ++i) {
    if (cvRound(img.cols / scale) < hog.winSize.width ||
        cvRound(img.rows / scale) < hog.winSize.height || scale0 <= 1) {
      break;
    }
    levels.push_back(scale);
    scale *= scale0;
  }
  if (levels.empty()) levels.push_back(1);
  // Largest first, each to the thread with the fewer pixels so far.
  std::vector<int> lane(levels.size());
  double pixels[2] = {0, 0};
  for (size_t i = 0; i < levels.size(); ++i) {
    const int to = pixels[0] <= pixels[1] ? 0 : 1;
    lane[i] = to;
    pixels[to] += 1 / (levels[i] * levels[i]);
  }
  std::vector<cv::Rect> hits[2];
  std::vector<double> hit_weights[2];
  forBothCameras([&](int side) {
    for (size_t i = 0; i < levels.size(); ++i) {
      if (lane[i] != side) continue;
      const double s = levels[i];
      const cv::Size size(cvRound(img.cols / s), cvRound(img.rows / s));
      cv::Mat level = img;
      if (size != img.size()) cv::resize(img, level, size, 0, 0, cv::INTER_LINEAR_EXACT);
      std::vector<cv::Point> at;
      std::vector<double> w;
      hog.detect(level, at, w, 0, stride, cv::Size());
      const cv::Size box(cvRound(hog.winSize.width * s), cvRound(hog.winSize.height * s));
      for (size_t j = 0; j < at.size(); ++j) {
        hits[side].emplace_back(cvRound(at[j].x * s), cvRound(at[j].y * s), box.width, box.height);
        hit_weights[side].push_back(j < w.size() ? w[j] : 0);
      }
    }
  });
  for (int side = 0; side < 2; ++side) {
    found->insert(found->end(), hits[side].begin(), hits[side].end());
    weights->insert(weights->end(), hit_weights[side].begin(), hit_weights[side].end());
  }
  hog.groupRectangles(*found, *weights, final_threshold, 0.2);
  // Cut to the image; none left of one: dropped (OpenCV's clipObjects).
  const cv::Rect image(0, 0, img.cols, img.rows);
  size_t kept = 0;
  for (size_t i = 0; i < found->size(); ++i) {
    const cv::Rect r = (*found)[i] & image;
    if (r.area() <= 0) continue;
    (*found)[kept] = r;
    if (i < weights->size()) (*weights)[kept] = (*weights)[i];
    ++kept;
  }
  found->resize(kept);
  weights->resize(std::min(weights->size(), kept));
}

PeopleScanner::PeopleScanner(std::vector<PeopleClass> classes, PeopleScanParams params,
                             cv::Size image)
    : classes_(std::move(classes)), p_(params), size_(image) {
  hog_.setSVMDetector(cv::HOGDescriptor::getDefaultPeopleDetector());
  // A track's window is scaled so its object's box is kWindowBoxScale of HOG's smallest: a few
  // levels above that cover a box 10 % smaller to 15 % larger than predicted.
  window_hog_.setSVMDetector(cv::HOGDescriptor::getDefaultPeopleDetector());
  window_hog_.nlevels = 6;
  for (const PeopleClass& c : classes_) {
    cascades_.emplace_back();
    if (c.detector != "cascade") continue;
    cascades_.back() = std::make_unique<cv::CascadeClassifier>();
    loadCascade(c.cascade, cascades_.back().get());
  }
}

int PeopleScanner::classOf(const std::string& class_name) const {
  for (size_t i = 0; i < classes_.size(); ++i) {
    if (classes_[i].name == class_name) return static_cast<int>(i);
  }
  return -1;
}

std::vector<PeopleScanner::Box> PeopleScanner::detect(size_t c, const cv::Mat& grey,
                                                      const cv::Rect& part, double scale,
                                                      bool fine) {
  const PeopleClass& k = classes_[c];
  cv::Mat img = grey;
  if (std::abs(scale - 1) > 1e-3) {
    cv::resize(grey, img, cv::Size(), scale, scale, scale < 1 ? cv::INTER_AREA : cv::INTER_LINEAR);
  }
  std::vector<cv::Rect> found;
  std::vector<double> weights;  // HOG's SVM margins (a cascade's hits weigh 1)
  cv::Point pad(0, 0);          // the padding's, top-left, scaled pixels
  if (k.detector == "hog") {
    // A standing person's feet are near the bottom of a level camera's view, and HOG's box reaches
    // an eighth of its height beyond the body: the image's own edges are padded by that
    // (replicated), so such a person is found.
    const int pad_y = hog_.winSize.height / 8, pad_x = hog_.winSize.width / 8;
    const int top = part.y == 0 ? pad_y : 0, left = part.x == 0 ? pad_x : 0;
    const int bottom = part.br().y == size_.height ? pad_y : 0;
    const int right = part.br().x == size_.width ? pad_x : 0;
    if (top + bottom + left + right > 0) {
      cv::copyMakeBorder(img, img, top, bottom, left, right, cv::BORDER_REPLICATE);
      pad = {left, top};
    }
    if (img.cols < hog_.winSize.width || img.rows < hog_.winSize.height) return {};
    if (fine) {
      hogMultiScale(window_hog_, img, cv::Size(4, 4), 1.05, 2, &found, &weights);
    } else {
      hogMultiScale(hog_, img, cv::Size(8, 8), 1.05, 2, &found, &weights);
    }
  } else {
    const int min_px = static_cast<int>(k.min_box_px);
    if (img.cols < min_px || img.rows < min_px) return {};
    // A strip looks for boxes up to max_box_fraction of the image's height (a window for any).
    const int max_px = fine ? 0 : static_cast<int>(k.max_box_fraction * size_.height * scale);
    cascades_[c]->detectMultiScale(img, found, fine ? 1.1 : 1.2, k.min_neighbors, 0,
                                   cv::Size(min_px, min_px), cv::Size(max_px, max_px));
  }
  std::vector<Box> boxes;
  for (size_t i = 0; i < found.size(); ++i) {
    const cv::Rect& r = found[i];
    boxes.push_back({cv::Rect2d(part.x + (r.x - pad.x) / scale, part.y + (r.y - pad.y) / scale,
                                r.width / scale, r.height / scale),
                     i < weights.size() ? weights[i] : 1.0});
  }
  // Strongest first, then in a fixed order: OpenCV's threads hand their hits back in any order,
  // and which of two overlapping boxes is kept must not depend on that.
  std::sort(boxes.begin(), boxes.end(), [](const Box& a, const Box& b) {
    return std::make_tuple(-a.weight, a.rect.y, a.rect.x, a.rect.height) <
           std::make_tuple(-b.weight, b.rect.y, b.rect.x, b.rect.height);
  });
  counts_["people_boxes"] += static_cast<int64_t>(boxes.size());
  return boxes;
}

bool PeopleScanner::range(size_t c, const cv::Rect2d& box, const CameraView& left,
                          const CameraView& right, const CropPixels crop[2], PatchObject* out,
                          std::string* why) {
  const PeopleClass& k = classes_[c];
  const cv::Point2d centre =
      (box.tl() + box.br()) * 0.5 - cv::Point2d(0, k.centre_above_box_fraction * box.height);
  const cv::Rect image(0, 0, size_.width, size_.height);
  const cv::Rect patch_rect =
      cv::Rect(static_cast<int>(std::lround(centre.x - box.width * k.patch_width_fraction / 2)),
               static_cast<int>(std::lround(centre.y - box.height * k.patch_height_fraction / 2)),
               std::max(8, static_cast<int>(std::lround(box.width * k.patch_width_fraction))),
               std::max(8, static_cast<int>(std::lround(box.height * k.patch_height_fraction)))) &
      image;
  if (patch_rect.width < 8 || patch_rect.height < 8) {
    ++counts_["people_refused_unmatched"];
    return false;
  }
  cv::Mat pixels;
  if (!crop[0](patch_rect, &pixels, why)) return false;
  const cv::Mat patch = greyOf(pixels).clone();
  const Eigen::Vector2d at(patch_rect.x + (patch_rect.width - 1) / 2.0,
                           patch_rect.y + (patch_rect.height - 1) / 2.0);
  const double reduce =
      std::min(1.0, p_.max_patch_px / static_cast<double>(std::max(patch.cols, patch.rows)));
  EpipolarMatch m;
  std::string unmatched;
  if (!matchAlongEpipolar(patch, at, left, right, crop[1], p_.min_range_m, p_.max_range_m, &m,
                          &unmatched, reduce) ||
      m.best < p_.min_score) {
    ++counts_["people_refused_unmatched"];
    return false;
  }
  if (m.best - m.second < p_.unique_margin) {
    ++counts_["people_refused_not_unique"];
    return false;
  }
  const Eigen::Vector2d rp(m.centre.x, m.centre.y);
  Eigen::Vector3d p;
  double epipolar_px = 0;
  if (!triangulate(left, right, at, rp, &p, &epipolar_px) || epipolar_px > 2 / reduce) {
    ++counts_["people_refused_epipolar"];
    return false;
  }
  const double range_m = (p - left.position_head_m).norm();
  const double z_m = left.toCamera(p).z();
  if (range_m < p_.min_range_m || range_m > p_.max_range_m || z_m <= 0) {
    ++counts_["people_refused_range"];
    return false;
  }
  const double expected_px = k.height_m * k.box_height_ratio * left.intrinsics.fx / z_m;
  if (std::abs(box.height / expected_px - 1) > p_.size_tolerance) {
    ++counts_["people_refused_size"];
    return false;
  }
  out->class_name = k.name;
  out->position_m = p;
  out->covariance_m2 = triangulationCovariance(left, right, at, rp, p_.pixel_sigma_px / reduce);
  out->radius_m = k.height_m / 2;
  out->pixel[0] = {at.x(), at.y()};
  out->pixel[1] = m.centre;
  out->box[0] = cv::Rect(box);
  out->box[1] = cv::Rect(box + (m.centre - cv::Point2d(at.x(), at.y())));
  out->score[0] = 1;
  out->score[1] = m.best;
  return true;
}

bool PeopleScanner::scan(const std::vector<Track>& tracks, double t_s, const CameraView& left,
                         const CameraView& right, const CropPixels crop[2],
                         std::vector<PatchObject>* out, std::string* why, ScanParts parts) {
  out->clear();
  if (!enabled()) return true;
  const cv::Rect image(0, 0, size_.width, size_.height);
  // One class's strip a frame: the classes take turns.
  const int n = std::max(1, p_.strips);
  const int turn = next_strip_;
  size_t scanned_class = classes_.size();  // none
  if (parts != ScanParts::kWindows) {
    next_strip_ = (next_strip_ + 1) % (n * static_cast<int>(classes_.size()));
    scanned_class = static_cast<size_t>(turn % static_cast<int>(classes_.size()));
    ++counts_["people_strips_scanned"];
  }
  const int k = turn / static_cast<int>(classes_.size());
  for (size_t c = 0; c < classes_.size(); ++c) {
    const PeopleClass& pc = classes_[c];
    std::vector<Box> boxes;
    // Windows: each track's box at its predicted place, scaled so the object is just above the
    // detector's smallest.
    for (const Track& t : tracks) {
      if (t.class_name != pc.name || parts == ScanParts::kNew) continue;
      const Eigen::Vector3d predicted = t.positionAt(t_s);
      const double z_m = left.toCamera(predicted).z();
      const Eigen::Vector2d q = left.project(predicted);
      if (z_m <= 0 || !q.allFinite()) continue;
      const double box_h = pc.height_m * pc.box_height_ratio * left.intrinsics.fx / z_m;
      const double box_w = box_h * pc.box_aspect;
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(t.positionCovariance());
      const double spread_px = std::min(
          3 * left.intrinsics.fx * std::sqrt(std::max(0.0, es.eigenvalues().maxCoeff())) / z_m,
          400.0);
      const double w = box_w * (1 + 2 * p_.window_margin) + 2 * spread_px;
      const double h = box_h * (1 + 2 * p_.window_margin) + 2 * spread_px;
      const cv::Rect window =
          cv::Rect(static_cast<int>(std::floor(q.x() - w / 2)),
                   static_cast<int>(std::floor(q.y() - h / 2)), static_cast<int>(std::ceil(w)),
                   static_cast<int>(std::ceil(h))) &
          image;
      if (window.empty()) continue;
      // Down to a 20th: a figure near the camera fills most of a 1080p frame's height.
      const double scale = std::clamp(kWindowBoxScale * pc.min_box_px / box_h, 0.05, 2.0);
      // A window that would cost more than a whole image halved (a track long unseen, an object
      // small in the image) is left to the strips.
      if (window.area() * scale * scale > p_.max_window_px2) {
        ++counts_["people_windows_left_to_strips"];
        continue;
      }
      ++counts_["people_windows"];
      cv::Mat pixels;
      if (!crop[0](window, &pixels, why)) return false;
      for (const auto& b : detect(c, greyOf(pixels), window, scale, true)) boxes.push_back(b);
    }
    if (c == scanned_class) {
      // The strip reaches beyond its share by half the widest box the class is looked for with, so
      // each such object is whole in one strip.
      const int reach =
          static_cast<int>(std::ceil(0.5 * pc.box_aspect * pc.max_box_fraction * size_.height));
      const int x0 = std::max(0, k * size_.width / n - reach);
      const int x1 = std::min(size_.width, (k + 1) * size_.width / n + reach);
      const cv::Rect strip(x0, 0, x1 - x0, size_.height);
      cv::Mat pixels;
      if (!crop[0](strip, &pixels, why)) return false;
      for (const auto& b : detect(c, greyOf(pixels), strip, pc.scan_scale, false)) {
        // Cut by the strip's edge (not the image's): whole in the next strip (strips overlap).
        constexpr double kClearPx = 2;
        if ((strip.x > 0 && b.rect.x < strip.x + kClearPx) ||
            (strip.br().x < size_.width && b.rect.br().x > strip.br().x - kClearPx)) {
          continue;
        }
        boxes.push_back(b);
      }
    }
    // Windows' boxes first (at the object's own scale), each ranged unless it overlaps one taken
    // already: a box refused (its size, no match) leaves the others their turn.
    std::vector<cv::Rect2d> taken;
    int tried = 0;
    for (const Box& b : boxes) {
      if (std::any_of(taken.begin(), taken.end(),
                      [&](const cv::Rect2d& t) { return overlap(t, b.rect) > 0.3; })) {
        continue;
      }
      if (static_cast<int>(taken.size()) >= p_.max_per_class || tried >= 3 * p_.max_per_class) {
        ++counts_["people_refused_capped"];
        continue;
      }
      ++tried;
      PatchObject o;
      std::string crop_why;
      if (range(c, b.rect, left, right, crop, &o, &crop_why)) {
        out->push_back(o);
        taken.push_back(b.rect);
      } else if (!crop_why.empty()) {
        *why = crop_why;
        return false;
      }
    }
  }
  counts_["people_objects"] += static_cast<int64_t>(out->size());
  return true;
}

}  // namespace ptz::perception
