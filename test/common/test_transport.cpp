// The LCM edge every process shares: checked subscriptions (newest-only delivery, sequence gaps,
// undecodable messages counted) over memq://, and the health rules of the status with an injected
// clock.
#include <gtest/gtest.h>

#include <map>

#include "common/config.hpp"
#include "common/transport.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace {

ptzstereo::object_pose_t poseFor(int64_t seq) {
  ptzstereo::object_pose_t m{};
  m.frame_seq = seq;
  m.target_index = -1;
  return m;
}

ptz::Params statusParams() {
  ptz::Params p("ptz-test", "");
  ptz::addTransportParams(p);
  return p;
}

// One process's LCM edge on memq://: its status reporter and what its subscriptions handled.
class Edge : public ::testing::Test {
 protected:
  lcm::LCM lcm{"memq://"};
  ptz::Params params = statusParams();
  ptz::StatusReporter status{&lcm, params, "ptz-test"};
  std::vector<int64_t> handled;
  void publishPose(int64_t seq) {
    const auto m = poseFor(seq);
    lcm.publish("OBJECT_POSE", &m);
  }
  ptz::SafeSubscription<ptzstereo::object_pose_t>::Handler recordPose() {
    return [this](const std::string&, const ptzstereo::object_pose_t& m) {
      handled.push_back(m.frame_seq);
    };
  }
};

}  // namespace

TEST_F(Edge, NewestDeliveryDrainsTheBacklogAndHandsOverOnlyTheLast) {
  std::vector<int64_t> handled;
  ptz::SafeSubscription<ptzstereo::object_pose_t> sub(
      lcm, "OBJECT_POSE", status,
      [&](const std::string&, const ptzstereo::object_pose_t& m) {
        handled.push_back(m.frame_seq);
      },
      ptz::Delivery::kNewest);
  for (int64_t seq = 0; seq < 6; ++seq) {
    const auto m = poseFor(seq);
    lcm.publish("OBJECT_POSE", &m);
  }
  EXPECT_GT(ptz::handleNewest(lcm, 0), 0);
  EXPECT_EQ(handled, std::vector<int64_t>{5});
  EXPECT_EQ(status.counter("dropped_superseded"), 5);
  EXPECT_EQ(status.counter("OBJECT_POSE.dropped_superseded"), 5);
  EXPECT_EQ(status.counter("dropped_seq_gap"), 0);
  EXPECT_EQ(ptz::handleNewest(lcm, 0), 0);  // nothing left, nothing handed over twice
  EXPECT_EQ(handled.size(), 1u);
}

TEST_F(Edge, EveryDeliveryKeepsTheOrder) {
  ptz::SafeSubscription<ptzstereo::ptz_setpoint_t> sub(
      lcm, "PTZ_SETPOINT", status, [&](const std::string&, const ptzstereo::ptz_setpoint_t& m) {
        handled.push_back(m.frame_seq);
      });
  for (int64_t seq = 0; seq < 4; ++seq) {
    ptzstereo::ptz_setpoint_t m{};
    m.frame_seq = seq;
    lcm.publish("PTZ_SETPOINT", &m);
  }
  while (ptz::handleNewest(lcm, 0) > 0) {
  }
  EXPECT_EQ(handled, (std::vector<int64_t>{0, 1, 2, 3}));
}

TEST_F(Edge, SequenceGapsAreCountedExactly) {
  ptz::SafeSubscription<ptzstereo::stereo_frame_t> sub(
      lcm, "STEREO_FRAME", status,
      [&](const std::string&, const ptzstereo::stereo_frame_t& m) { handled.push_back(m.seq); });
  // 0 1 2 _ _ 5 6 _ _ _ 10 11: five lost; back to 3 (a restart); a lone hostile 2000000 (an
  // outlier, not two million lost frames), then on from 4; INT64_MAX goes nowhere either.
  for (int64_t seq : {int64_t{0}, int64_t{1}, int64_t{2}, int64_t{5}, int64_t{6}, int64_t{10},
                      int64_t{11}, int64_t{3}, int64_t{2'000'000}, int64_t{4}, int64_t{-1},
                      std::numeric_limits<int64_t>::max(), int64_t{5}}) {
    ptzstereo::stereo_frame_t m{};
    m.seq = seq;
    lcm.publish("STEREO_FRAME", &m);
    ptz::handleNewest(lcm, 0);
  }
  EXPECT_EQ(handled.size(), 13u);
  EXPECT_EQ(status.counter("dropped_seq_gap"), 5);
  EXPECT_EQ(status.counter("STEREO_FRAME.dropped_seq_gap"), 5);
  EXPECT_EQ(status.counter("STEREO_FRAME.seq_restart"), 1);
  EXPECT_EQ(status.counter("STEREO_FRAME.seq_outlier"), 2);
}

TEST_F(Edge, GapsInADerivedSequenceAreToldButNotDroppedAgain) {
  // Frames ptz-detect skipped (and counted) show as gaps in its poses' frame_seq.
  ptz::SafeSubscription<ptzstereo::object_pose_t> sub(lcm, "OBJECT_POSE", status, recordPose());
  for (int64_t seq : {0, 1, 4, 5}) {
    publishPose(seq);
    ptz::handleNewest(lcm, 0);
  }
  EXPECT_EQ(status.counter("OBJECT_POSE.seq_gap"), 2);
  EXPECT_EQ(status.counter("dropped_seq_gap"), 0);
}

TEST_F(Edge, UndecodableMessagesAreDroppedAndCounted) {
  ptz::SafeSubscription<ptzstereo::object_pose_t> sub(lcm, "OBJECT_POSE", status, recordPose(),
                                                      ptz::Delivery::kNewest);
  const uint8_t junk[] = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  for (int i = 0; i < 7; ++i) {
    lcm.publish("OBJECT_POSE", junk, sizeof(junk));
    ptz::handleNewest(lcm, 0);
  }
  EXPECT_TRUE(handled.empty());
  EXPECT_EQ(status.counter("dropped_undecodable"), 7);
  EXPECT_EQ(status.counter("OBJECT_POSE.dropped_undecodable"), 7);
}

TEST_F(Edge, StarvingInputTurnsWarnThenErrorAndRecovers) {
  int64_t now = 1'800'000'000'000'000;
  status.useClock([&] { return now; });
  status.expectInput("STEREO_FRAME");
  using S = ptzstereo::process_status_t;
  EXPECT_EQ(status.health().first, S::STATE_OK);
  now += 900'000;
  EXPECT_EQ(status.health().first, S::STATE_OK);
  now += 200'000;
  EXPECT_EQ(status.health().first, S::STATE_WARN);
  EXPECT_EQ(status.health().second, "no STEREO_FRAME for 1 s");
  now += 4'000'000;
  EXPECT_EQ(status.health().first, S::STATE_ERROR);
  EXPECT_EQ(status.health().second, "no STEREO_FRAME for 5 s");
  status.countIn("STEREO_FRAME", 3.0);
  EXPECT_EQ(status.health().first, S::STATE_OK);
  EXPECT_EQ(status.health().second, "");
  // The process's own warning and the starvation are both told.
  status.setState(S::STATE_WARN, "delay p99 400 ms");
  now += 2'000'000;
  EXPECT_EQ(status.health().first, S::STATE_WARN);
  EXPECT_EQ(status.health().second, "delay p99 400 ms; no STEREO_FRAME for 2 s");
}

TEST_F(Edge, ThePublishedStatusCarriesTheHealth) {
  std::vector<ptzstereo::process_status_t> got;
  ptz::SafeSubscription<ptzstereo::process_status_t> sub(
      lcm, "PROCESS_STATUS_PTZ_TEST", status,
      [&](const std::string&, const ptzstereo::process_status_t& m) { got.push_back(m); });
  int64_t now = ptz::wallUtime();
  status.useClock([&] { return now; });
  status.expectInput("OBJECT_POSE");
  now += 6'000'000;
  status.publishNow();
  ASSERT_GT(ptz::handleNewest(lcm, 0), 0);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].state, ptzstereo::process_status_t::STATE_ERROR);
  EXPECT_EQ(got[0].message, "no OBJECT_POSE for 6 s");
}
