#include "tools/replay/replay_answers.hpp"

#include <algorithm>
#include <cmath>

#include "tools/logs/log_reader.hpp"

namespace ptz::tools {

double largestPositionChange(const ptzstereo::object_pose_t& a, const ptzstereo::object_pose_t& b) {
  if (a.num_objects != b.num_objects) return INFINITY;
  double worst = 0;
  for (size_t i = 0; i < a.objects.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      worst = std::max(worst, std::abs(a.objects[i].position_m[k] - b.objects[i].position_m[k]));
    }
  }
  return worst;
}

template <>
void Answers<ptzstereo::object_pose_t>::report(int64_t seq, const ptzstereo::object_pose_t& a,
                                               const ptzstereo::object_pose_t& b) const {
  std::fprintf(stderr, "ptz-replay: frame %lld: pose differs (largest position change %g m)\n",
               static_cast<long long>(seq), largestPositionChange(a, b));
}

std::string replaySummary(const ReplayTally& tally, const Answers<ptzstereo::object_pose_t>& poses,
                          const Answers<ptzstereo::object_tracks_t>& tracks) {
  char line[512];
  std::snprintf(
      line, sizeof line,
      "replayed %lld frames: %lld poses identical to the log, %lld different, %lld without a "
      "logged pose; %lld tracks identical, %lld different, %lld without logged tracks; %lld "
      "frames unanswered\n",
      static_cast<long long>(tally.frames), static_cast<long long>(poses.identical),
      static_cast<long long>(poses.different), static_cast<long long>(poses.not_logged),
      static_cast<long long>(tracks.identical), static_cast<long long>(tracks.different),
      static_cast<long long>(tracks.not_logged), static_cast<long long>(tally.unanswered));
  return line;
}

int replayExitCode(bool check, const ReplayTally& tally,
                   const Answers<ptzstereo::object_pose_t>& poses,
                   const Answers<ptzstereo::object_tracks_t>& tracks) {
  if (check && poses.different + tracks.different > 0) return log_exit::kVerdict;
  if (tally.unanswered > 0 || (check && poses.identical == 0)) return log_exit::kUnanswered;
  return log_exit::kOk;
}

}  // namespace ptz::tools
