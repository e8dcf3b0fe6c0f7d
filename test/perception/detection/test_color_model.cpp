// Colour detection in real light (issue #32): the relative intensity limit on a dimmed rendered
// ball, the hue gate separating a ball from a poster of a near hue, the colour model's learning,
// forgetting and appearance status, each against known answers.
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <optional>

#include "perception/detection/color_model.hpp"
#include "perception/detection/detector.hpp"
#include "sim/simulator.hpp"
#include "support/detect_scene.hpp"

using ptz::PtzPose;
using ptz::Side;
using ptz::StereoRig;
namespace perception = ptz::perception;
namespace sim = ptz::sim;
using ptz::test::defaultClasses;
using ptz::test::kRed;
using ptz::test::object;

namespace {

// The red ball at p, lit at `brightness` of the scene's light, both cameras straight ahead.
sim::SimFrame renderLit(const StereoRig& rig, const Eigen::Vector3d& p, double brightness) {
  sim::Scene scene;
  scene.objects = {object("red_ball", sim::SceneObject::Shape::kSphere, p, kRed)};
  if (brightness != 1) {
    scene.light.brightness_s = {0.0};
    scene.light.brightness = {brightness};
  }
  sim::Simulator s(rig, scene, ptz::defaultPlantParams(), 2.0, 3);
  return s.capture();
}

// The one region of the red class (none when there are none or several).
std::optional<perception::Region> onlyRed(const std::vector<perception::Region>& regions) {
  std::optional<perception::Region> red;
  for (const auto& r : regions) {
    if (r.class_index != 0) continue;
    if (red) return std::nullopt;
    red = r;
  }
  return red;
}

// A grey image with noise (sigma 2), a poster of `poster_bgr` and a disc of ball_bgr overlapping
// it.
cv::Mat ballOnPoster(const cv::Vec3b& poster_bgr, const cv::Point2d& centre, double radius_px,
                     const cv::Vec3b& ball_bgr = kRed) {
  cv::Mat img(240, 320, CV_8UC3, cv::Scalar(120, 125, 130));
  cv::rectangle(img, cv::Rect(150, 60, 140, 120), cv::Scalar(poster_bgr), cv::FILLED);
  // Drawn at 1/16 px so that its centre is exact.
  cv::circle(img, cv::Point(cvRound(centre.x * 16), cvRound(centre.y * 16)),
             cvRound(radius_px * 16), cv::Scalar(ball_bgr), cv::FILLED, cv::LINE_AA, 4);
  cv::Mat noise(img.size(), CV_16SC3);
  cv::RNG rng(5);
  rng.fill(noise, cv::RNG::NORMAL, 0, 2);
  cv::Mat out;
  img.convertTo(out, CV_16SC3);
  out += noise;
  out.convertTo(img, CV_8UC3);
  return img;
}

// The classes with room for a poster's blob (its area above the red class's default limit), and
// where ballOnPoster's ball is drawn in the hue split's tests.
perception::DetectorParams posterClasses() {
  perception::DetectorParams params = defaultClasses();
  params.classes[0].max_area_px2 = 1e6;
  return params;
}
const cv::Point2d kBallCentre(170.3, 120.6);

}  // namespace

TEST(ColorModel, HueWindowArithmetic) {
  EXPECT_DOUBLE_EQ(perception::hueWindowCentreDeg(340, 20), 0);
  EXPECT_DOUBLE_EQ(perception::hueWindowHalfwidthDeg(340, 20), 20);
  EXPECT_DOUBLE_EQ(perception::hueWindowCentreDeg(90, 150), 120);
  EXPECT_DOUBLE_EQ(perception::hueDifferenceDeg(350, 10), -20);
  EXPECT_DOUBLE_EQ(perception::hueDifferenceDeg(10, 350), 20);
  EXPECT_DOUBLE_EQ(perception::hueDifferenceDeg(180, 0), 180);
}

// A dimmed ball's shaded side falls below intensity_min: its region shrinks to the lit side and
// its centroid moves toward the light. Relative to its own bright pixels, the region is whole.
TEST(ColorModel, ARelativeIntensityLimitKeepsADimmedBallWhole) {
  const StereoRig rig = StereoRig::makeDefault();
  const Eigen::Vector3d p(0.2, 0.1, 2.5);
  const Eigen::Vector2d truth = rig.view(Side::kLeft, PtzPose{}).project(p);
  perception::DetectorParams fixed_limit = defaultClasses();
  fixed_limit.adapt.intensity_min_fraction = 0;
  perception::DetectorParams relative = fixed_limit;
  relative.adapt.intensity_min_fraction = 0.25;
  const perception::Detector fixed_detector(fixed_limit), relative_detector(relative);

  const sim::SimFrame lit = renderLit(rig, p, 1.0);
  const std::optional<perception::Region> lit_region = onlyRed(fixed_detector.detect(lit.left));
  ASSERT_TRUE(lit_region);
  // In full light the relative limit is intensity_min itself: the same region to the bit.
  const std::optional<perception::Region> lit_relative =
      onlyRed(relative_detector.detect(lit.left));
  ASSERT_TRUE(lit_relative);
  EXPECT_EQ(lit_relative->area_px2, lit_region->area_px2);
  EXPECT_EQ(lit_relative->centroid_px, lit_region->centroid_px);

  const sim::SimFrame dim = renderLit(rig, p, 0.3);
  const std::optional<perception::Region> dim_fixed = onlyRed(fixed_detector.detect(dim.left));
  const std::optional<perception::Region> dim_relative =
      onlyRed(relative_detector.detect(dim.left));
  ASSERT_TRUE(dim_relative);
  const double fixed_error = dim_fixed ? std::hypot(dim_fixed->centroid_px.x - truth.x(),
                                                    dim_fixed->centroid_px.y - truth.y())
                                       : 1e9;
  const double relative_error =
      std::hypot(dim_relative->centroid_px.x - truth.x(), dim_relative->centroid_px.y - truth.y());
  EXPECT_GT(fixed_error, 2.0) << "dimmed to 30 % the fixed limit should cut the shaded side";
  EXPECT_LT(relative_error, 1.0);
  EXPECT_GT(dim_relative->area_px2, 0.9 * lit_region->area_px2);
  EXPECT_LT(dim_relative->area_px2, 1.1 * lit_region->area_px2);
  // The colour measured: hue near the red window's centre, intensity about 30 % of the lit one.
  EXPECT_NEAR(dim_relative->colour.intensity / lit_region->colour.intensity, 0.3, 0.05);
  EXPECT_NEAR(dim_relative->colour.hue_offset_deg, 0, 2);
}

TEST(ColorModel, TheRegionsColourIsMeasured) {
  perception::DetectorParams params = defaultClasses();
  const perception::Detector detector(params);
  cv::Mat img(120, 160, CV_8UC3, cv::Scalar(120, 125, 130));
  cv::circle(img, {80, 60}, 20, cv::Scalar(kRed), cv::FILLED, cv::LINE_8);
  const std::optional<perception::Region> r = onlyRed(detector.detect(img));
  ASSERT_TRUE(r);
  // BGR (30, 30, 210): hue 0 (the window 340..20's centre), saturation 1 - 3 * 30 / 270.
  EXPECT_EQ(r->colour.pixels, static_cast<int>(r->area_px2));
  EXPECT_NEAR(r->colour.hue_offset_deg, 0, 1e-9);
  EXPECT_NEAR(r->colour.hue_sigma_deg, 0, 1e-9);
  EXPECT_NEAR(r->colour.saturation, 1 - 90.0 / 270, 1e-9);
  EXPECT_NEAR(r->colour.intensity, 90, 1e-9);
}

// A red ball in front of a red-orange poster (hue 15.6 deg, inside the red window): one blob of
// the red class, not a ball. Before any hue is learnt the blob's hues are two groups, so it is
// split at their threshold: the ball on its own. Gated to the ball's hue, the ball alone.
TEST(ColorModel, AHueGateSeparatesABallFromAPosterOfANearHue) {
  const cv::Vec3b poster(30, 80, 210);
  const cv::Point2d centre = kBallCentre;
  const double radius = 18;
  const cv::Mat img = ballOnPoster(poster, centre, radius);
  perception::DetectorParams params = posterClasses();
  const perception::Detector plain(params);
  // The blob the ball and the poster make fails the circle: only the split finds the ball.
  const cv::Mat blob = plain.mask(img, 0);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(blob.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  ASSERT_EQ(contours.size(), 1u) << "the ball and the poster are one blob of the class";
  EXPECT_GT(cv::contourArea(contours[0]), 140.0 * 120 * 0.95);
  const std::optional<perception::Region> split = onlyRed(plain.detect(img));
  ASSERT_TRUE(split) << "the ball alone: the poster's side is no circle";
  EXPECT_NEAR(split->centroid_px.x, centre.x, 0.5);
  EXPECT_NEAR(split->centroid_px.y, centre.y, 0.5);
  EXPECT_GT(split->area_px2, M_PI * (radius - 1) * (radius - 1));
  EXPECT_LT(split->area_px2, M_PI * (radius + 1) * (radius + 1));
  EXPECT_NEAR(split->colour.hue_offset_deg, 0, 1.5) << "the ball's own hue, not the poster's";

  // The model learns the ball's hue from regions of it alone (its confirmed track's).
  const cv::Mat alone = ballOnPoster(cv::Vec3b(120, 125, 130), centre, radius);
  const std::optional<perception::Region> learned_from = onlyRed(plain.detect(alone));
  ASSERT_TRUE(learned_from);
  params.adapt.follow = true;
  perception::ColorModel model;
  for (int i = 0; i < params.adapt.follow_min_updates; ++i) {
    EXPECT_FALSE(model.gate(i * 0.1, params.adapt).active);
    model.learn(learned_from->colour, i * 0.1, params.adapt);
  }
  const double t = params.adapt.follow_min_updates * 0.1;
  const perception::HueGate gate = model.gate(t, params.adapt);
  ASSERT_TRUE(gate.active);
  EXPECT_NEAR(gate.offset_deg, 0, 1);
  EXPECT_LT(gate.halfwidth_deg, 10);

  perception::Detector gated(params);
  gated.setGates({gate});
  const std::optional<perception::Region> ball = onlyRed(gated.detect(img));
  ASSERT_TRUE(ball);
  EXPECT_NEAR(ball->centroid_px.x, centre.x, 0.3);
  EXPECT_NEAR(ball->centroid_px.y, centre.y, 0.3);
  // The disc, and its rim's pixels blended less than about half with the poster.
  EXPECT_GT(ball->area_px2, M_PI * (radius - 0.5) * (radius - 0.5));
  EXPECT_LT(ball->area_px2, M_PI * (radius + 0.75) * (radius + 0.75));
  // Forgotten after follow_forget_s without a confirmed region: the class's window again.
  EXPECT_FALSE(model.gate(t + params.adapt.follow_forget_s + 0.01, params.adapt).active);
}

// The split by hue takes only what is two groups of hues, each an object: a ball before a poster
// of its own hue, or of a hue too near, stays one blob (no ball); on a grey wall a ball needs none.
TEST(ColorModel, ABlobIsSplitByHueOnlyWhenItsHuesAreTwoGroups) {
  const cv::Point2d centre = kBallCentre;
  const perception::Detector detector(posterClasses());
  auto ballFound = [&](const cv::Vec3b& poster) {
    for (const auto& r : detector.detect(ballOnPoster(poster, centre, 18))) {
      if (r.class_index == 0 &&
          std::hypot(r.centroid_px.x - centre.x, r.centroid_px.y - centre.y) < 1) {
        return true;
      }
    }
    return false;
  };
  EXPECT_FALSE(ballFound(kRed)) << "the same hue: nothing to split";
  // (30, 38, 210): hue 2.3 deg from the ball's, under HueGroups::kMinGapDeg.
  EXPECT_FALSE(ballFound(cv::Vec3b(30, 38, 210))) << "hues too near to be told apart";
  EXPECT_TRUE(ballFound(cv::Vec3b(30, 80, 210)));  // 15.6 deg: two groups
  EXPECT_TRUE(ballFound(cv::Vec3b(120, 125, 130))) << "a grey wall: the ball alone";
}

// Hues either side of the red window's 0 deg: a ball of hue 351 before a poster of 10.6.
TEST(ColorModel, ABlobIsSplitByHueAcrossZeroDegrees) {
  const cv::Point2d centre = kBallCentre;
  const perception::Detector detector(posterClasses());
  const cv::Mat img = ballOnPoster(cv::Vec3b(30, 65, 210), centre, 18, cv::Vec3b(60, 30, 210));
  const auto ball = onlyRed(detector.detect(img));
  ASSERT_TRUE(ball.has_value());
  EXPECT_LT(std::hypot(ball->centroid_px.x - centre.x, ball->centroid_px.y - centre.y), 0.5);
  EXPECT_NEAR(ball->colour.hue_offset_deg, -9, 1.5);  // 351 deg, from the window's centre 0
}

// A part of the image or a window around the blob splits it as the full scan does, to the bit.
TEST(ColorModel, AHueSplitInAPartOrAWindowIsTheFullScans) {
  const cv::Point2d centre = kBallCentre;
  const perception::Detector detector(posterClasses());
  const cv::Mat img = ballOnPoster(cv::Vec3b(30, 80, 210), centre, 18);
  const auto full = onlyRed(detector.detect(img));
  ASSERT_TRUE(full.has_value());
  const int margin = detector.exactMarginPx();
  const cv::Rect part(100, 20, 220, 200);  // reaches the image's right edge
  const auto in_part = onlyRed(detector.detect(img(part).clone(), part.tl()));
  const cv::Rect window(140, 50, 160, 140);
  const cv::Rect crop = cv::Rect(window.x - margin, window.y - margin, window.width + 2 * margin,
                                 window.height + 2 * margin) &
                        cv::Rect(0, 0, img.cols, img.rows);
  bool cut = true;
  const auto in_window =
      onlyRed(detector.detectWindow(img(crop).clone(), crop.tl(), window, img.size(), &cut));
  EXPECT_FALSE(cut);
  for (const auto& got : {in_part, in_window}) {
    ASSERT_TRUE(got.has_value());
    EXPECT_DOUBLE_EQ(got->centroid_px.x, full->centroid_px.x);
    EXPECT_DOUBLE_EQ(got->centroid_px.y, full->centroid_px.y);
    EXPECT_DOUBLE_EQ(got->area_px2, full->area_px2);
    EXPECT_EQ(got->bbox, full->bbox);
  }
}

namespace {
// `count` levels of a normal distribution (mean, sigma in levels), clipped to 0..255.
void addNormal(std::vector<uint8_t>* levels, int count, double mean, double sigma, uint64_t seed) {
  cv::RNG rng(seed);
  for (int i = 0; i < count; ++i) {
    levels->push_back(cv::saturate_cast<uint8_t>(mean + rng.gaussian(sigma)));
  }
}
}  // namespace

// Two groups need a gap, separation and a valley; Otsu's split of one even spread has a ratio of
// gap to pooled deviation of sqrt(12) = 3.46 (halves of width w: gap w, deviation w / sqrt(12)).
TEST(ColorModel, TwoHueGroupsAreTwoObjectsNotOneSpread) {
  const double per_deg = 255.0 / 40;  // the red window, 340 .. 20
  std::vector<uint8_t> two;
  addNormal(&two, 2000, 100, 1 * per_deg, 1);
  addNormal(&two, 20000, 100 + 15 * per_deg, 1 * per_deg, 2);
  const perception::HueGroups g = perception::twoHueGroups(two, per_deg, 300);
  EXPECT_TRUE(g.two);
  EXPECT_NEAR(g.gap_deg, 15, 0.2);
  EXPECT_NEAR(g.pooled_sigma_deg, 1, 0.1);
  EXPECT_GT(g.threshold, 100 + 2 * per_deg);
  EXPECT_LT(g.threshold, 100 + 13 * per_deg);
  EXPECT_LT(g.valley_fraction, 0.01);
  // The smaller group under min_pixels: one object and noise.
  EXPECT_FALSE(perception::twoHueGroups(two, per_deg, 2500).two);

  std::vector<uint8_t> even;
  for (int level = 0; level < 256; ++level) even.insert(even.end(), 100, level);
  const perception::HueGroups e = perception::twoHueGroups(even, per_deg, 300);
  EXPECT_FALSE(e.two);
  EXPECT_NEAR(e.gap_deg / e.pooled_sigma_deg, std::sqrt(12.0), 0.05);
  EXPECT_GT(e.valley_fraction, 0.9);

  std::vector<uint8_t> one;
  addNormal(&one, 20000, 128, 3 * per_deg, 3);
  EXPECT_FALSE(perception::twoHueGroups(one, per_deg, 300).two);

  std::vector<uint8_t> near;  // 4 deg apart, each 0.5 deg wide: a valley, but under kMinGapDeg
  addNormal(&near, 5000, 100, 0.5 * per_deg, 4);
  addNormal(&near, 5000, 100 + 4 * per_deg, 0.5 * per_deg, 5);
  const perception::HueGroups n = perception::twoHueGroups(near, per_deg, 300);
  EXPECT_FALSE(n.two);
  EXPECT_NEAR(n.gap_deg, 4, 0.2);
  EXPECT_LT(n.valley_fraction, 0.1);

  EXPECT_FALSE(perception::twoHueGroups({}, per_deg, 0).two);
  EXPECT_FALSE(perception::twoHueGroups({7}, per_deg, 0).two);
}

TEST(ColorModel, LearnsAtItsRateAndForgets) {
  perception::ColorAdaptParams p;
  p.follow = true;
  p.follow_learning_rate = 0.25;
  p.follow_min_updates = 1;
  perception::ColorModel model;
  perception::RegionColour c;
  c.pixels = 100;
  c.hue_offset_deg = 4;
  c.hue_sigma_deg = 1;
  model.learn(c, 0.0, p);
  EXPECT_DOUBLE_EQ(model.hueOffsetDeg(), 4);
  c.hue_offset_deg = 8;
  model.learn(c, 0.1, p);
  EXPECT_DOUBLE_EQ(model.hueOffsetDeg(), 5);  // 4 + 0.25 (8 - 4)
  // The spread's three sigmas, but never below the floor.
  EXPECT_DOUBLE_EQ(model.gate(0.1, p).halfwidth_deg, p.follow_min_halfwidth_deg);
  c.hue_sigma_deg = 5;
  model.learn(c, 0.2, p);
  EXPECT_DOUBLE_EQ(model.gate(0.2, p).halfwidth_deg, 3 * (1 + 0.25 * 4));
  // A region without pixels (a split disc) teaches nothing.
  model.learn(perception::RegionColour{}, 0.3, p);
  EXPECT_EQ(model.updates(), 3);
  // Back after a gap longer than follow_forget_s: a new object, learned afresh.
  c.hue_offset_deg = -6;
  const double back_s = 0.2 + p.follow_forget_s + 0.1;
  model.learn(c, back_s, p);
  EXPECT_DOUBLE_EQ(model.hueOffsetDeg(), -6);
  EXPECT_EQ(model.updates(), 1);
  EXPECT_TRUE(model.gate(back_s, p).active);
  // Time going back is a new run of the source: nothing of the old one holds.
  EXPECT_FALSE(model.recent(back_s - 1, p));
  EXPECT_FALSE(model.gate(back_s - 1, p).active);
  c.hue_offset_deg = 3;
  model.learn(c, back_s - 1, p);
  EXPECT_DOUBLE_EQ(model.hueOffsetDeg(), 3);
  EXPECT_EQ(model.updates(), 1);
}

TEST(ColorModel, TwoViewsColoursMergeWeightedByTheirPixels) {
  perception::RegionColour a, b;
  a.pixels = 300;
  a.hue_offset_deg = 2;
  a.hue_sigma_deg = 1;
  a.saturation = 0.6;
  a.intensity = 90;
  b.pixels = 100;
  b.hue_offset_deg = 6;
  b.hue_sigma_deg = 1;
  b.saturation = 0.7;
  b.intensity = 70;
  const perception::RegionColour m = perception::mergeColours(a, b);
  EXPECT_EQ(m.pixels, 400);
  EXPECT_DOUBLE_EQ(m.hue_offset_deg, 3);  // 0.75 * 2 + 0.25 * 6
  // Pooled variance: 0.75 (1 + 1^2) + 0.25 (1 + 3^2) = 4.
  EXPECT_NEAR(m.hue_sigma_deg, 2, 1e-12);
  EXPECT_NEAR(m.saturation, 0.625, 1e-12);
  EXPECT_NEAR(m.intensity, 85, 1e-12);
  EXPECT_EQ(perception::mergeColours(a, perception::RegionColour{}).pixels, 300);
}

TEST(ColorModel, SaysWhenTheAppearanceLeavesTheConfiguredRange) {
  const perception::ColorClass red = defaultClasses().classes[0];  // 340..20, saturation >= 0.5
  perception::ColorAdaptParams p;
  p.intensity_min_fraction = 0;
  perception::ColorModel model;
  EXPECT_EQ(model.outOfRange(red, p), "");
  perception::RegionColour c;
  c.pixels = 100;
  c.hue_offset_deg = 5;
  c.hue_sigma_deg = 2;
  c.saturation = 0.7;
  c.saturation_sigma = 0.03;
  c.intensity = 90;
  model.learn(c, 0, p);
  EXPECT_EQ(model.outOfRange(red, p), "");
  c.hue_offset_deg = 15;  // 15 + max(3 * 2, 4) > 20
  model.learn(c, 0.1, p);
  EXPECT_NE(model.outOfRange(red, p).find("hue 15.0 +- 6.0 deg"), std::string::npos)
      << model.outOfRange(red, p);
  c.hue_offset_deg = 0;
  c.saturation = 0.55;  // 0.55 - 2 * 0.03 < 0.5
  model.learn(c, 0.2, p);
  EXPECT_NE(model.outOfRange(red, p).find("saturation 0.55"), std::string::npos);
  c.saturation = 0.7;
  c.intensity = 20;  // below 1.5 intensity_min (15)
  model.learn(c, 0.3, p);
  EXPECT_NE(model.outOfRange(red, p).find("intensity 20"), std::string::npos);
  // Relative intensity reaches down to floor / fraction: 20 is then well inside.
  p.intensity_min_fraction = 0.25;
  p.intensity_floor = 2;
  EXPECT_EQ(model.outOfRange(red, p), "");
}
