// Splitting blobs of overlapping balls into discs (disc_split.hpp), on drawn discs whose centres
// and radii are known: two side by side, one mostly hidden behind another, three in a row; and
// what must not split: one ball, one cut by an object of another colour, a square.
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <vector>

#include "perception/detection/detector.hpp"
#include "perception/detection/disc_split.hpp"

namespace ptz::perception {
namespace {

struct Blob {
  std::vector<cv::Point> contour;
  cv::Mat mask;  // the blob alone, in its box
  cv::Point origin;
};

// The largest outer contour of a drawn mask, and the mask cut to its box.
Blob blobOf(const cv::Mat& drawn) {
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(drawn.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  EXPECT_FALSE(contours.empty());
  size_t best = 0;
  for (size_t i = 0; i < contours.size(); ++i) {
    if (cv::contourArea(contours[i]) > cv::contourArea(contours[best])) best = i;
  }
  const cv::Rect box = cv::boundingRect(contours[best]);
  return {contours[best], drawn(box).clone(), box.tl()};
}

// Discs drawn at sub-pixel centres (shift 4: 1/16 px), filled.
cv::Mat discs(const std::vector<cv::Vec3d>& xyr, cv::Size size = {640, 480}) {
  cv::Mat m(size, CV_8U, cv::Scalar(0));
  for (const auto& d : xyr) {
    cv::circle(m, cv::Point(cvRound(d[0] * 16), cvRound(d[1] * 16)), cvRound(d[2] * 16),
               cv::Scalar(255), cv::FILLED, cv::LINE_8, 4);
  }
  return m;
}

// The found disc nearest (x, y): its centre within tol_px of it and its radius within tol_px.
void expectDisc(const std::vector<Disc>& found, cv::Vec3d truth, double tol_px) {
  const Disc* best = nullptr;
  for (const auto& d : found) {
    if (!best || std::hypot(d.centre_px.x - truth[0], d.centre_px.y - truth[1]) <
                     std::hypot(best->centre_px.x - truth[0], best->centre_px.y - truth[1])) {
      best = &d;
    }
  }
  ASSERT_NE(best, nullptr);
  EXPECT_NEAR(best->centre_px.x, truth[0], tol_px);
  EXPECT_NEAR(best->centre_px.y, truth[1], tol_px);
  EXPECT_NEAR(best->radius_px, truth[2], tol_px);
}

TEST(DiscSplit, CircleThroughThreePointsAndLeastSquaresFit) {
  cv::Point2d c;
  double r = 0;
  ASSERT_TRUE(circleThrough({13, 2}, {3, 12}, {-7, 2}, &c, &r));
  EXPECT_NEAR(c.x, 3, 1e-9);
  EXPECT_NEAR(c.y, 2, 1e-9);
  EXPECT_NEAR(r, 10, 1e-9);
  EXPECT_FALSE(circleThrough({0, 0}, {1, 1}, {2, 2}, &c, &r));  // on a line
  std::vector<cv::Point2d> arc;
  for (int k = 0; k < 20; ++k) {
    const double a = 0.1 * k;  // a third of the circle
    arc.emplace_back(100 + 25 * std::cos(a), 50 + 25 * std::sin(a));
  }
  ASSERT_TRUE(fitCircle(arc, &c, &r));
  EXPECT_NEAR(c.x, 100, 1e-6);
  EXPECT_NEAR(c.y, 50, 1e-6);
  EXPECT_NEAR(r, 25, 1e-6);
}

TEST(DiscSplit, TwoBallsSideBySideGiveTwoDiscs) {
  const cv::Vec3d a(300.3, 240.6, 30), b(338.7, 236.2, 24);
  const Blob blob = blobOf(discs({a, b}));
  const std::vector<Disc> found = splitDiscs(blob.contour, blob.mask, blob.origin, 4);
  ASSERT_EQ(found.size(), 2u);
  expectDisc(found, a, 0.7);
  expectDisc(found, b, 0.7);
}

TEST(DiscSplit, ABallMostlyHiddenBehindAnotherLeavesTheFrontDiscWhole) {
  // The front ball's disc is drawn last: the back one shows a crescent of 7 px beside it.
  const cv::Vec3d front(320.2, 239.7, 29), back(334.0, 236.0, 24);
  const Blob blob = blobOf(discs({back, front}));
  const std::vector<Disc> found = splitDiscs(blob.contour, blob.mask, blob.origin, 4);
  ASSERT_GE(found.size(), 1u);
  expectDisc(found, front, 0.7);
}

TEST(DiscSplit, ThreeBallsInARow) {
  const cv::Vec3d a(200, 200, 20), b(232, 204, 22), c(268, 198, 18);
  const Blob blob = blobOf(discs({a, b, c}));
  const std::vector<Disc> found = splitDiscs(blob.contour, blob.mask, blob.origin, 4);
  ASSERT_EQ(found.size(), 3u);
  for (const auto& d : {a, b, c}) expectDisc(found, d, 0.8);
}

TEST(DiscSplit, OneBallIsOneDiscThatExplainsAllOfIt) {
  const cv::Vec3d a(320.4, 240.3, 26);
  const Blob blob = blobOf(discs({a}));
  double covered = 0;
  const std::vector<Disc> found = splitDiscs(blob.contour, blob.mask, blob.origin, 4, {}, &covered);
  ASSERT_EQ(found.size(), 1u);
  expectDisc(found, a, 0.6);
  EXPECT_GT(covered, 0.99);
}

TEST(DiscSplit, ABallCutByAnotherColourAndASquareGiveNoDisc) {
  // A third of the ball hidden by a box of another class: its disc is not in the region.
  cv::Mat cut = discs({{320, 240, 30}});
  cv::rectangle(cut, cv::Rect(330, 180, 60, 120), cv::Scalar(0), cv::FILLED);
  Blob blob = blobOf(cut);
  for (const auto& d : splitDiscs(blob.contour, blob.mask, blob.origin, 4)) {
    ADD_FAILURE() << d.centre_px << " r " << d.radius_px << " arc " << d.arc_fraction;
  }
  cv::Mat square(480, 640, CV_8U, cv::Scalar(0));
  cv::rectangle(square, cv::Rect(300, 200, 50, 50), cv::Scalar(255), cv::FILLED);
  blob = blobOf(square);
  EXPECT_TRUE(splitDiscs(blob.contour, blob.mask, blob.origin, 4).empty());
}

TEST(DiscSplit, TheSameBlobGivesTheSameDiscs) {
  const Blob blob = blobOf(discs({{300, 240, 30}, {345, 240, 26}}));
  const std::vector<Disc> a = splitDiscs(blob.contour, blob.mask, blob.origin, 4);
  const std::vector<Disc> b = splitDiscs(blob.contour, blob.mask, blob.origin, 4);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].centre_px, b[i].centre_px);
    EXPECT_EQ(a[i].radius_px, b[i].radius_px);
  }
}

}  // namespace
}  // namespace ptz::perception
