// OnvifHead against the real ONVIF camera emulator served over real HTTP (ptz-sim's server,
// ptz_sim_onvif) on 127.0.0.1: the start-up (profile, the camera's clock 37 s off), moves to a
// known angle, GetStatus back, a wrong password, a camera that stops answering and comes back,
// the confirmed stop, the continuous mode. Conditions waited on with deadlines, never sleeps.
#include <gtest/gtest.h>
#include <poll.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <fstream>
#include <functional>
#include <mutex>

#include "common/measure.hpp"
#include "common/plant.hpp"
#include "ptz_driver/heads/head_factory.hpp"
#include "ptz_driver/heads/onvif/head/onvif_head.hpp"
#include "sim/onvif/onvif_server.hpp"
#include "support/error_of.hpp"

namespace {

using ptz::PtzPose;
using ptz::driver::OnvifHead;
using ptz::driver::OnvifHeadSettings;
using ptz::driver::OnvifModel;
using ptz::driver::OnvifMoveMode;

const std::string kGeneric = PTZ_SOURCE_DIR "/config/onvif/generic_ptz.yaml";
constexpr double kDeadlineS = 15;  // generous: the machine is loaded

double nowS() {
  return ptz::wallUtime() * 1e-6;
}

// Two emulated cameras whose plant follows their setpoint at once (GetStatus reads back exactly
// what was commanded); pause() holds the server's loop, so the cameras stop answering.
class Cameras {
 public:
  explicit Cameras(const std::string& password, double clock_offset_s = 0, bool http_digest = false,
                   const std::string& model = kGeneric) {
    std::array<ptz::driver::OnvifCameraSettings, 2> settings;
    for (auto& s : settings) {
      s.password = password;
      s.clock_offset_s = clock_offset_s;
    }
    ptz::sim::OnvifServerOptions options;
    options.http_digest = http_digest;
    cameras_ =
        std::make_unique<ptz::sim::OnvifCameras>(OnvifModel::load(model), settings, options,
                                                 [this](const ptz::sim::OnvifCameras::Step& step) {
                                                   std::unique_lock<std::mutex> lk(lock_);
                                                   resumed_.wait(lk, [this] { return !paused_; });
                                                   if (const auto sp = step(poses_)) poses_ = *sp;
                                                 });
    cameras_->start();
  }
  ~Cameras() {
    pause(false);
    cameras_->stop();
  }
  std::string url() const {
    return "http://127.0.0.1:" + std::to_string(cameras_->port(ptz::Side::kLeft));
  }
  PtzPose left() {
    std::lock_guard<std::mutex> lk(lock_);
    return poses_[0];
  }
  void pause(bool paused) {
    {
      std::lock_guard<std::mutex> lk(lock_);
      paused_ = paused;
    }
    resumed_.notify_all();
  }
  ptz::sim::OnvifServerCounters counters() const { return cameras_->counters(); }

 private:
  std::mutex lock_;
  std::condition_variable resumed_;
  bool paused_ = false;
  std::array<PtzPose, 2> poses_{PtzPose{0, 0, 1}, PtzPose{0, 0, 1}};
  std::unique_ptr<ptz::sim::OnvifCameras> cameras_;
};

OnvifHeadSettings settings(const Cameras& c, const std::string& password) {
  OnvifHeadSettings s;
  s.url = c.url();
  s.password = password;
  s.timeout_ms = 500;
  s.status_rate_hz = 50;
  return s;
}

// Drives the head as ptz-driver does (poll its fd, receive, inquire) until done() or the deadline.
bool runUntil(OnvifHead& head, const std::function<bool()>& done, double deadline_s = kDeadlineS) {
  const double end = nowS() + deadline_s;
  while (nowS() < end) {
    pollfd fd{head.fd(), POLLIN, 0};
    ::poll(&fd, 1, 20);
    head.receive(nowS());
    if (done()) return true;
    head.inquire(nowS(), 0.1);
  }
  return false;
}

bool near(const PtzPose& a, const PtzPose& b, double tol) {
  return std::abs(a.pan_rad - b.pan_rad) < tol && std::abs(a.tilt_rad - b.tilt_rad) < tol &&
         std::abs(a.zoom - b.zoom) < tol;
}

TEST(OnvifHead, StartsWithTheCameraClock37sOffMovesWhereCommandedAndReadsItBack) {
  Cameras cams("s3cret", 37.0);
  const OnvifModel model = OnvifModel::load(kGeneric);
  OnvifHead head(model, settings(cams, "s3cret"));
  EXPECT_NE(head.problem(nowS()), "");  // before the start-up
  head.start(nowS());
  ASSERT_TRUE(runUntil(head, [&] { return head.ready(); })) << head.problem(nowS());
  EXPECT_EQ(head.profileToken(), "profile_1");
  // GetSystemDateAndTime's whole seconds: within a second at first.
  EXPECT_NEAR(head.clockOffsetS(), 37.0, 1.0);
  EXPECT_EQ(head.problem(nowS()), "");

  // Known answer through the model: 0.5 rad of -170..170 deg is x = 0.5 / (170 pi / 180);
  // zoom 2.5 is 0.4 in the table.
  EXPECT_NEAR(model.panNormalised(0.5), 0.5 / (170 * M_PI / 180), 1e-12);
  EXPECT_NEAR(model.zoomNormalised(2.5), 0.4, 1e-12);
  const PtzPose target{0.5, 0.2, 2.5};
  head.command(target, nowS());
  ASSERT_TRUE(runUntil(head, [&] { return near(cams.left(), target, 1e-6); }))
      << "plant at " << cams.left().pan_rad;
  ASSERT_TRUE(
      runUntil(head, [&] { return head.measured() && near(*head.measured(), target, 1e-6); }));
  // The stamp: the camera's UtcTime back on the local clock (not 37 s off), within the exchange.
  const double received_s = nowS();
  EXPECT_LE(head.measuredAtS(), received_s);
  EXPECT_GT(head.measuredAtS(), received_s - 1.0);
  // GetStatus's UtcTime (ms) refines the offset.
  EXPECT_NEAR(head.clockOffsetS(), 37.0, 0.1);
  std::printf("clock offset %.4f s (camera 37 s ahead); stamp %.1f ms before the receive\n",
              head.clockOffsetS(), (received_s - head.measuredAtS()) * 1e3);
  EXPECT_EQ(head.stats().errors + head.stats().timeouts + head.stats().malformed, 0);
  EXPECT_FALSE(head.stats().round_trip_ms.empty());
  EXPECT_EQ(cams.counters().auth_refused, 0);
}

TEST(OnvifHead, AWrongPasswordIsNotAuthorizedAndMovesNothing) {
  Cameras cams("s3cret");
  OnvifHead head(OnvifModel::load(kGeneric), settings(cams, "hunter2-wrong"));
  head.start(nowS());
  head.command(PtzPose{1.0, 0.3, 4.0}, nowS());
  // Two refused start-ups (the second 0.1 s after the first).
  ASSERT_TRUE(runUntil(head, [&] { return head.stats().errors >= 2; }));
  head.command(PtzPose{1.0, 0.3, 4.0}, nowS());
  const std::string problem = head.problem(nowS());
  std::printf("problem: %s\n", problem.c_str());
  EXPECT_NE(problem.find("NotAuthorized"), std::string::npos) << problem;
  EXPECT_EQ(problem.find("hunter2"), std::string::npos) << "the password is never printed";
  EXPECT_EQ(head.stats().last_error.find("hunter2"), std::string::npos);
  EXPECT_FALSE(head.ready());
  EXPECT_FALSE(head.measured());
  EXPECT_FALSE(head.stop(nowS(), 0.5)) << "nothing confirmed by a camera that refuses us";
  EXPECT_TRUE(near(cams.left(), PtzPose{0, 0, 1}, 1e-12)) << "no move";
  // The server's counters are copied after each of its loops: waited for.
  EXPECT_TRUE(runUntil(head, [&] { return cams.counters().auth_refused >= 2; }));
}

TEST(OnvifHead, ACameraDemandingHttpDigestIsAnsweredWithThePassword) {
  Cameras cams("s3cret", 0, /*http_digest=*/true);
  OnvifHead head(OnvifModel::load(kGeneric), settings(cams, "s3cret"));
  head.start(nowS());
  const PtzPose target{0.5, 0.2, 2.5};
  head.command(target, nowS());
  ASSERT_TRUE(runUntil(head, [&] { return near(cams.left(), target, 1e-6); }))
      << head.problem(nowS());
  ASSERT_TRUE(
      runUntil(head, [&] { return head.measured() && near(*head.measured(), target, 1e-6); }));
  // Challenged (libcurl asks each request's challenge anew: one more round trip each), never
  // refused.
  EXPECT_TRUE(runUntil(head, [&] { return cams.counters().digest_challenges >= 1; }));
  EXPECT_EQ(cams.counters().auth_refused, 0);
  EXPECT_EQ(head.stats().errors, 0);
}

TEST(OnvifHead, AWrongHttpDigestPasswordIsNamedAsAuthentication) {
  Cameras cams("s3cret", 0, /*http_digest=*/true);
  OnvifHead head(OnvifModel::load(kGeneric), settings(cams, "hunter2-wrong"));
  head.start(nowS());
  head.command(PtzPose{1.0, 0.3, 4.0}, nowS());
  ASSERT_TRUE(runUntil(head, [&] { return head.stats().errors >= 2; }));
  const std::string problem = head.problem(nowS());
  std::printf("problem: %s\n", problem.c_str());
  EXPECT_NE(problem.find("GetSystemDateAndTime: HTTP 401: authentication refused"),
            std::string::npos)
      << problem;
  EXPECT_EQ(problem.find("hunter2"), std::string::npos) << "the password is never printed";
  EXPECT_FALSE(head.measured());
  EXPECT_TRUE(near(cams.left(), PtzPose{0, 0, 1}, 1e-12)) << "no move";
  EXPECT_TRUE(runUntil(head, [&] { return cams.counters().auth_refused >= 2; }));
}

TEST(OnvifHead, ACameraThatStopsAnsweringTimesOutAndNoMoveGoesOutUntilItAnswers) {
  Cameras cams("");
  OnvifHead head(OnvifModel::load(kGeneric), settings(cams, ""));
  head.start(nowS());
  const PtzPose first{-0.4, 0.1, 1.6};
  head.command(first, nowS());
  ASSERT_TRUE(
      runUntil(head, [&] { return head.measured() && near(*head.measured(), first, 1e-6); }));

  cams.pause(true);
  ASSERT_TRUE(runUntil(head, [&] { return head.stats().timeouts >= 1; }));
  const std::string problem = head.problem(nowS());
  std::printf("problem: %s\n", problem.c_str());
  EXPECT_NE(problem.find("timeout"), std::string::npos) << problem;
  EXPECT_FALSE(head.ready());
  // Commanded while the camera is silent: dropped, not sent when it answers again.
  head.command(PtzPose{0.9, 0.0, 1.0}, nowS());
  ASSERT_TRUE(runUntil(head, [&] { return head.stats().timeouts >= 2; }));
  cams.pause(false);
  ASSERT_TRUE(runUntil(head, [&] { return head.ready(); })) << head.problem(nowS());
  EXPECT_EQ(head.problem(nowS()), "");
  ASSERT_TRUE(
      runUntil(head, [&, n = head.stats().replies] { return head.stats().replies >= n + 3; }));
  EXPECT_TRUE(near(cams.left(), first, 1e-6)) << "the stale setpoint went out";
  // A fresh one does.
  const PtzPose second{0.3, -0.2, 1.0};
  head.command(second, nowS());
  EXPECT_TRUE(runUntil(head, [&] { return near(cams.left(), second, 1e-6); }));
}

TEST(OnvifHead, StopIsConfirmedWhenTheCameraAnswersAndNotWhenItIsSilent) {
  Cameras cams("pw");
  OnvifHead head(OnvifModel::load(kGeneric), settings(cams, "pw"));
  head.start(nowS());
  ASSERT_TRUE(runUntil(head, [&] { return head.ready(); })) << head.problem(nowS());
  EXPECT_TRUE(head.stop(nowS(), 5.0));
  cams.pause(true);
  const double t0 = nowS();
  EXPECT_FALSE(head.stop(nowS(), 0.3));
  EXPECT_LT(nowS() - t0, 2.0) << "stop() waits its timeout, not the camera";
  cams.pause(false);
}

TEST(OnvifHead, ContinuousModeSteersTheVelocityToTheSetpoint) {
  Cameras cams("");
  OnvifHeadSettings s = settings(cams, "");
  s.move_mode = OnvifMoveMode::kContinuous;
  OnvifHead head(OnvifModel::load(kGeneric), s);
  head.start(nowS());
  const PtzPose target{0.6, -0.1, 2.0};
  head.command(target, nowS());
  ASSERT_TRUE(
      runUntil(head, [&] { return head.measured() && near(*head.measured(), target, 0.01); }))
      << "at " << (head.measured() ? head.measured()->pan_rad : NAN);
  EXPECT_TRUE(head.stop(nowS(), 5.0));
  // Stopped: it stays (no velocity is sent after the stop).
  const PtzPose stopped = cams.left();
  ASSERT_TRUE(
      runUntil(head, [&, n = head.stats().replies] { return head.stats().replies >= n + 10; }));
  EXPECT_TRUE(near(cams.left(), stopped, 1e-3));
}

// A camera that offers ContinuousMove alone (no absolute spaces; AbsoluteMove a fault): the
// default mode, auto, steers it by velocity, where absolute moves would have failed.
TEST(OnvifHead, AutoModeSteersACameraWithoutAbsoluteMoveByVelocity) {
  const std::string model = ::testing::TempDir() + "continuous_only_ptz.yaml";
  {
    std::ifstream in(kGeneric);
    std::ofstream out(model);
    out << in.rdbuf() << "absolute_moves: 0\n";
  }
  Cameras cams("", 0, false, model);
  OnvifHeadSettings s = settings(cams, "");
  ASSERT_EQ(s.move_mode, OnvifMoveMode::kAuto);
  OnvifHead head(OnvifModel::load(kGeneric), s);
  head.start(nowS());
  const PtzPose target{-0.4, 0.2, 1.5};
  head.command(target, nowS());
  ASSERT_TRUE(runUntil(head, [&] {
    return head.measured() && near(*head.measured(), target, 0.01);
  })) << head.problem(nowS());
  EXPECT_TRUE(head.ready());
  EXPECT_EQ(head.stats().errors, 0);
  EXPECT_TRUE(head.stop(nowS(), 5.0));
}

TEST(OnvifHead, TheBackendsParametersAreCheckedByName) {
  ptz::Params p("test", "");
  ptz::addAxisLimitParams(p);
  ptz::driver::declareBackendParams(p);
  p.set("backend", "onvif");
  p.set("onvif_model", kGeneric);
  p.set("onvif_move_mode", "sideways");
  EXPECT_NE(ptz::test::errorOf([&] {
              ptz::driver::makeHeads(p);
            }).find("parameter 'onvif_move_mode' must be auto, absolute or continuous"),
            std::string::npos);
  p.set("onvif_move_mode", "continuous");
  p.set("onvif_left_url", "ftp://127.0.0.1:21");
  EXPECT_NE(ptz::test::errorOf([&] { ptz::driver::makeHeads(p); }).find("'onvif_left_url'"),
            std::string::npos);
  p.set("onvif_left_url", "http://127.0.0.1:1");
  p.set("onvif_password_file", "/nonexistent/onvif_password");
  EXPECT_NE(ptz::test::errorOf([&] { ptz::driver::makeHeads(p); }).find("cannot be read"),
            std::string::npos);
  p.set("onvif_password_file", "");
  auto heads = ptz::driver::makeHeads(p);
  ASSERT_TRUE(heads[0] && heads[1]);
  EXPECT_GE(heads[0]->fd(), 0);
  EXPECT_NE(heads[0]->problem(nowS()).find("not started"), std::string::npos);
  EXPECT_FALSE(heads[0]->measured());
}

}  // namespace
