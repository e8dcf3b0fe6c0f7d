// ptz-replay's bookkeeping, without LCM traffic: ptz-detect's answers to the replayed frames set
// against the logged ones (byte for byte once publish_utime is set aside), the line that says
// how it went, the exit code, and the replayed messages as log events.
#pragma once

#include <lcm/lcm-cpp.hpp>

#include <cstdint>
#include <cstdio>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "common/transport/message_check.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"

namespace ptz::tools {

template <typename Message>
std::vector<uint8_t> encoded(const Message& m) {
  std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

// The bytes without the publish time: what must be identical between runs.
template <typename Message>
std::vector<uint8_t> canonical(Message m) {
  m.publish_utime = 0;
  return encoded(m);
}

// The largest change of an object's position between two poses (infinite: other objects).
double largestPositionChange(const ptzstereo::object_pose_t& a, const ptzstereo::object_pose_t& b);

// One of ptz-detect's answers to a frame: the logged ones, the replayed ones, by frame_seq.
template <typename Message>
struct Answers {
  explicit Answers(std::string name) : what(std::move(name)) {}
  std::string what;  // "pose", "tracks"
  std::map<int64_t, Message> logged, replies, replayed;
  int64_t identical = 0, different = 0, not_logged = 0;
  // Checked before it is decoded (a hostile count must not make the replay allocate).
  void onReply(const void* data, size_t size) {
    Message m;
    if (decodeChecked(data, size, &m, nullptr)) replies[m.frame_seq] = m;
  }
  // The reply to frame seq, stamped with the frame's logged capture time, kept for the end.
  Message* take(int64_t seq, int64_t logged_utime) {
    auto it = replies.find(seq);
    if (it == replies.end()) return nullptr;
    it->second.utime = logged_utime;
    Message* kept = &(replayed[seq] = it->second);
    replies.erase(replies.begin(), replies.upper_bound(seq));
    return kept;
  }
  void compare() {
    for (const auto& [seq, r] : replayed) {
      const auto it = logged.find(seq);
      if (it == logged.end()) {
        ++not_logged;
      } else if (canonical(it->second) == canonical(r)) {
        ++identical;
      } else {
        ++different;
        report(seq, it->second, r);
      }
    }
  }
  void report(int64_t seq, const Message&, const Message&) const {
    std::fprintf(stderr, "ptz-replay: frame %lld: %s differs\n", static_cast<long long>(seq),
                 what.c_str());
  }
};

template <>
void Answers<ptzstereo::object_pose_t>::report(int64_t seq, const ptzstereo::object_pose_t& a,
                                               const ptzstereo::object_pose_t& b) const;

template <typename Message>
void writeEvent(lcm::LogFile* out, int64_t eventnum, const char* channel, const Message& m) {
  std::vector<uint8_t> bytes = encoded(m);
  lcm::LogEvent e{};
  e.eventnum = eventnum;
  e.timestamp = m.publish_utime;
  e.channel = channel;
  e.datalen = static_cast<int32_t>(bytes.size());
  e.data = bytes.data();
  out->writeEvent(&e);
}

struct ReplayTally {
  int64_t frames = 0, unanswered = 0, undecodable = 0;
};

// "replayed N frames: ..." (one line).
std::string replaySummary(const ReplayTally& tally, const Answers<ptzstereo::object_pose_t>& poses,
                          const Answers<ptzstereo::object_tracks_t>& tracks);
// 1 (--check: a difference), 3 (unanswered frames; --check: no pose to compare), else 0.
int replayExitCode(bool check, const ReplayTally& tally,
                   const Answers<ptzstereo::object_pose_t>& poses,
                   const Answers<ptzstereo::object_tracks_t>& tracks);

}  // namespace ptz::tools
