// The rig loader: StereoRig::load on a file written from the input. Properties: only ConfigError
// escapes, naming the file; an accepted rig has a size within bounds, an increasing zoom table
// of finite intrinsics with positive focal lengths, a rotation, a finite non-zero baseline, and
// projects a point in front of both cameras to finite pixels at every zoom; saved and loaded
// again it is the same rig.
#include <cmath>

#include "common/config.hpp"
#include "common/rig.hpp"
#include "fuzz/fuzz_support.hpp"

namespace {

bool finite(const ptz::Intrinsics& k) {
  bool ok =
      std::isfinite(k.fx) && std::isfinite(k.fy) && std::isfinite(k.cx) && std::isfinite(k.cy);
  for (double d : k.distortion) ok = ok && std::isfinite(d);
  return ok;
}

bool same(const ptz::CameraSpec& a, const ptz::CameraSpec& b) {
  if (a.width != b.width || a.height != b.height || a.zoom_table.size() != b.zoom_table.size() ||
      a.optical_centre_from_pivot_m != b.optical_centre_from_pivot_m) {
    return false;
  }
  for (size_t i = 0; i < a.zoom_table.size(); ++i) {
    const ptz::ZoomEntry &x = a.zoom_table[i], &y = b.zoom_table[i];
    if (x.zoom != y.zoom || x.intrinsics.fx != y.intrinsics.fx ||
        x.intrinsics.fy != y.intrinsics.fy || x.intrinsics.cx != y.intrinsics.cx ||
        x.intrinsics.cy != y.intrinsics.cy || x.intrinsics.distortion != y.intrinsics.distortion) {
      return false;
    }
  }
  return true;
}

void checkCamera(const ptz::StereoRig& rig, ptz::Side side) {
  const ptz::CameraSpec& c = rig.camera(side);
  const std::string name = ptz::sideName(side);
  FUZZ_CHECK(c.width >= 1 && c.width <= 16384 && c.height >= 1 && c.height <= 16384,
             name + " size " + std::to_string(c.width) + "x" + std::to_string(c.height));
  FUZZ_CHECK(!c.zoom_table.empty(), name + " without a zoom table");
  for (size_t i = 0; i < c.zoom_table.size(); ++i) {
    const ptz::ZoomEntry& e = c.zoom_table[i];
    FUZZ_CHECK(std::isfinite(e.zoom) && e.zoom > 0 && (i == 0 || e.zoom > c.zoom_table[i - 1].zoom),
               name + " zoom_table[" + std::to_string(i) + "] zoom " + std::to_string(e.zoom));
    FUZZ_CHECK(finite(e.intrinsics) && e.intrinsics.fx > 0 && e.intrinsics.fy > 0,
               name + " zoom_table[" + std::to_string(i) + "] intrinsics");
  }
  FUZZ_CHECK(c.optical_centre_from_pivot_m.allFinite(), name + " optical centre");
  for (const ptz::ZoomEntry& e : c.zoom_table) {
    const ptz::CameraView view = rig.view(side, {0.0, 0.0, e.zoom});
    const Eigen::Vector3d ahead = view.position_head_m + view.rotation_head_camera.col(2) * 3.0;
    FUZZ_CHECK(view.project(ahead).allFinite(), name + " projects a point ahead to NaN");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const ptz::fuzz::InputFile file(data, size, "rig.yaml");
  ptz::StereoRig rig;
  try {
    rig = ptz::StereoRig::load(file.path());
  } catch (const ptz::ConfigError& e) {
    FUZZ_CHECK(ptz::fuzz::names(e.what(), file.path()),
               std::string("error without the file: ") + e.what());
    return 0;
  }
  checkCamera(rig, ptz::Side::kLeft);
  checkCamera(rig, ptz::Side::kRight);
  const Eigen::Matrix3d& R = rig.home.R;
  FUZZ_CHECK(R.allFinite() && (R * R.transpose() - Eigen::Matrix3d::Identity()).norm() <= 1e-6 &&
                 R.determinant() > 0,
             "R is not a rotation");
  FUZZ_CHECK(rig.home.T.allFinite() && rig.home.T.norm() > 0, "T not finite or zero");

  const ptz::fuzz::InputFile copy(nullptr, 0, "rig-saved.yaml");
  rig.save(copy.path());
  const ptz::StereoRig again = ptz::StereoRig::load(copy.path());
  FUZZ_CHECK(same(rig.left, again.left) && same(rig.right, again.right) &&
                 rig.home.R == again.home.R && rig.home.T == again.home.T,
             "the rig saved and loaded again differs");
  return 0;
}
