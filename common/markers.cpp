#include "common/markers.hpp"

#include "common/rig.hpp"

#include <opencv2/aruco.hpp>
#include <opencv2/core.hpp>

#include <cmath>
#include <utility>

namespace ptz {
namespace {

const std::vector<std::pair<std::string, int>>& families() {
  using namespace cv::aruco;
  static const std::vector<std::pair<std::string, int>> kFamilies = {
      {"aruco_4x4_50", DICT_4X4_50},           {"aruco_4x4_100", DICT_4X4_100},
      {"aruco_4x4_250", DICT_4X4_250},         {"aruco_4x4_1000", DICT_4X4_1000},
      {"aruco_5x5_50", DICT_5X5_50},           {"aruco_5x5_100", DICT_5X5_100},
      {"aruco_5x5_250", DICT_5X5_250},         {"aruco_5x5_1000", DICT_5X5_1000},
      {"aruco_6x6_50", DICT_6X6_50},           {"aruco_6x6_100", DICT_6X6_100},
      {"aruco_6x6_250", DICT_6X6_250},         {"aruco_6x6_1000", DICT_6X6_1000},
      {"aruco_7x7_50", DICT_7X7_50},           {"aruco_7x7_100", DICT_7X7_100},
      {"aruco_7x7_250", DICT_7X7_250},         {"aruco_7x7_1000", DICT_7X7_1000},
      {"aruco_original", DICT_ARUCO_ORIGINAL}, {"apriltag_16h5", DICT_APRILTAG_16h5},
      {"apriltag_25h9", DICT_APRILTAG_25h9},   {"apriltag_36h10", DICT_APRILTAG_36h10},
      {"apriltag_36h11", DICT_APRILTAG_36h11},
  };
  return kFamilies;
}

}  // namespace

const std::vector<std::string>& markerFamilies() {
  static const std::vector<std::string> kNames = [] {
    std::vector<std::string> names;
    for (const auto& f : families()) names.push_back(f.first);
    return names;
  }();
  return kNames;
}

int markerFamilyDictionary(const std::string& family) {
  for (const auto& f : families()) {
    if (f.first == family) return f.second;
  }
  return -1;
}

bool markerFamilyUpsideDownInOpenCv(const std::string& family) {
  return family.rfind("apriltag_", 0) == 0;
}

int markerFamilyCount(const std::string& family) {
  const int d = markerFamilyDictionary(family);
  if (d < 0) return 0;
  return cv::aruco::getPredefinedDictionary(d)->bytesList.rows;
}

bool markerCells(const std::string& family, int id, cv::Mat* cells, std::string* why) {
  const int d = markerFamilyDictionary(family);
  if (d < 0) {
    *why = "unknown marker family '" + family + "'";
    return false;
  }
  const cv::Ptr<cv::aruco::Dictionary> dict = cv::aruco::getPredefinedDictionary(d);
  if (id < 0 || id >= dict->bytesList.rows) {
    *why = "marker id " + std::to_string(id) + " is not in " + family + " (0.." +
           std::to_string(dict->bytesList.rows - 1) + ")";
    return false;
  }
  const int n = dict->markerSize;
  const cv::Mat bits = cv::aruco::Dictionary::getBitsFromByteList(dict->bytesList.row(id), n);
  *cells = cv::Mat::zeros(n + 2, n + 2, CV_8UC1);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) cells->at<uchar>(r + 1, c + 1) = bits.at<uchar>(r, c) ? 255 : 0;
  }
  // OpenCV holds the AprilTag codes turned by half a turn against the tags as printed
  // (libapriltag's own images, which its detector's corners follow).
  if (markerFamilyUpsideDownInOpenCv(family)) cv::rotate(*cells, *cells, cv::ROTATE_180);
  return true;
}

Eigen::Matrix3d tagRotation(double yaw_deg, double pitch_deg) {
  return rotationY(yaw_deg * M_PI / 180) * rotationX(pitch_deg * M_PI / 180);
}

}  // namespace ptz
