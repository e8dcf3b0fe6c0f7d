// Faces and people on frames rendered by the simulator (JPEG, sensor noise): OpenCV's HOG people
// detector finds the simulator's walking figure, Debian opencv-data's frontal-face cascade its
// printed face; each is ranged in the right view along its epipolar line and compared with its
// true position. A class whose height does not fit what is seen is refused; windows around a track
// find it again. Then the detectors on real photographs (Debian opencv-doc's samples).
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <tuple>
#include <vector>

#include "perception/people/people_scan.hpp"
#include "sim/scene/pictures.hpp"
#include "sim/simulator.hpp"
#include "support/render_aimed.hpp"

namespace perception = ptz::perception;
namespace sim = ptz::sim;
using ptz::Side;

namespace {

sim::SceneObject person(const Eigen::Vector3d& centre) {
  sim::SceneObject o;
  o.name = "walker";
  o.class_name = "person";
  o.shape = sim::SceneObject::Shape::kPerson;
  o.height_m = 1.75;
  o.color_bgr = {140, 70, 40};
  o.trajectory.centre_m = centre;
  return o;
}

sim::SceneObject faceBox(const Eigen::Vector3d& centre) {
  sim::SceneObject o;
  o.name = "head";
  o.class_name = "face";
  o.shape = sim::SceneObject::Shape::kBox;
  o.half_extents_m = {0.11, 0.11, 0.005};
  o.color_bgr = {235, 235, 235};
  o.trajectory.centre_m = centre;
  sim::SceneTag print;
  print.family.clear();
  print.id = -1;
  print.size_m = 0.22;
  print.centre_m = {0, 0, -0.005};
  print.picture = sim::facePicture(256);
  o.tags = {print};
  return o;
}

std::vector<perception::PeopleClass> classes() {
  perception::PeopleClass p = perception::defaultPeopleClass("hog");
  p.name = "person";
  perception::PeopleClass f = perception::defaultPeopleClass("cascade");
  f.name = "face";
  return {p, f};
}

// Every strip of one frame scanned once (for each class): the objects found, by class.
std::vector<perception::PatchObject> scanAll(
    perception::PeopleScanner* s, const ptz::test::AimedFrame& f,
    const std::vector<ptz::perception::Track>& tracks = {}) {
  ptz::test::FrameCrops c;
  c.images[0] = f.left;
  c.images[1] = f.right;
  std::vector<perception::PatchObject> all;
  // One class's strip a frame: every strip of both classes.
  for (int k = 0; k < 2 * perception::PeopleScanParams{}.strips; ++k) {
    std::vector<perception::PatchObject> objects;
    std::string why;
    EXPECT_TRUE(s->scan(tracks, 0, f.left_view, f.right_view, c.crop, &objects, &why)) << why;
    for (const auto& o : objects) {
      const bool seen = std::any_of(all.begin(), all.end(), [&](const auto& a) {
        return a.class_name == o.class_name && (a.position_m - o.position_m).norm() < 0.2;
      });
      if (!seen) all.push_back(o);
    }
  }
  return all;
}

}  // namespace

TEST(People, FindsTheFigureAndTheFaceAndRangesThem) {
  sim::Scene scene;
  scene.objects = {person({-0.6, 0.2, 3.5}), faceBox({0.5, -0.1, 1.5})};
  const ptz::test::AimedFrame f = ptz::test::renderAtHome(scene, 0.3);
  perception::PeopleScanner scanner(classes(), {}, {f.left.cols, f.left.rows});
  const auto found = scanAll(&scanner, f);
  ASSERT_EQ(found.size(), 2u);
  for (const auto& o : found) {
    const sim::SceneObject& truth = scene.objects[o.class_name == "person" ? 0 : 1];
    const Eigen::Vector3d at = truth.trajectory.centre_m;
    // The figure: within 1 % of its range (its box's centre, measured once: 0.7 %); the face on
    // its print, 5 mm before the box's centre: within 0.5 % and that.
    const double tolerance_m =
        o.class_name == "person" ? 0.01 * at.norm() : 0.005 * at.norm() + 0.005;
    EXPECT_LT((o.position_m - at).norm(), tolerance_m) << o.class_name;
    // Ranged by the right view (the figure's or the face's own disparity, not the backdrop's).
    EXPECT_NEAR(o.position_m.z(), at.z(), 0.005 * at.z()) << o.class_name;
    EXPECT_GT(o.score[1], 0.8) << o.class_name;
    EXPECT_EQ(o.radius_m, (o.class_name == "person" ? 1.75 : 0.22) / 2);
  }
  EXPECT_EQ(scanner.counts().at("people_strips_scanned"),
            2 * perception::PeopleScanParams{}.strips);

  // A class told the figure is a child's height: its boxes do not fit their range, refused.
  std::vector<perception::PeopleClass> small = classes();
  small[0].height_m = 1.0;
  perception::PeopleScanner wrong(small, {}, {f.left.cols, f.left.rows});
  const auto none = scanAll(&wrong, f);
  EXPECT_EQ(std::count_if(none.begin(), none.end(),
                          [](const auto& o) { return o.class_name == "person"; }),
            0);
  EXPECT_GT(wrong.counts().at("people_refused_size"), 0);
}

// ptz-detect's HOG, its levels on two threads of its own, finds exactly OpenCV's boxes with their
// weights: on the simulator's figure (rendered, so the test always runs), at a window's stride and
// at a strip's.
TEST(People, HogOnTwoThreadsIsOpenCvsDetectMultiScale) {
  sim::Scene scene;
  scene.objects = {person({-0.6, 0.2, 3.5}), person({0.7, 0.25, 4.5})};
  const ptz::test::AimedFrame f = ptz::test::renderAtHome(scene, 0.3);
  cv::Mat grey, big;
  cv::cvtColor(f.left, grey, cv::COLOR_BGR2GRAY);
  cv::resize(grey, big, cv::Size(), 1.5, 1.5);
  cv::HOGDescriptor hog;
  hog.setSVMDetector(cv::HOGDescriptor::getDefaultPeopleDetector());
  const auto sorted = [](const std::vector<cv::Rect>& r, const std::vector<double>& w) {
    std::vector<std::tuple<int, int, int, int, double>> v;
    for (size_t i = 0; i < r.size(); ++i) {
      v.emplace_back(r[i].x, r[i].y, r[i].width, r[i].height, w.at(i));
    }
    std::sort(v.begin(), v.end());
    return v;
  };
  for (const cv::Size stride : {cv::Size(4, 4), cv::Size(8, 8)}) {
    std::vector<cv::Rect> theirs, ours;
    std::vector<double> their_weights, our_weights;
    hog.detectMultiScale(big, theirs, their_weights, 0, stride, cv::Size(), 1.05, 2);
    perception::hogMultiScale(hog, big, stride, 1.05, 2, &ours, &our_weights);
    EXPECT_GE(theirs.size(), 2u) << "stride " << stride;  // both figures
    ASSERT_EQ(ours.size(), theirs.size()) << "stride " << stride;
    ASSERT_EQ(our_weights.size(), their_weights.size());
    EXPECT_EQ(sorted(ours, our_weights), sorted(theirs, their_weights)) << "stride " << stride;
  }
}

TEST(People, ATrackedFigureIsFoundInItsWindowEveryFrame) {
  // Walking across at 1.5 m/s, 3 m away: the track's window finds it in each frame, strips or not.
  sim::Scene scene;
  scene.objects = {person({0, 0.2, 3.0})};
  scene.objects[0].trajectory.type = sim::Trajectory::Type::kLine;
  scene.objects[0].trajectory.amplitude_m = {1.2, 0, 0};
  scene.objects[0].trajectory.period_s = 2 * M_PI * 1.2 / 1.5;  // 1.5 m/s through the centre
  perception::PeopleScanParams params;
  params.strips = 64;  // the strip alone would seldom see it whole
  perception::PeopleScanner scanner(classes(), params, {640, 480});
  int found = 0;
  for (int k = 0; k < 10; ++k) {
    const double t = k / 30.0;
    const ptz::test::AimedFrame f = ptz::test::renderAtHome(scene, t);
    const Eigen::Vector3d truth = scene.objects[0].trajectory.position(t);
    ptz::test::FrameCrops c;
    c.images[0] = f.left;
    c.images[1] = f.right;
    std::vector<perception::PatchObject> objects;
    std::string why;
    // A track where it is, 5 cm off (10 cm spread): what the tracker would predict.
    std::vector<perception::Track> tracks(1);
    tracks[0].class_name = "person";
    tracks[0].x.head<3>() = truth + Eigen::Vector3d(0.05, 0, 0);
    tracks[0].P = Eigen::Matrix<double, 9, 9>::Identity() * 0.01;
    tracks[0].t_s = t;
    ASSERT_TRUE(scanner.scan(tracks, t, f.left_view, f.right_view, c.crop, &objects, &why)) << why;
    // Within 2 % of its range (measured: 0.6-1.6 %; a box's centre jitters by a few pixels).
    for (const auto& o : objects) {
      if (o.class_name == "person" && (o.position_m - truth).norm() < 0.02 * truth.norm()) ++found;
    }
  }
  EXPECT_EQ(found, 10);
  EXPECT_EQ(scanner.counts().at("people_windows"), 10);
}

// Debian opencv-doc's sample photographs (installed by scripts/test): a footballer's face
// (messi5.jpg) and the pedestrians of vtest.avi, through the same detectors.
TEST(People, RealPhotographs) {
  const std::string dir = "/usr/share/doc/opencv-doc/examples/data/";
  if (!std::filesystem::exists(dir + "messi5.jpg") || !std::filesystem::exists(dir + "vtest.avi")) {
    GTEST_SKIP() << dir << " has no messi5.jpg or vtest.avi (Debian: apt-get install opencv-doc)";
  }
  perception::PeopleClass face = perception::defaultPeopleClass("cascade");
  cv::CascadeClassifier cascade;
  perception::loadCascade(face.cascade, &cascade);
  cv::Mat grey = cv::imread(dir + "messi5.jpg", cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(grey.empty());
  std::vector<cv::Rect> faces;
  cascade.detectMultiScale(grey, faces, 1.1, face.min_neighbors, 0, cv::Size(24, 24));
  // Where the faces and people are: read off the pictures by eye (boxes drawn and looked at).
  const auto near = [](const std::vector<cv::Rect>& found, cv::Point2d centre, double min_h,
                       double max_h) {
    return std::any_of(found.begin(), found.end(), [&](const cv::Rect& r) {
      const cv::Point2d c(r.x + r.width / 2.0, r.y + r.height / 2.0);
      return cv::norm(c - centre) < 15 && r.height >= min_h && r.height <= max_h;
    });
  };
  EXPECT_TRUE(near(faces, {245, 112}, 30, 45)) << faces.size() << " faces";
  cv::VideoCapture video(dir + "vtest.avi");
  ASSERT_TRUE(video.isOpened());
  cv::Mat frame;
  for (int i = 0; i < 30; ++i) video >> frame;
  ASSERT_FALSE(frame.empty());
  // Its walkers are 100-140 px tall: HOG's boxes are 128 px at the least, so the frame is doubled
  // (as the window of a track would be scaled).
  cv::HOGDescriptor hog;
  hog.setSVMDetector(cv::HOGDescriptor::getDefaultPeopleDetector());
  std::vector<cv::Rect> people;
  std::vector<double> weights;
  cv::Mat big;
  cv::resize(frame, big, cv::Size(), 2, 2);
  hog.detectMultiScale(big, people, weights, 0, cv::Size(8, 8), cv::Size(), 1.05, 2);
  for (auto& r : people) r = cv::Rect(r.x / 2, r.y / 2, r.width / 2, r.height / 2);
  // Two pairs of walkers, frame 30: each of the four found.
  for (const cv::Point2d walker : {cv::Point2d(390, 227), cv::Point2d(413, 264),
                                   cv::Point2d(653, 305), cv::Point2d(689, 297)}) {
    EXPECT_TRUE(near(people, walker, 90, 150)) << walker;
  }
}
