#include "perception/depth_eval/stereo_eval.hpp"

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <limits>

#include "common/config.hpp"

namespace ptz::perception {

cv::Mat loadGroundTruth(const std::string& path, double scale) {
  const cv::Mat raw = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (raw.empty()) throw ConfigError("ground truth '" + path + "': cannot read the image");
  if (!(scale > 0)) throw ConfigError("ground truth '" + path + "': scale must be > 0");
  cv::Mat gt;
  raw.convertTo(gt, CV_32F, 1.0 / scale);
  return gt;
}

cv::Mat nonOccludedMask(const cv::Mat& gl, const cv::Mat& gr) {
  cv::Mat mask(gl.size(), CV_8U, cv::Scalar(0));
  for (int y = 0; y < gl.rows; ++y) {
    const float* dl = gl.ptr<float>(y);
    uint8_t* m = mask.ptr<uint8_t>(y);
    // Without the right view's truth: the largest disparity landing on each right pixel.
    std::vector<float> nearest(static_cast<size_t>(gl.cols), 0.0f);
    if (gr.empty()) {
      for (int x = 0; x < gl.cols; ++x) {
        const int xr = static_cast<int>(std::lround(x - dl[x]));
        if (dl[x] > 0 && xr >= 0) nearest[xr] = std::max(nearest[xr], dl[x]);
      }
    }
    for (int x = 0; x < gl.cols; ++x) {
      if (!(dl[x] > 0)) continue;
      const int xr = static_cast<int>(std::lround(x - dl[x]));
      if (xr < 0) continue;  // outside the right image
      const float other = gr.empty() ? nearest[xr] : gr.ptr<float>(y)[xr];
      const bool seen =
          gr.empty() ? dl[x] >= other - 1.0f : other > 0 && std::abs(other - dl[x]) <= 1.0f;
      if (seen) m[x] = 255;
    }
  }
  return mask;
}

StereoScore scoreDisparity(const cv::Mat& disp, const cv::Mat& gt, const cv::Mat& nonocc,
                           int border, double threshold) {
  StereoScore s;
  int64_t bad_all = 0, bad_nonocc = 0, invalid = 0;
  for (int y = border; y < gt.rows - border; ++y) {
    const float* g = gt.ptr<float>(y);
    const float* d = disp.ptr<float>(y);
    const uint8_t* m = nonocc.ptr<uint8_t>(y);
    for (int x = border; x < gt.cols - border; ++x) {
      if (!(g[x] > 0)) continue;  // unknown ground truth
      const bool valid = std::isfinite(d[x]);
      const bool bad = !valid || std::abs(d[x] - g[x]) > threshold;
      ++s.known_px;
      bad_all += bad;
      invalid += !valid;
      if (m[x]) {
        ++s.nonocc_px;
        bad_nonocc += bad;
      }
    }
  }
  auto frac = [](int64_t a, int64_t b) {
    return b > 0 ? static_cast<double>(a) / b : std::numeric_limits<double>::quiet_NaN();
  };
  s.bad_all = frac(bad_all, s.known_px);
  s.bad_nonocc = frac(bad_nonocc, s.nonocc_px);
  s.invalid_fraction = frac(invalid, s.known_px);
  return s;
}

cv::Mat disparityToFloat(const cv::Mat& d16, int min_disparity_px) {
  cv::Mat out;
  d16.convertTo(out, CV_32F, 1.0 / 16);
  out.setTo(std::numeric_limits<float>::quiet_NaN(), d16 < min_disparity_px * 16);
  return out;
}

}  // namespace ptz::perception
