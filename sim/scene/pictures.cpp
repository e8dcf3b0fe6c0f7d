#include "sim/scene/pictures.hpp"

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <vector>

namespace ptz::sim {
namespace {

const cv::Scalar kSkin(150, 175, 215), kHair(40, 50, 70), kTrousers(50, 40, 30);

// A limb from a to b, w0 wide at a and w1 at b, rounded at both ends.
void limb(cv::Mat* img, cv::Point2d a, cv::Point2d b, double w0, double w1,
          const cv::Scalar& colour) {
  cv::Point2d d = b - a;
  d /= std::max(1e-9, cv::norm(d));
  const cv::Point2d n(-d.y, d.x);
  const std::vector<cv::Point> quad = {a + n * (w0 / 2), b + n * (w1 / 2), b - n * (w1 / 2),
                                       a - n * (w0 / 2)};
  cv::fillConvexPoly(*img, quad, colour, cv::LINE_AA);
  cv::circle(*img, b, static_cast<int>(std::lround(w1 / 2)), colour, cv::FILLED, cv::LINE_AA);
  cv::circle(*img, a, static_cast<int>(std::lround(w0 / 2)), colour, cv::FILLED, cv::LINE_AA);
}

}  // namespace

cv::Mat facePicture(int side_px) {
  const double s = side_px;
  cv::Mat img(side_px, side_px, CV_8UC3, cv::Scalar(200, 200, 200));
  auto at = [&](double x, double y) { return cv::Point(cvRound(x * s), cvRound(y * s)); };
  auto size = [&](double w, double h) { return cv::Size(cvRound(w * s), cvRound(h * s)); };
  cv::ellipse(img, at(0.5, 0.5), size(0.36, 0.46), 0, 0, 360, kSkin, cv::FILLED, cv::LINE_AA);
  cv::ellipse(img, at(0.5, 0.14), size(0.36, 0.14), 0, 180, 360, kHair, cv::FILLED, cv::LINE_AA);
  for (const double side : {-1.0, 1.0}) {
    const double x = 0.5 + side * 0.15;
    cv::ellipse(img, at(x, 0.36), size(0.09, 0.025), 0, 0, 360, cv::Scalar(50, 60, 80), cv::FILLED,
                cv::LINE_AA);
    cv::ellipse(img, at(x, 0.44), size(0.075, 0.035), 0, 0, 360, cv::Scalar(245, 245, 245),
                cv::FILLED, cv::LINE_AA);
    cv::circle(img, at(x, 0.44), cvRound(0.03 * s), cv::Scalar(40, 30, 30), cv::FILLED,
               cv::LINE_AA);
  }
  cv::ellipse(img, at(0.5, 0.6), size(0.05, 0.03), 0, 0, 360, cv::Scalar(110, 130, 170), cv::FILLED,
              cv::LINE_AA);
  cv::ellipse(img, at(0.5, 0.74), size(0.12, 0.035), 0, 0, 360, cv::Scalar(80, 80, 150), cv::FILLED,
              cv::LINE_AA);
  return img;
}

cv::Mat personPicture(int height_px, double stride, const cv::Vec3b& shirt_bgr) {
  const double h = height_px;
  cv::Mat img(height_px, height_px / 2, CV_8UC4, cv::Scalar(0, 0, 0, 0));
  const cv::Scalar shirt(shirt_bgr[0], shirt_bgr[1], shirt_bgr[2], 255);
  const cv::Scalar trousers = kTrousers + cv::Scalar(0, 0, 0, 255);
  const cv::Scalar skin = kSkin + cv::Scalar(0, 0, 0, 255);
  auto at = [&](double x, double y) { return cv::Point2d(h * (0.25 + x), h * y); };
  // Proportions of an adult: head an eighth of the height, hips at 0.53, shoulders 0.24 wide.
  limb(&img, at(-0.05, 0.53), at(-stride, 0.97), 0.10 * h, 0.06 * h, trousers);
  limb(&img, at(0.05, 0.53), at(stride, 0.97), 0.10 * h, 0.06 * h, trousers);
  const std::vector<cv::Point> torso = {at(-0.11, 0.19), at(0.11, 0.19), at(0.09, 0.55),
                                        at(-0.09, 0.55)};
  cv::fillConvexPoly(img, torso, shirt, cv::LINE_AA);
  for (const double side : {-1.0, 1.0}) {
    cv::circle(img, at(side * 0.095, 0.21), cvRound(0.035 * h), shirt, cv::FILLED, cv::LINE_AA);
    limb(&img, at(side * 0.12, 0.21), at(side * (0.14 + 0.4 * stride), 0.50), 0.06 * h, 0.045 * h,
         shirt);
  }
  limb(&img, at(0, 0.13), at(0, 0.19), 0.05 * h, 0.05 * h, skin);
  cv::ellipse(img, at(0, 0.07), cv::Size(cvRound(0.05 * h), cvRound(0.065 * h)), 0, 0, 360, skin,
              cv::FILLED, cv::LINE_AA);
  return img;
}

}  // namespace ptz::sim
