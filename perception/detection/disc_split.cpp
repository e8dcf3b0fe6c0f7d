#include "perception/detection/disc_split.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace ptz::perception {
namespace {

constexpr int kArcBins = 36;
constexpr double kMinArcRunDeg = 40;  // of the circle in one piece
constexpr double kConfidence = 0.999;
constexpr size_t kMaxPoints = 1000;

double tolerance(const DiscSplitParams& p, double radius_px) {
  return std::max(p.inlier_px, p.inlier_share * radius_px);
}

std::vector<size_t> inliersOf(const std::vector<cv::Point2d>& points,
                              const std::vector<size_t>& candidates, const cv::Point2d& centre,
                              double radius, double tol) {
  std::vector<size_t> in;
  for (size_t i : candidates) {
    if (std::abs(std::hypot(points[i].x - centre.x, points[i].y - centre.y) - radius) <= tol) {
      in.push_back(i);
    }
  }
  return in;
}

// The share of the circumference the points cover, and the longest arc of it in one piece, in
// degrees (a ball's arc is whole; the sides of a square touch a circle in short bits). In bins
// of 10 degrees, wider on a small circle, whose outline has fewer points (about 5.7 r of them):
// each bin must be able to hold one.
double arcFraction(const std::vector<cv::Point2d>& points, const std::vector<size_t>& in,
                   const cv::Point2d& centre, double radius_px, double* longest_run_deg) {
  const int n = std::clamp(static_cast<int>(std::lround(2 * M_PI * radius_px / 1.5)), 8, kArcBins);
  std::array<bool, kArcBins> bins{};
  for (size_t i : in) {
    const double a = std::atan2(points[i].y - centre.y, points[i].x - centre.x) + M_PI;
    bins[static_cast<size_t>(std::min(n - 1, static_cast<int>(a / (2 * M_PI) * n)))] = true;
  }
  int longest = 0;
  for (int start = 0, run = 0; start < 2 * n; ++start) {  // twice round: runs wrap
    run = bins[static_cast<size_t>(start % n)] ? run + 1 : 0;
    longest = std::max(longest, std::min(run, n));
  }
  *longest_run_deg = 360.0 * longest / n;
  return static_cast<double>(std::count(bins.begin(), bins.begin() + n, true)) / n;
}

// Whether at least `share` of the disc's pixels are the region's: stops as soon as too many are
// not (a hostile blob's big circles cost little), pixels beyond the mask's box counted at once.
bool mostlyInside(const cv::Mat& mask, const cv::Point& origin, const cv::Point2d& c, double r,
                  double share) {
  const int y0 = static_cast<int>(std::ceil(c.y - r)), y1 = static_cast<int>(std::floor(c.y + r));
  const int x0 = static_cast<int>(std::ceil(c.x - r)), x1 = static_cast<int>(std::floor(c.x + r));
  const double allowed = (1 - share) * M_PI * r * r;
  double outside = 0;
  const double r2 = r * r;
  for (int y = y0; y <= y1; ++y) {
    const double dy = y - c.y;
    const double half = std::sqrt(std::max(0.0, r2 - dy * dy));  // the disc's row: |x - cx| <= half
    const int from = static_cast<int>(std::ceil(c.x - half)),
              to = static_cast<int>(std::floor(c.x + half));
    if (to < from) continue;
    const int my = y - origin.y;
    if (my < 0 || my >= mask.rows) {
      outside += to - from + 1;
    } else {
      const uchar* row = mask.ptr<uchar>(my);
      for (int x = std::max(from, x0); x <= std::min(to, x1); ++x) {
        const int mx = x - origin.x;
        outside += (mx < 0 || mx >= mask.cols || row[mx] == 0) ? 1 : 0;
      }
    }
    if (outside > allowed) return false;
  }
  return true;
}

// Two balls' discs cannot share a centre: one would hide the other whole, and a circle near
// concentric with a disc found already is its own arc's noise with a neighbour's.
bool nearAccepted(const std::vector<Disc>& discs, const cv::Point2d& c, double r) {
  for (const Disc& d : discs) {
    if (std::hypot(c.x - d.centre_px.x, c.y - d.centre_px.y) < 0.5 * std::min(r, d.radius_px)) {
      return true;
    }
  }
  return false;
}

}  // namespace

bool circleThrough(const cv::Point2d& a, const cv::Point2d& b, const cv::Point2d& c,
                   cv::Point2d* centre, double* radius) {
  const double d = 2 * (a.x * (b.y - c.y) + b.x * (c.y - a.y) + c.x * (a.y - b.y));
  if (std::abs(d) < 1e-9) return false;
  const double a2 = a.dot(a), b2 = b.dot(b), c2 = c.dot(c);
  centre->x = (a2 * (b.y - c.y) + b2 * (c.y - a.y) + c2 * (a.y - b.y)) / d;
  centre->y = (a2 * (c.x - b.x) + b2 * (a.x - c.x) + c2 * (b.x - a.x)) / d;
  *radius = std::hypot(a.x - centre->x, a.y - centre->y);
  return std::isfinite(*radius);
}

bool fitCircle(const std::vector<cv::Point2d>& points, cv::Point2d* centre, double* radius) {
  if (points.size() < 3) return false;
  // x^2 + y^2 = 2 cx x + 2 cy y + (r^2 - cx^2 - cy^2), about the mean for conditioning.
  cv::Point2d mean(0, 0);
  for (const auto& p : points) mean += p;
  mean *= 1.0 / static_cast<double>(points.size());
  cv::Matx33d A = cv::Matx33d::zeros();
  cv::Vec3d b(0, 0, 0);
  for (const auto& q : points) {
    const cv::Point2d p = q - mean;
    const cv::Vec3d row(2 * p.x, 2 * p.y, 1);
    const double rhs = p.dot(p);
    A += row * row.t();
    b += rhs * row;
  }
  cv::Vec3d s;
  if (!cv::solve(A, b, s, cv::DECOMP_CHOLESKY)) return false;
  const double r2 = s[2] + s[0] * s[0] + s[1] * s[1];
  if (!(r2 > 0)) return false;
  *centre = mean + cv::Point2d(s[0], s[1]);
  *radius = std::sqrt(r2);
  return std::isfinite(*radius);
}

std::vector<Disc> splitDiscs(const std::vector<cv::Point>& contour, const cv::Mat& mask,
                             const cv::Point& mask_origin, double min_radius_px,
                             const DiscSplitParams& p, double* covered_share) {
  std::vector<Disc> discs;
  if (contour.size() < 12 || mask.empty() || mask.type() != CV_8U) return discs;
  // A long outline (a big or ragged blob, or a hostile image) is thinned evenly: RANSAC's cost
  // is iterations x points.
  const size_t stride = (contour.size() + kMaxPoints - 1) / kMaxPoints;
  std::vector<cv::Point2d> points;
  for (size_t i = 0; i < contour.size(); i += stride) points.emplace_back(contour[i]);
  std::vector<size_t> remaining(points.size());
  for (size_t i = 0; i < remaining.size(); ++i) remaining[i] = i;
  // A disc almost wholly inside the region fits its shorter side (give or take its edge).
  const double max_radius_px = 1.1 * std::min(mask.cols, mask.rows) / 2.0 + 2;
  cv::RNG rng(0x5eed);
  while (static_cast<int>(discs.size()) < p.max_discs && remaining.size() >= 6) {
    cv::Point2d best_c;
    double best_r = 0;
    size_t best_count = 0;
    double needed = p.iterations;
    for (int it = 0; it < p.iterations; ++it) {
      const size_t n = remaining.size();
      const size_t i = remaining[rng.uniform(0, static_cast<int>(n))];
      const size_t j = remaining[rng.uniform(0, static_cast<int>(n))];
      const size_t k = remaining[rng.uniform(0, static_cast<int>(n))];
      if (i == j || j == k || i == k) continue;
      cv::Point2d c;
      double r = 0;
      if (!circleThrough(points[i], points[j], points[k], &c, &r)) continue;
      if (r < min_radius_px || r > max_radius_px || nearAccepted(discs, c, r)) continue;
      const size_t count = inliersOf(points, remaining, c, r, tolerance(p, r)).size();
      if (count > best_count) {
        best_count = count, best_c = c, best_r = r;
        // Enough samples that one all on the best circle's arc came up with 99.9 % probability
        // (RANSAC's adaptive count: log(1 - p) / log(1 - w^3), w its inlier share).
        const double w = static_cast<double>(count) / static_cast<double>(n);
        const double miss = 1 - w * w * w;
        needed = miss <= 0 ? 0 : std::log(1 - kConfidence) / std::log(miss);
      }
      if (it + 1 >= needed) break;
    }
    if (best_count < 6) break;
    // Refined on its inliers, twice (the inliers of the refined circle may be more).
    std::vector<size_t> in = inliersOf(points, remaining, best_c, best_r, tolerance(p, best_r));
    for (int pass = 0; pass < 2; ++pass) {
      std::vector<cv::Point2d> on;
      for (size_t i : in) on.push_back(points[i]);
      cv::Point2d c;
      double r = 0;
      if (!fitCircle(on, &c, &r) || r < min_radius_px || r > max_radius_px) break;
      std::vector<size_t> again = inliersOf(points, remaining, c, r, tolerance(p, r));
      if (again.size() < in.size()) break;
      best_c = c, best_r = r, in = std::move(again);
    }
    Disc d;
    d.centre_px = best_c;
    d.radius_px = best_r;
    double longest_run_deg = 0;
    d.arc_fraction = arcFraction(points, in, best_c, best_r, &longest_run_deg);
    double ss = 0;
    for (size_t i : in) {
      const double e = std::hypot(points[i].x - best_c.x, points[i].y - best_c.y) - best_r;
      ss += e * e;
    }
    d.rms_px = std::sqrt(ss / static_cast<double>(in.size()));
    if (d.arc_fraction < p.min_arc_fraction || longest_run_deg < kMinArcRunDeg ||
        !mostlyInside(mask, mask_origin, best_c, best_r, p.min_inside)) {
      break;
    }
    discs.push_back(d);
    // Its arc goes, with the points its noise put just off it (twice the tolerance) or inside it.
    std::vector<size_t> rest;
    for (size_t i : remaining) {
      const double dist = std::hypot(points[i].x - best_c.x, points[i].y - best_c.y);
      if (dist > best_r + 2 * tolerance(p, best_r)) rest.push_back(i);
    }
    remaining = std::move(rest);
  }
  if (discs.empty()) return discs;
  // The discs must explain the region: a shape that merely holds an arc or two is no pair of balls.
  int region = 0, covered = 0;
  for (int y = 0; y < mask.rows; ++y) {
    for (int x = 0; x < mask.cols; ++x) {
      if (mask.at<uchar>(y, x) == 0) continue;
      ++region;
      const cv::Point2d q(x + mask_origin.x, y + mask_origin.y);
      for (const Disc& d : discs) {
        const double dx = q.x - d.centre_px.x, dy = q.y - d.centre_px.y;
        if (dx * dx + dy * dy <= (d.radius_px + 1) * (d.radius_px + 1)) {
          ++covered;
          break;
        }
      }
    }
  }
  if (covered_share) *covered_share = region > 0 ? static_cast<double>(covered) / region : 0.0;
  if (region == 0 || covered < p.min_covered * region) discs.clear();
  return discs;
}

}  // namespace ptz::perception
