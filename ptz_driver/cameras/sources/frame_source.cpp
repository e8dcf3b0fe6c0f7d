#include "ptz_driver/cameras/sources/frame_source.hpp"

#include <opencv2/core/utility.hpp>

#include <sys/stat.h>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <fstream>

#include "common/config.hpp"

namespace ptz::driver {
namespace {

bool startsWith(const std::string& s, const std::string& prefix) {
  return s.rfind(prefix, 0) == 0;
}

bool isFolder(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t\r") - b + 1);
}

}  // namespace

const char* sourceKindName(SourceKind kind) {
  switch (kind) {
    case SourceKind::kV4l2:
      return "V4L2 camera";
    case SourceKind::kGstreamer:
      return "GStreamer pipeline";
    case SourceKind::kRtsp:
      return "RTSP stream";
    case SourceKind::kVideoFile:
      return "video file";
    case SourceKind::kImageFolder:
      return "image folder";
  }
  return "?";
}

bool SourceSpec::live() const {
  return kind == SourceKind::kV4l2 || kind == SourceKind::kGstreamer || kind == SourceKind::kRtsp;
}

SourceSpec parseSource(const std::string& text, const std::string& what) {
  SourceSpec s;
  s.text = text;
  if (text.empty()) throw ConfigError("parameter '" + what + "' is empty: name a camera or file");
  if (std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); })) {
    s.kind = SourceKind::kV4l2;
    s.device_index = std::atoi(text.c_str());
  } else if (startsWith(text, "/dev/video")) {
    s.kind = SourceKind::kV4l2;
  } else if (startsWith(lower(text), "rtsp://") || startsWith(lower(text), "rtsps://")) {
    s.kind = SourceKind::kRtsp;
    s.pipeline = rtspPipeline(text);
  } else if (text.find("appsink") != std::string::npos) {
    s.kind = SourceKind::kGstreamer;
    s.pipeline = text;
  } else if (text.back() == '/' || isFolder(text)) {
    s.kind = SourceKind::kImageFolder;
  } else {
    s.kind = SourceKind::kVideoFile;
  }
  return s;
}

std::string rtspPipeline(const std::string& url) {
  return "rtspsrc location=" + url +
         " latency=0 ! decodebin ! videoconvert ! appsink drop=true max-buffers=1 sync=false";
}

std::string defaultTimestampsPath(const std::string& source) {
  std::string path = source;
  while (path.size() > 1 && path.back() == '/') path.pop_back();
  return path + ".timestamps";
}

std::vector<int64_t> readTimestamps(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError("timestamps file '" + path + "': cannot open");
  std::vector<int64_t> times;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    const std::string where = "timestamps file '" + path + "', line " + std::to_string(number);
    errno = 0;
    char* end = nullptr;
    const long long v = std::strtoll(t.c_str(), &end, 10);
    if (end == t.c_str() || *end != '\0' || errno == ERANGE) {
      throw ConfigError(where + ": '" + t + "' is not a time in integer microseconds");
    }
    if (!times.empty() && v <= times.back()) {
      throw ConfigError(where + ": " + t + " is not after the previous time " +
                        std::to_string(times.back()) + " (times must increase)");
    }
    times.push_back(v);
  }
  if (times.empty()) throw ConfigError("timestamps file '" + path + "': no times in it");
  return times;
}

std::vector<std::string> listImageFiles(const std::string& folder) {
  static const std::vector<std::string> kExtensions = {".png",  ".jpg", ".jpeg", ".bmp", ".tif",
                                                       ".tiff", ".pgm", ".ppm",  ".pnm", ".webp"};
  std::vector<cv::String> all;
  if (isFolder(folder)) cv::glob(folder, all, false);  // cv::glob sorts by name
  std::vector<std::string> images;
  for (const auto& f : all) {
    const std::string name = lower(f);
    const auto dot = name.rfind('.');
    if (dot == std::string::npos) continue;
    if (std::find(kExtensions.begin(), kExtensions.end(), name.substr(dot)) != kExtensions.end()) {
      images.push_back(f);
    }
  }
  std::sort(images.begin(), images.end());
  if (images.empty()) throw ConfigError("image folder '" + folder + "': no image files in it");
  return images;
}

}  // namespace ptz::driver
