#include "sim/scene/posters.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdint>
#include <filesystem>

#include "common/config.hpp"

namespace ptz::sim {
namespace {

// Bilinear BGR at (x, y) in pixel coordinates (0: the first pixel's centre), clamped to the edge.
cv::Vec3f bilinear(const cv::Mat& image, double x, double y) {
  x = std::clamp(x, 0.0, image.cols - 1.0);
  y = std::clamp(y, 0.0, image.rows - 1.0);
  const int x0 = std::min(static_cast<int>(x), image.cols - 1);
  const int y0 = std::min(static_cast<int>(y), image.rows - 1);
  const int x1 = std::min(x0 + 1, image.cols - 1), y1 = std::min(y0 + 1, image.rows - 1);
  const float ax = static_cast<float>(x - x0), ay = static_cast<float>(y - y0);
  const auto at = [&](int xx, int yy) { return cv::Vec3f(image.at<cv::Vec3b>(yy, xx)); };
  return (1 - ay) * ((1 - ax) * at(x0, y0) + ax * at(x1, y0)) +
         ay * ((1 - ax) * at(x0, y1) + ax * at(x1, y1));
}

// The photograph and its halvings (area averages) down to one pixel.
std::vector<cv::Mat> imageLevels(const cv::Mat& image) {
  std::vector<cv::Mat> levels{image};
  while (levels.back().cols > 1 || levels.back().rows > 1) {
    const cv::Mat& fine = levels.back();
    cv::Mat coarse;
    cv::resize(fine, coarse, cv::Size((fine.cols + 1) / 2, (fine.rows + 1) / 2), 0, 0,
               cv::INTER_AREA);
    levels.push_back(coarse);
  }
  return levels;
}

cv::Mat readImage(const std::string& value, const std::string& base_dir, const std::string& w) {
  std::filesystem::path path(value);
  if (path.is_relative() && !base_dir.empty()) {
    path = (std::filesystem::path(base_dir) / path).lexically_normal();
  }
  cv::Mat image;
  std::string why = "cannot be read as an image";
  std::error_code ec;
  // A photograph is at most this big, on disk and decoded (a config may name any file).
  constexpr uintmax_t kMaxFileBytes = uintmax_t{64} << 20;
  constexpr double kMaxPixels = 40e6;
  if (!std::filesystem::is_regular_file(path, ec)) {  // (imread would only warn on stderr)
    why = std::filesystem::exists(path, ec) ? "is not a file" : "does not exist";
  } else if (std::filesystem::file_size(path, ec) > kMaxFileBytes) {
    why = "is larger than 64 MiB";
  } else {
    try {
      image = cv::imread(path.string(), cv::IMREAD_COLOR);
    } catch (const cv::Exception& e) {
      why += " (" + e.err + ")";
    }
    if (static_cast<double>(image.total()) > kMaxPixels) {
      image.release();
      why = "has more than 40 million pixels";
    }
    if (!image.empty()) return image;
  }
  if (path.string() != value) why += " (relative paths in a config file are from its folder)";
  throw ConfigError(fieldPath(w, "image") + " = '" + value + "': '" + path.string() + "' " + why);
}

}  // namespace

cv::Vec3b Poster::shade(double x_m, double y_m, double footprint_m,
                        const cv::Vec3b& backdrop) const {
  if (image_levels.empty()) {
    // The backdrop texture's level (its green spans 40 .. 215) as 0.85 .. 1.15: the poster keeps
    // a little of it, so that stereo block matching still has texture on it.
    const double level = 0.85 + 0.3 * (backdrop[1] - 40) / 175.0;
    const double k = brightness * level;
    return {cv::saturate_cast<uchar>(color_bgr[0] * k), cv::saturate_cast<uchar>(color_bgr[1] * k),
            cv::saturate_cast<uchar>(color_bgr[2] * k)};
  }
  // The finest level whose texels are no smaller than about the pixel's footprint.
  size_t level = 0;
  const cv::Mat& full = image_levels[0];
  double texels = footprint_m * std::max(full.cols / size_m.x(), full.rows / size_m.y());
  while (texels > M_SQRT2 && level + 1 < image_levels.size()) {
    texels /= 2;
    ++level;
  }
  const cv::Mat& image = image_levels[level];
  const double col = (x_m - centre_m.x() + size_m.x() / 2) / size_m.x() * image.cols - 0.5;
  const double row = (y_m - centre_m.y() + size_m.y() / 2) / size_m.y() * image.rows - 0.5;
  const cv::Vec3f c = bilinear(image, col, row) * static_cast<float>(brightness);
  return {cv::saturate_cast<uchar>(c[0]), cv::saturate_cast<uchar>(c[1]),
          cv::saturate_cast<uchar>(c[2])};
}

bool Poster::operator==(const Poster& o) const {
  const bool same_image = image_levels.size() == o.image_levels.size() &&
                          (image_levels.empty() || image_levels[0].data == o.image_levels[0].data);
  return centre_m == o.centre_m && size_m == o.size_m && color_bgr == o.color_bgr &&
         brightness == o.brightness && image_path == o.image_path && same_image;
}

RayBox RayBox::of(const Poster& poster, const CameraView& view, double backdrop_distance_m) {
  RayBox box;
  for (const double sx : {-0.5, 0.5}) {
    for (const double sy : {-0.5, 0.5}) {
      const Eigen::Vector3d c =
          view.toCamera({poster.centre_m.x() + sx * poster.size_m.x(),
                         poster.centre_m.y() + sy * poster.size_m.y(), backdrop_distance_m});
      if (c.z() > 1e-9) {
        box.add(c.x() / c.z(), c.y() / c.z());
      } else {
        box.add(-HUGE_VAL, -HUGE_VAL);
        box.add(HUGE_VAL, HUGE_VAL);
      }
    }
  }
  return box;
}

void RayBox::add(double x, double y) {
  lo_x = std::min(lo_x, x);
  hi_x = std::max(hi_x, x);
  lo_y = std::min(lo_y, y);
  hi_y = std::max(hi_y, y);
}

void RayBox::add(const RayBox& box) {
  add(box.lo_x, box.lo_y);
  add(box.hi_x, box.hi_y);
}

std::vector<Poster> readPosters(const cv::FileNode& list, const std::string& where,
                                const std::string& base_dir) {
  std::vector<Poster> posters;
  if (list.empty()) return posters;
  if (!list.isSeq()) throw ConfigError(fieldPath(where, "posters") + ": must be a list");
  if (list.size() > Poster::kMax) {
    throw ConfigError(fieldPath(where, "posters") + ": at most " + std::to_string(Poster::kMax) +
                      " posters, got " + std::to_string(list.size()));
  }
  int i = 0;
  for (const auto& n : list) {
    const std::string w = fieldPath(where, "posters") + "[" + std::to_string(i++) + "]";
    checkFields(n, {"centre_m", "size_m", "color_bgr", "brightness", "image"}, w);
    Poster p;
    const auto centre = readNumbers(n, "centre_m", 2, w, Range::between(-1e4, 1e4));
    const auto size = readNumbers(n, "size_m", 2, w, Range::above(0).andAtMost(1e4));
    p.centre_m = {centre[0], centre[1]};
    p.size_m = {size[0], size[1]};
    p.brightness = readDouble(n, "brightness", w, 1.0, Range::between(0, 10));
    if (!n["image"].empty()) p.image_path = readString(n, "image", w);
    if (p.image_path.empty()) {
      const auto bgr = readNumbers(n, "color_bgr", 3, w, Range::between(0, 255));
      for (int k = 0; k < 3; ++k) p.color_bgr[k] = static_cast<uchar>(bgr[k]);
    } else if (!n["color_bgr"].empty()) {
      throw ConfigError(w +
                        ": color_bgr and image exclude each other (the photograph is the "
                        "poster's colour)");
    } else {
      p.image_levels = imageLevels(readImage(p.image_path, base_dir, w));
    }
    posters.push_back(std::move(p));
  }
  return posters;
}

}  // namespace ptz::sim
