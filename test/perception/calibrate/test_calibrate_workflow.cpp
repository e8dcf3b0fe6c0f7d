// The real-rig workflow of ptz-calibrate on image files rendered by the simulator: home stereo
// calibration, then a zoom table entry, then the pivot offsets, each step extending the rig file.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <opencv2/imgcodecs.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <utility>

#include "support/board_views.hpp"

namespace {

namespace fs = std::filesystem;

int runCalibrate(const std::string& args) {
  const int status = std::system((std::string(PTZ_CALIBRATE_BIN) + " " + args + " > " +
                                  ::testing::TempDir() + "/ptz_calibrate_workflow.log 2>&1")
                                     .c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string freshDir(const std::string& name) {
  const std::string dir = std::string(::testing::TempDir()) + "/ptz_workflow_" + name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// The numbers of `field`'s data list in a camera_info YAML file.
std::vector<double> yamlNumbers(const std::string& path, const std::string& field) {
  std::ifstream in(path);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t at = text.find(field + ":");
  if (at == std::string::npos) return {};
  const size_t open = text.find('[', at), close = text.find(']', at);
  std::vector<double> numbers;
  std::stringstream list(text.substr(open + 1, close - open - 1));
  for (std::string item; std::getline(list, item, ',');) numbers.push_back(std::stod(item));
  return numbers;
}

class Workflow : public ::testing::Test {
 protected:
  Workflow() {
    truth_.left.optical_centre_from_pivot_m = {0.002, -0.008, 0.045};
    truth_.right.optical_centre_from_pivot_m = {-0.002, -0.006, 0.03};
  }
  // Writes left<index>.png and right<index>.png of the current board at the given poses.
  void writePair(const std::string& dir, int index, const ptz::PtzPose& pose) {
    for (ptz::Side side : {ptz::Side::kLeft, ptz::Side::kRight}) {
      cv::imwrite(dir + "/" + ptz::sideName(side) + std::to_string(100 + index) + ".png",
                  sim_.render(truth_.view(side, pose)));
    }
  }
  // `count` pairs of the board at random poses that both cameras see at `pose`, out to the image
  // corners (where the pivot views put the board).
  void writeRandomPairs(const std::string& dir, const ptz::PtzPose& pose, double distance_m,
                        int count) {
    const std::vector<ptz::CameraView> views = {truth_.view(ptz::Side::kLeft, pose),
                                                truth_.view(ptz::Side::kRight, pose)};
    for (int i = 0; i < count; ++i) {
      ASSERT_TRUE(ptz::test::placeBoard(rng_, views, {0, 0, distance_m},
                                        Eigen::Vector3d(0.6, 0.45, 0.3) * distance_m / 1.3, 0.7,
                                        &sim_.chessboard()));
      writePair(dir, i, pose);
    }
  }

  std::mt19937 rng_{5};
  ptz::StereoRig truth_ = ptz::StereoRig::makeDefault();
  ptz::test::BoardScene sim_;
};

TEST_F(Workflow, HomeThenZoomThenPivotExtendTheRigFile) {
  const std::string home = freshDir("home"), zoom2 = freshDir("zoom2");
  const std::string pivot[2] = {freshDir("pivot_a"), freshDir("pivot_b")};
  const std::string rig_path = home + "/rig.yaml";
  writeRandomPairs(home, {}, 1.3, 16);
  ASSERT_EQ(runCalibrate("--images-dir " + home + " --square-m 0.05 --output " + rig_path), 0);
  // Zoom 2: the board twice as far for the same apparent size.
  writeRandomPairs(zoom2, {0, 0, 2}, 2.6, 12);
  const std::string info = zoom2 + "/camera_info";  // not there yet: made by ptz-calibrate
  ASSERT_EQ(runCalibrate("--mode zoom --zoom 2 --images-dir " + zoom2 + " --square-m 0.05 " +
                         "--rig-file " + rig_path + " --output " + rig_path +
                         " --camera-info-dir " + info),
            0);
  // camera_info at each zoom of the rig: its intrinsics there, and a rectification of its own.
  {
    const ptz::StereoRig zoomed = ptz::StereoRig::load(rig_path);
    for (ptz::Side side : {ptz::Side::kLeft, ptz::Side::kRight}) {
      for (const auto& [zoom, name] : {std::pair<double, std::string>{1.0, ".yaml"},
                                       std::pair<double, std::string>{2.0, "_zoom2.yaml"}}) {
        const std::string path = info + "/" + ptz::sideName(side) + name;
        const std::vector<double> k = yamlNumbers(path, "camera_matrix");
        ASSERT_EQ(k.size(), 9u) << path;
        const ptz::Intrinsics in = zoomed.camera(side).intrinsicsAt(zoom);
        EXPECT_NEAR(k[0], in.fx, 1e-6 * in.fx) << path;
        EXPECT_NEAR(k[4], in.fy, 1e-6 * in.fy) << path;
        EXPECT_NEAR(k[2], in.cx, 1e-6) << path;
        const std::vector<double> p = yamlNumbers(path, "projection_matrix");
        ASSERT_EQ(p.size(), 12u) << path;
        // Rectified at zoom 2, the focal length about doubles (alpha 0 crops a little).
        const double zoom1_p0 = yamlNumbers(info + "/left.yaml", "projection_matrix")[0];
        if (zoom == 2.0) {
          EXPECT_NEAR(p[0] / zoom1_p0, 2.0, 0.2) << path;
        }
      }
    }
    EXPECT_EQ(std::distance(fs::directory_iterator(info), fs::directory_iterator()), 4);
  }
  // Two board stations, turned towards the rig; the board stays put while both cameras pan and
  // tilt. A list per station gives the angles of each pair.
  for (int station = 0; station < 2; ++station) {
    const double x_m = station == 0 ? -0.25 : 0.25;
    sim_.chessboard().centre_head_m = {x_m, 0, 1.4};
    sim_.chessboard().rotation_head_board =
        Eigen::AngleAxisd(x_m, Eigen::Vector3d::UnitY()).toRotationMatrix();
    std::ofstream list(pivot[station] + "/pairs.txt");
    int index = 0;
    for (double pan_deg : {-15.0, -7.5, 0.0, 7.5, 15.0}) {
      for (double tilt_deg : {-10.0, 0.0, 10.0}) {
        writePair(pivot[station], index, {pan_deg * M_PI / 180, tilt_deg * M_PI / 180, 1});
        list << "left" << 100 + index << ".png right" << 100 + index << ".png " << pan_deg << " "
             << tilt_deg << " " << pan_deg << " " << tilt_deg << "\n";
        ++index;
      }
    }
  }
  ASSERT_EQ(
      runCalibrate("--mode pivot --image-list " + pivot[0] + "/pairs.txt," + pivot[1] +
                   "/pairs.txt --square-m 0.05 --rig-file " + rig_path + " --output " + rig_path),
      0);

  const ptz::StereoRig rig = ptz::StereoRig::load(rig_path);
  for (ptz::Side side : {ptz::Side::kLeft, ptz::Side::kRight}) {
    const ptz::CameraSpec& c = rig.camera(side);
    ASSERT_EQ(c.zoom_table.size(), 2u) << ptz::sideName(side);
    EXPECT_EQ(c.zoom_table[1].zoom, 2);
    for (double zoom : {1.0, 1.5, 2.0}) {
      const double truth_fx = truth_.camera(side).intrinsicsAt(zoom).fx;
      EXPECT_NEAR(c.intrinsicsAt(zoom).fx, truth_fx, 0.005 * truth_fx) << "zoom " << zoom;
    }
    const Eigen::Vector3d error =
        c.optical_centre_from_pivot_m - truth_.camera(side).optical_centre_from_pivot_m;
    EXPECT_LT(error.norm(), 0.003) << ptz::sideName(side) << " offset error " << error.transpose();
  }
  EXPECT_NEAR(rig.baselineM(), truth_.baselineM(), 0.005 * truth_.baselineM());
  // Every step's report is still there.
  cv::FileStorage report(rig_path, cv::FileStorage::READ);
  EXPECT_GE(report["calibration"]["views"].size(), 14u);
  EXPECT_FALSE(report["Q"].empty());
  EXPECT_EQ(report["zoom_calibrations"].size(), 1u);
  EXPECT_FALSE(report["pivot_calibration"]["residual_left_m"].empty());
}

TEST_F(Workflow, ExtendingARigOfAnotherImageSizeIsRefused) {
  const std::string dir = freshDir("other_size");
  ptz::StereoRig other = truth_;
  other.left.width = other.right.width = 1280;
  other.left.height = other.right.height = 720;
  other.save(dir + "/rig720.yaml");
  writeRandomPairs(dir, {0, 0, 2}, 2.6, 1);
  EXPECT_EQ(runCalibrate("--mode zoom --zoom 2 --images-dir " + dir + " --square-m 0.05 " +
                         "--rig-file " + dir + "/rig720.yaml --output " + dir + "/out.yaml"),
            2);
  std::ifstream log(std::string(::testing::TempDir()) + "/ptz_calibrate_workflow.log");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("rig720.yaml' is for 1280x720 images, these are 640x480"), std::string::npos)
      << text;
}

}  // namespace
