// ptz-replay: process replay. Publishes every STEREO_FRAME of a recorded log, one at a time,
// to the real ptz-detect (started beforehand, e.g. by scripts/replay) and waits for the
// OBJECT_POSE (and, where the log has them, the OBJECT_TRACKS) that answer it before the next
// frame, so nothing is dropped and the replay runs as fast as detection. Each replayed message is
// compared with the logged one of the same frame: byte for byte once publish_utime (wall clock)
// is set aside. --check: exit 1 on a difference;
// 3 when frames went unanswered (no ptz-detect, or it dropped them). A missing, empty or foreign
// log, or one without frames, has its own exit code (tools/logs/log_reader.hpp); --out is
// written under a temporary name and kept only when every frame was replayed.
#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "common/freshness.hpp"
#include "common/transport/transport.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "tools/logs/log_reader.hpp"
#include "tools/replay/replay_answers.hpp"

namespace {

using ptz::tools::Answers;

void noteUp(const lcm::ReceiveBuffer*, const std::string&, bool* up) {
  *up = true;
}

template <typename Message>
void onReply(const lcm::ReceiveBuffer* rbuf, const std::string&, Answers<Message>* answers) {
  answers->onReply(rbuf->data, rbuf->data_size);
}

// The replay; returns the exit code. Throws LogError for a log it cannot use.
int replay(const ptz::Params& params, lcm::LCM& lcm) {
  const std::string path = params.getString("log");
  if (path.empty()) throw ptz::ConfigError("--log FILE is required");
  ptz::tools::LogReader reader(path);  // a missing log before anything else
  std::unique_ptr<ptz::tools::OutputFile> out_file;
  std::unique_ptr<lcm::LogFile> out;
  if (!params.getString("out").empty()) {
    out_file = std::make_unique<ptz::tools::OutputFile>(params.getString("out"));
    out = std::make_unique<lcm::LogFile>(out_file->tempPath(), "w");
    if (!out->good()) {
      throw ptz::tools::LogError(ptz::tools::log_exit::kOutput,
                                 "cannot write '" + params.getString("out") + "'");
    }
  }
  const std::string in_prefix = params.getString("log_channel_prefix");
  const auto timeout =
      std::chrono::milliseconds(static_cast<int64_t>(params.getDouble("timeout_s") * 1000));
  Answers<ptzstereo::object_pose_t> poses("pose");
  Answers<ptzstereo::object_tracks_t> tracks("tracks");
  bool detect_up = false;
  lcm.subscribeFunction(ptz::channel(params, ptz::channels::kObjectPose),
                        &onReply<ptzstereo::object_pose_t>, &poses);
  lcm.subscribeFunction(ptz::channel(params, ptz::channels::kObjectTracks),
                        &onReply<ptzstereo::object_tracks_t>, &tracks);
  lcm.subscribeFunction(ptz::channel(params, "PROCESS_STATUS_PTZ_DETECT"), &noteUp, &detect_up);
  auto waitFor = [&](auto done) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!done() && std::chrono::steady_clock::now() < deadline &&
           !ptz::StopFlag::stopRequested()) {
      lcm.handleTimeout(20);
    }
    return done();
  };
  // One pass: frames are replayed as they come, the logged answers (which follow their frames in
  // the log) are collected, and the two compared at the end (older logs have no tracks: counted).
  ptz::tools::ReplayTally tally;
  int64_t& frames = tally.frames;
  int64_t& undecodable = tally.undecodable;
  const std::string frame_channel = ptz::channel(params, ptz::channels::kStereoFrame);
  while (const lcm::LogEvent* ev = reader.next()) {
    if (ptz::StopFlag::stopRequested()) break;
    ptzstereo::object_pose_t logged_pose;
    if (ev->channel == in_prefix + ptz::channels::kObjectPose &&
        ptz::tools::decodeEvent(*ev, &logged_pose, &undecodable)) {
      poses.logged[logged_pose.frame_seq] = logged_pose;
      continue;
    }
    ptzstereo::object_tracks_t logged_tracks;
    if (ev->channel == in_prefix + ptz::channels::kObjectTracks &&
        ptz::tools::decodeEvent(*ev, &logged_tracks, &undecodable)) {
      tracks.logged[logged_tracks.frame_seq] = logged_tracks;
      continue;
    }
    ptzstereo::stereo_frame_t frame;
    if (ev->channel != in_prefix + ptz::channels::kStereoFrame ||
        !ptz::tools::decodeEvent(*ev, &frame, &undecodable)) {
      continue;
    }
    // ptz-detect is waited for at the first frame: a log without frames is its own error.
    if (frames == 0 && !waitFor([&] { return detect_up; })) {
      std::fprintf(stderr, "ptz-replay: ptz-detect is not running on this LCM network (no %s)\n",
                   ptz::channel(params, "PROCESS_STATUS_PTZ_DETECT").c_str());
      return ptz::tools::log_exit::kUnanswered;
    }
    ++frames;
    // Published now, so fresh to ptz-detect's freshness rule: a capture time on the wall clock
    // moves with the publish time (their difference kept); sim time stays as logged.
    const int64_t now_utime = ptz::wallUtime();
    const int64_t logged_utime = frame.utime;
    if (ptz::captureOnWallClock(frame.utime, frame.publish_utime)) {
      frame.utime = now_utime - ptz::saturatingDiffUs(frame.publish_utime, frame.utime);
    }
    frame.publish_utime = now_utime;
    lcm.publish(frame_channel, &frame);
    const bool answered = waitFor(
        [&] { return poses.replies.count(frame.seq) > 0 && tracks.replies.count(frame.seq) > 0; });
    if (!answered) {
      ++tally.unanswered;
      std::fprintf(stderr, "ptz-replay: no %s for frame %lld within the timeout\n",
                   poses.replies.count(frame.seq) ? "tracks" : "pose",
                   static_cast<long long>(frame.seq));
      continue;  // a half answer is not compared
    }
    // The frame's own capture time, as the log has it.
    const auto* pose = poses.take(frame.seq, logged_utime);
    const auto* frame_tracks = tracks.take(frame.seq, logged_utime);
    if (out) {
      ptz::tools::writeEvent(out.get(), 2 * (frames - 1), ptz::channels::kObjectPose, *pose);
      if (frame_tracks) {
        ptz::tools::writeEvent(out.get(), 2 * frames - 1, ptz::channels::kObjectTracks,
                               *frame_tracks);
      }
    }
  }
  if (ptz::StopFlag::stopRequested()) {
    std::fprintf(stderr, "ptz-replay: stopped (signal) after %lld frames; no --out written\n",
                 static_cast<long long>(frames));
    return ptz::tools::log_exit::kUnanswered;
  }
  reader.requireEvents();
  if (frames == 0) {
    reader.requireChannels({in_prefix + ptz::channels::kStereoFrame});
    throw ptz::tools::LogError(ptz::tools::log_exit::kNoChannels,
                               "log '" + path + "': no STEREO_FRAME in it decodes");
  }
  poses.compare();
  tracks.compare();
  if (undecodable) {
    std::fprintf(stderr, "ptz-replay: %lld undecodable messages in the log\n",
                 static_cast<long long>(undecodable));
  }
  if (!reader.breaks().empty()) {
    std::fprintf(stderr,
                 "ptz-replay: warning: the log is damaged; replayed what could be read:\n%s",
                 reader.describeBreaks().c_str());
  }
  std::fputs(ptz::tools::replaySummary(tally, poses, tracks).c_str(), stdout);
  const int code = ptz::tools::replayExitCode(params.getBool("check"), tally, poses, tracks);
  if (out_file) {
    out.reset();  // flushed and closed
    if (tally.unanswered > 0) {
      std::fprintf(stderr, "ptz-replay: %lld frames unanswered: --out not written\n",
                   static_cast<long long>(tally.unanswered));
    } else {
      out_file->commit();
    }
  }
  return code;
}

}  // namespace

int main(int argc, char** argv) {
  ptz::Params p("ptz-replay",
                "Replays the STEREO_FRAME messages of an LCM log through a running ptz-detect, "
                "one frame at a time, and compares its OBJECT_POSE and OBJECT_TRACKS messages with "
                "the logged ones.\n" +
                    ptz::tools::logExitCodesHelp(
                        "--check: a replayed pose or tracks message differs from the logged one",
                        "frames unanswered (no ptz-detect, or it dropped them; --check: also "
                        "no logged pose to compare), or stopped by a signal"));
  ptz::addTransportParams(p);
  p.add("log", "", "the recorded LCM log (required)");
  p.add("log_channel_prefix", "", "prefix of the channel names in the log");
  p.add("out", "",
        "write the replayed OBJECT_POSE and OBJECT_TRACKS messages to this LCM log (only when "
        "every frame was answered)");
  p.add("timeout_s", 5.0, "s", "wait this long for each answer (and for ptz-detect to be up)",
        ptz::Range::above(0));
  p.add("check", false,
        "exit 1 when a replayed pose or tracks message differs from the logged one (3 when "
        "frames are unanswered, with or without it)");
  // Not runProcess: its exit codes (1 for an LCM that does not open) are not these.
  try {
    if (!p.parse(argc, argv)) return ptz::tools::log_exit::kOk;
  } catch (const ptz::ConfigError& e) {
    std::fprintf(stderr, "ptz-replay: %s\n", e.what());
    return ptz::tools::log_exit::kUsage;
  }
  const std::string url = ptz::lcmUrl(p);
  ptz::warnIfReceiveBufferSmall(url);
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "ptz-replay: cannot open LCM at '%s' (scripts/check-network says why)\n",
                 url.c_str());
    return ptz::tools::log_exit::kFailed;
  }
  ptz::StopFlag::install();
  try {
    return replay(p, lcm);
  } catch (const ptz::tools::LogError& e) {
    std::fprintf(stderr, "ptz-replay: %s\n", e.what());
    return e.exitCode();
  } catch (const ptz::ConfigError& e) {
    std::fprintf(stderr, "ptz-replay: %s\n", e.what());
    return ptz::tools::log_exit::kUsage;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ptz-replay: stopped: %s\n", e.what());
    return ptz::tools::log_exit::kFailed;
  }
}
