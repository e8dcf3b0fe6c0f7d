// What the detection tests share: the project's detector classes and simulated objects of them.
#pragma once

#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "perception/detection/detector.hpp"
#include "perception/detection/windows.hpp"
#include "perception/jpeg/jpeg_window.hpp"
#include "sim/scene/scene.hpp"

namespace ptz::test {

// config/detect_default.yaml's classes.
inline perception::DetectorParams defaultClasses() {
  cv::FileStorage fs(PTZ_SOURCE_DIR "/config/detect_default.yaml", cv::FileStorage::READ);
  return perception::DetectorParams::fromConfig(fs["classes"], "detect_default.yaml");
}

// A ball of radius 0.1 m or a cube of half extent 0.09 m, of a class, named as its class.
inline sim::SceneObject object(const std::string& cls, sim::SceneObject::Shape shape,
                               const Eigen::Vector3d& centre, cv::Vec3b bgr) {
  sim::SceneObject o;
  o.name = cls;
  o.class_name = cls;
  o.shape = shape;
  o.radius_m = 0.1;
  o.half_extents_m = {0.09, 0.09, 0.09};
  o.color_bgr = bgr;
  o.trajectory.centre_m = centre;
  return o;
}

// A JPEG (of `size`, kept alive by the caller) as ptz-detect reads it: parts by
// decodeJpegWindows, reduced rows by decodeJpegReducedRows.
inline perception::ImagePixels jpegPixels(const std::vector<uint8_t>& jpeg, cv::Size size) {
  return {[&jpeg, size](const std::vector<cv::Rect>& rects, std::vector<cv::Mat>* parts,
                        std::string* why) {
            return perception::decodeJpegWindows(jpeg.data(), jpeg.size(), size.width, size.height,
                                                 rects, parts, why);
          },
          [&jpeg, size](int scale, int row0, int row1, cv::Mat* reduced, std::string* why) {
            return perception::decodeJpegReducedRows(
                perception::JpegRestartIndex(jpeg.data(), jpeg.size()), size.width, size.height,
                scale, row0, row1, reduced, why);
          }};
}

// Colours the default classes take: red_ball, green_box.
inline const cv::Vec3b kRed(30, 30, 210), kGreen(40, 170, 40);

}  // namespace ptz::test
