#include "perception/calibrate/calibration_files.hpp"

#include <opencv2/imgcodecs.hpp>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>

namespace ptz::perception {

namespace fs = std::filesystem;

namespace {

bool isImageFile(const fs::path& path) {
  std::string ext = path.extension().string();
  for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  for (const char* known : {".png", ".jpg", ".jpeg", ".bmp", ".pgm", ".ppm", ".tif", ".tiff"}) {
    if (ext == known) return true;
  }
  return false;
}

}  // namespace

std::vector<ImagePair> pairsFromFolder(const std::string& folder, const std::string& left_prefix,
                                       const std::string& right_prefix) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    throw CalibrationError("image folder '" + folder + "': not a readable folder");
  }
  std::map<std::string, std::string> left, right;  // key: name after the prefix
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    if (!entry.is_regular_file() || !isImageFile(entry.path())) continue;
    const std::string name = entry.path().filename().string();
    if (name.rfind(left_prefix, 0) == 0) left[name.substr(left_prefix.size())] = entry.path();
    if (name.rfind(right_prefix, 0) == 0) right[name.substr(right_prefix.size())] = entry.path();
  }
  std::string unmatched;
  for (const auto& [key, path] : left) {
    if (!right.count(key)) unmatched += "\n  " + path + " (no " + right_prefix + key + ")";
  }
  for (const auto& [key, path] : right) {
    if (!left.count(key)) unmatched += "\n  " + path + " (no " + left_prefix + key + ")";
  }
  if (!unmatched.empty()) {
    throw CalibrationError("image folder '" + folder + "': left/right count mismatch (" +
                           std::to_string(left.size()) + " " + left_prefix + "*, " +
                           std::to_string(right.size()) + " " + right_prefix +
                           "*); files without a partner:" + unmatched);
  }
  if (left.empty()) {
    throw CalibrationError("image folder '" + folder + "': no files named " + left_prefix +
                           "* and " + right_prefix + "*");
  }
  std::vector<ImagePair> pairs;
  for (const auto& [key, path] : left) pairs.push_back({path, right[key]});
  return pairs;
}

std::vector<ImagePair> pairsFromList(const std::string& list_path) {
  std::ifstream in(list_path);
  if (!in) throw CalibrationError("image list '" + list_path + "': cannot open");
  const fs::path base = fs::path(list_path).parent_path();
  std::vector<ImagePair> pairs;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    line = line.substr(0, line.find('#'));
    std::istringstream words(line);
    std::string l, r;
    if (!(words >> l)) continue;
    const std::string where = "image list '" + list_path + "', line " + std::to_string(number);
    if (!(words >> r)) {
      throw CalibrationError(where +
                             ": expected 'left_path right_path' (left/right count mismatch)");
    }
    ImagePair pair{(base / l).string(), (base / r).string()};
    std::vector<double> angles_deg;
    for (double a; words >> a;) angles_deg.push_back(a);
    if (!words.eof() || (angles_deg.size() != 0 && angles_deg.size() != 4)) {
      throw CalibrationError(where +
                             ": after the two paths expect nothing or 'left_pan_deg "
                             "left_tilt_deg right_pan_deg right_tilt_deg'");
    }
    if (angles_deg.size() == 4) {
      for (double& a : angles_deg) a *= M_PI / 180;
      pair.left_pan_tilt_rad = {angles_deg[0], angles_deg[1]};
      pair.right_pan_tilt_rad = {angles_deg[2], angles_deg[3]};
    }
    pairs.push_back(pair);
  }
  if (pairs.empty()) throw CalibrationError("image list '" + list_path + "': no pairs");
  return pairs;
}

namespace {

struct Found {
  cv::Size size;
  bool ok = false;
  std::vector<cv::Point2f> corners;
};

}  // namespace

DetectedViews detectPairs(const std::vector<ImagePair>& pairs, const BoardSpec& board,
                          const Progress& progress) {
  std::vector<std::string> paths;
  for (const auto& p : pairs) {
    paths.push_back(p.left_path);
    paths.push_back(p.right_path);
  }
  std::vector<Found> found(paths.size());
  std::mutex progress_mutex;
  size_t done = 0;
  cv::parallel_for_(cv::Range(0, static_cast<int>(paths.size())), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) {
      const cv::Mat image = cv::imread(paths[static_cast<size_t>(i)], cv::IMREAD_GRAYSCALE);
      Found& f = found[static_cast<size_t>(i)];
      f.size = image.size();
      if (!image.empty()) f.ok = findCorners(image, board, &f.corners);
      if (progress) {
        const std::lock_guard<std::mutex> lock(progress_mutex);
        ++done;
        const std::string& path = paths[static_cast<size_t>(i)];
        progress("image " + std::to_string(done) + "/" + std::to_string(paths.size()) + " (" +
                     path.substr(path.find_last_of('/') + 1) + "): " +
                     (image.empty() ? std::string("unreadable")
                      : f.ok        ? std::to_string(f.corners.size()) + " corners found"
                                    : std::string("no board")),
                 false);
      }
    }
  });
  std::string unreadable;
  for (size_t i = 0; i < paths.size(); ++i) {
    if (found[i].size.area() == 0) unreadable += "\n  " + paths[i];
  }
  if (!unreadable.empty()) {
    throw CalibrationError("cannot read these images (missing, not an image, or truncated):" +
                           unreadable);
  }
  DetectedViews out;
  out.image_size = found.front().size;
  std::string other_size;
  for (size_t i = 0; i < paths.size(); ++i) {
    if (found[i].size != out.image_size) {
      other_size += "\n  " + paths[i] + " is " + std::to_string(found[i].size.width) + "x" +
                    std::to_string(found[i].size.height);
    }
  }
  if (!other_size.empty()) {
    throw CalibrationError("images of different sizes: " + paths.front() + " is " +
                           std::to_string(out.image_size.width) + "x" +
                           std::to_string(out.image_size.height) + " but" + other_size);
  }
  int any = 0;
  for (size_t i = 0; i < pairs.size(); ++i) {
    Found& l = found[2 * i];
    Found& r = found[2 * i + 1];
    any += (l.ok ? 1 : 0) + (r.ok ? 1 : 0);
    if (l.ok) {
      out.left_px.push_back(l.corners);
      out.left_pan_tilt_rad.push_back(pairs[i].left_pan_tilt_rad);
    }
    if (r.ok) {
      out.right_px.push_back(r.corners);
      out.right_pan_tilt_rad.push_back(pairs[i].right_pan_tilt_rad);
    }
    if (l.ok && r.ok) {
      alignCornerOrder(l.corners, &r.corners);
      out.views.push_back({pairs[i].left_path, pairs[i].right_path, l.corners, r.corners});
    } else {
      out.skipped.push_back(pairs[i].left_path + " / " + pairs[i].right_path +
                            ": board not found in " +
                            (l.ok   ? "the right"
                             : r.ok ? "the left"
                                    : "either") +
                            " image");
    }
  }
  if (any == 0) {
    throw CalibrationError("no chessboard of " + std::to_string(board.inner_cols) + "x" +
                           std::to_string(board.inner_rows) +
                           " inner corners found in any of the " + std::to_string(paths.size()) +
                           " images (" + paths.front() + " ... " + paths.back() +
                           "): check the board size (--board-cols, --board-rows count inner "
                           "corners, one less than the squares)");
  }
  return out;
}

}  // namespace ptz::perception
