// Stereo pairs by capture time. Each side's frames come in capture-time order. The oldest waiting
// frame of either side pairs with the other side's oldest waiting frame when their capture times
// differ by at most the tolerance; otherwise it can never pair (the other side's later frames are
// later still) and is counted unmatched. With a tolerance below half the frame period this is the
// nearest match, and each frame is used once. Buffers are bounded: the oldest frame beyond the
// bound is unmatched. A rig that never pairs says why (noPairMessage).
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "common/rig.hpp"  // Side
#include "ptz_driver/cameras/sources/frame_source.hpp"

namespace ptz::driver {

struct PairerParams {
  int64_t tolerance_us = 15'000;
  size_t buffer_frames = 30;  // per side
  double no_pair_warn_s = 2.0;
};

struct StereoPair {
  CapturedFrame left, right;
  int64_t first_arrival_utime = 0;  // when the earlier of the two arrived (wall clock)
};

class StereoPairer {
 public:
  explicit StereoPairer(PairerParams params) : params_(params) {}

  // A frame of one side that arrived at arrival_utime (wall clock). A frame not after the side's
  // previous one in capture time is unmatched at once.
  void add(Side side, CapturedFrame frame, int64_t arrival_utime);
  // The side will deliver nothing more (end of file): frames waiting for it are unmatched.
  void setEnded(Side side);
  // Pairs made since the last call, oldest first.
  std::vector<StereoPair> takePairs();

  int64_t pairs() const { return pairs_; }
  int64_t unmatched(Side side) const { return unmatched_[static_cast<size_t>(side)]; }
  size_t waiting(Side side) const { return buffer_[static_cast<size_t>(side)].size(); }
  // Median of right - left capture time of the nearest frames, over the recent decisions.
  std::optional<double> typicalOffsetS() const;
  // Non-empty when both sides delivered frames in the last no_pair_warn_s but nothing paired for
  // that long: "no stereo pair in 2.0 s: right is 0.480 s behind left (tolerance 0.020 s); ...".
  std::string noPairMessage(int64_t now_utime) const;

 private:
  struct Waiting {
    CapturedFrame frame;
    int64_t arrival_utime;
  };
  void decide();
  void unmatch(size_t side);
  // The offset to the nearest frame of the other side that arrived recently.
  void sampleOffset(size_t side, int64_t t);
  void pushOffset(int64_t right_minus_left_us);

  PairerParams params_;
  std::array<std::deque<Waiting>, 2> buffer_;
  std::array<std::deque<int64_t>, 2> recent_;  // capture times of the last frames that arrived
  std::array<std::optional<int64_t>, 2> newest_;
  std::array<bool, 2> ended_{false, false};
  std::array<int64_t, 2> first_arrival_{0, 0}, last_arrival_{0, 0};
  int64_t last_pair_arrival_ = 0;
  std::deque<int64_t> offsets_us_;  // right - left
  std::vector<StereoPair> made_;
  int64_t pairs_ = 0;
  std::array<int64_t, 2> unmatched_{0, 0};
};

}  // namespace ptz::driver
