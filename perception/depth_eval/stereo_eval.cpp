#include "perception/depth_eval/stereo_eval.hpp"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <vector>

#include "common/config.hpp"

namespace ptz::perception {

namespace {

// What a disparity file's header says, read before the image is decoded.
struct Header {
  std::string format;  // "PNG", "PNM", "PFM" or "" (another format: OpenCV decides)
  int width = 0, height = 0, channels = 0;
  int64_t data_offset = 0;  // PFM: where the floats start
};

constexpr int64_t kMaxPixels = int64_t{1} << 27;  // ~134 Mpx: far beyond any disparity map

uint32_t bigEndian32(const unsigned char* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}

// The header tokens of a PNM or PFM file: magic, then numbers separated by whitespace (PNM
// also comments); *end is the offset after the single whitespace that ends the last one.
std::vector<std::string> netpbmTokens(const std::string& head, size_t count, bool comments,
                                      size_t* end) {
  std::vector<std::string> tokens;
  size_t i = 2;
  while (tokens.size() < count && i < head.size()) {
    if (std::isspace(static_cast<unsigned char>(head[i]))) {
      ++i;
    } else if (comments && head[i] == '#') {
      while (i < head.size() && head[i] != '\n') ++i;
    } else {
      size_t j = i;
      while (j < head.size() && !std::isspace(static_cast<unsigned char>(head[j]))) ++j;
      tokens.push_back(head.substr(i, j - i));
      i = j;
    }
  }
  *end = i + 1;  // the one whitespace character after the last token
  return tokens;
}

// A positive whole number of at most 8 digits, or -1.
int dimension(const std::string& token) {
  if (token.empty() || token.size() > 8 ||
      !std::all_of(token.begin(), token.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return -1;
  }
  return std::stoi(token);
}

Header readHeader(const std::string& path, const std::string& where, int64_t file_bytes) {
  std::ifstream in(path, std::ios::binary);
  std::string head(256, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<size_t>(in.gcount()));
  Header h;
  const auto* u = reinterpret_cast<const unsigned char*>(head.data());
  if (head.size() >= 26 && head.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0) {
    if (head.compare(12, 4, "IHDR") != 0) throw ConfigError(where + ": a PNG without its header");
    h.format = "PNG";
    h.width = static_cast<int>(std::min<uint32_t>(bigEndian32(u + 16), INT32_MAX));
    h.height = static_cast<int>(std::min<uint32_t>(bigEndian32(u + 20), INT32_MAX));
    const int colour = u[25];  // 0 grey, 2 RGB, 3 palette (decodes to colour), 4 grey + alpha
    h.channels = colour == 0 ? 1 : colour == 4 ? 2 : colour == 6 ? 4 : 3;
  } else if (head.size() >= 3 && (head.compare(0, 2, "Pf") == 0 || head.compare(0, 2, "PF") == 0)) {
    h.format = "PFM";
    h.channels = head[1] == 'f' ? 1 : 3;
    size_t end = 0;
    const auto t = netpbmTokens(head, 3, false, &end);
    char* scale_end = nullptr;
    const double scale = t.size() == 3 ? std::strtod(t[2].c_str(), &scale_end) : 0;
    h.width = t.size() == 3 ? dimension(t[0]) : -1;
    h.height = t.size() == 3 ? dimension(t[1]) : -1;
    if (h.width <= 0 || h.height <= 0 || !scale_end || *scale_end || !std::isfinite(scale) ||
        scale == 0 || end > head.size()) {
      throw ConfigError(where +
                        ": a PFM header must be 'Pf', width, height and a non-zero scale (its "
                        "sign the byte order)");
    }
    h.data_offset = static_cast<int64_t>(end);
    const int64_t need = int64_t{h.width} * h.height * h.channels * 4;
    if (file_bytes - h.data_offset != need) {
      throw ConfigError(where + ": the PFM header says " + std::to_string(h.width) + "x" +
                        std::to_string(h.height) + " (" + std::to_string(need) +
                        " bytes of data), the file has " +
                        std::to_string(file_bytes - h.data_offset) + ": truncated or not PFM");
    }
  } else if (head.size() >= 3 && head[0] == 'P' && (head[1] == '5' || head[1] == '6')) {
    h.format = "PNM";
    h.channels = head[1] == '5' ? 1 : 3;
    size_t end = 0;
    const auto t = netpbmTokens(head, 3, true, &end);
    h.width = t.size() == 3 ? dimension(t[0]) : -1;
    h.height = t.size() == 3 ? dimension(t[1]) : -1;
    if (h.width <= 0 || h.height <= 0) {
      throw ConfigError(where + ": a PGM/PPM header without a width and height");
    }
  }
  return h;
}

}  // namespace

cv::Mat loadGroundTruth(const std::string& path, double scale, cv::Size expected,
                        std::string* format) {
  const std::string where = "ground truth '" + path + "'";
  if (!(scale >= 0) || !std::isfinite(scale)) throw ConfigError(where + ": scale must be >= 0");
  std::error_code ec;
  const auto file_bytes = static_cast<int64_t>(std::filesystem::file_size(path, ec));
  if (ec) throw ConfigError(where + ": cannot read (" + ec.message() + ")");
  // The header first: a hostile size allocates nothing.
  const Header h = readHeader(path, where, file_bytes);
  if (!h.format.empty()) {
    if (int64_t{h.width} * h.height > kMaxPixels) {
      throw ConfigError(where + ": " + std::to_string(h.width) + "x" + std::to_string(h.height) +
                        " is no disparity map");
    }
    if (h.channels != 1) {
      throw ConfigError(where + ": has " + std::to_string(h.channels) +
                        " channels; a disparity map has one");
    }
    if (!expected.empty() && cv::Size(h.width, h.height) != expected) {
      throw ConfigError(where + ": is " + std::to_string(h.width) + "x" + std::to_string(h.height) +
                        ", the left image " + std::to_string(expected.width) + "x" +
                        std::to_string(expected.height));
    }
  }
  cv::Mat raw;
  try {
    raw = cv::imread(path, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw ConfigError(where + ": cannot decode (" + e.err + ")");
  }
  if (raw.empty()) throw ConfigError(where + ": cannot read the image");
  if (raw.channels() != 1) {
    throw ConfigError(where + ": has " + std::to_string(raw.channels()) +
                      " channels; a disparity map has one");
  }
  if (!expected.empty() && raw.size() != expected) {
    throw ConfigError(where + ": is " + std::to_string(raw.cols) + "x" + std::to_string(raw.rows) +
                      ", the left image " + std::to_string(expected.width) + "x" +
                      std::to_string(expected.height));
  }
  // Each format's own unit when no scale is given: 8-bit and float maps are in px, KITTI's
  // 16-bit maps in 1/256 px.
  const int depth = raw.depth();
  if (depth != CV_8U && depth != CV_16U && depth != CV_32F) {
    throw ConfigError(where + ": must be 8-bit, 16-bit or float (PFM)");
  }
  const double used = scale > 0 ? scale : depth == CV_16U ? 256.0 : 1.0;
  cv::Mat gt;
  raw.convertTo(gt, CV_32F, 1.0 / used);
  // PFM (Middlebury 2014): inf marks unknown; so does anything not a positive disparity.
  cv::patchNaNs(gt, 0);
  const cv::Mat unknown = (gt <= 0) | (gt == std::numeric_limits<float>::infinity());
  gt.setTo(0, unknown);
  if (format) {
    std::ostringstream f;
    f << (depth == CV_8U    ? "8-bit"
          : depth == CV_16U ? "16-bit"
                            : "float")
      << (h.format.empty() ? "" : " " + h.format) << ", scale " << used;
    *format = f.str();
  }
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
