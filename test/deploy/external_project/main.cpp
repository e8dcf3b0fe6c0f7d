// Uses the installed libraries as a user would: the default rig's geometry, a setpoint encoded
// and sent over LCM (memq://), an image through the JPEG coding. Prints known answers that
// test/deploy/test_install.sh checks.
#include <lcm/lcm-cpp.hpp>

#include <cstdio>
#include <vector>

#include "common/rig.hpp"
#include "common/transport/transport.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"

namespace {
struct Receiver {
  double pan_rad = -1;
  void onSetpoint(const lcm::ReceiveBuffer*, const std::string&,
                  const ptzstereo::ptz_setpoint_t* msg) {
    pan_rad = msg->left.pan_rad;
  }
};
}  // namespace

int main() {
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  std::printf("baseline_m %.3f\n", rig.baselineM());
  const ptz::CameraView view = rig.view(ptz::Side::kLeft, ptz::PtzPose{});
  const Eigen::Vector2d px = view.projectCamera(Eigen::Vector3d(0.2, 0.0, 2.0));
  std::printf("pixel %.3f %.3f\n", px.x(), px.y());

  ptzstereo::ptz_setpoint_t sp{};
  sp.left.pan_rad = 0.25;
  sp.left.zoom = sp.right.zoom = 1;
  std::printf("setpoint_bytes %d\n", sp.getEncodedSize());
  lcm::LCM lcm("memq://");
  if (!lcm.good()) return 1;
  Receiver receiver;
  lcm.subscribe("PTZ_SETPOINT", &Receiver::onSetpoint, &receiver);
  lcm.publish("PTZ_SETPOINT", &sp);
  lcm.handleTimeout(1000);
  std::printf("received_pan_rad %.2f\n", receiver.pan_rad);

  const cv::Mat gray(48, 64, CV_8UC1, cv::Scalar(128));
  const ptzstereo::image_t msg = ptz::encodeImage(gray, ptzstereo::image_t::ENCODING_JPEG, 90);
  cv::Mat decoded;
  std::string error;
  if (!ptz::decodeImage(msg, &decoded, &error)) {
    std::printf("decode failed: %s\n", error.c_str());
    return 1;
  }
  std::printf("jpeg %dx%d\n", decoded.cols, decoded.rows);
  return 0;
}
