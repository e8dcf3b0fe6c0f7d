// decodeEvent on what fuzz/fuzz_log_reader found: events whose counts ask for a gigabyte and
// whose string length is 0 (lcm-gen's decode threw std::length_error out of every log tool).
// Each is checked before it is decoded: refused, counted, nothing thrown, nothing allocated.
#include <gtest/gtest.h>

#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "tools/logs/log_reader.hpp"

namespace {

// Decodes every event of the reproducer as T; returns (events, undecodable).
template <class T>
std::pair<int64_t, int64_t> decodeAll(const std::string& name) {
  ptz::tools::LogReader reader(PTZ_SOURCE_DIR "/fuzz/corpus/fuzz_log_reader/" + name);
  int64_t events = 0, undecodable = 0;
  while (const lcm::LogEvent* ev = reader.next()) {
    ++events;
    T msg;
    EXPECT_FALSE(ptz::tools::decodeEvent(*ev, &msg, &undecodable)) << ev->channel;
  }
  return {events, undecodable};
}

}  // namespace

TEST(DecodeEvent, DamagedEventsAreRefusedAndCountedWithoutThrowingOrAllocating) {
  const auto [events, undecodable] =
      decodeAll<ptzstereo::process_status_t>("find-decode-string-length-zero-throws");
  EXPECT_GT(events, 0);
  EXPECT_EQ(undecodable, events);
  // An event of 1767 bytes that lcm-gen decoded into a 1 GB image.
  ptz::tools::LogReader reader(PTZ_SOURCE_DIR
                               "/fuzz/corpus/fuzz_log_reader/find-decode-allocates-1g");
  int64_t bad = 0;
  while (const lcm::LogEvent* ev = reader.next()) {
    ptzstereo::stereo_frame_t frame;
    EXPECT_FALSE(ptz::tools::decodeEvent(*ev, &frame, &bad));
    EXPECT_EQ(frame.left.data.capacity(), 0u) << "allocated for a count the event does not hold";
    ptzstereo::object_pose_t pose;
    ptz::tools::decodeEvent(*ev, &pose, &bad);
    EXPECT_LE(pose.objects.capacity() * sizeof(ptzstereo::object_3d_t), 4u * ev->datalen);
  }
  EXPECT_GT(bad, 0);
}
