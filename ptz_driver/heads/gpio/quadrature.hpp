// x4 quadrature decoding with a state table: every edge of A and B counts. A leads B when the
// shaft turns the positive way: AB = 00 -> 10 -> 11 -> 01 -> 00 counts up. A step where both
// lines changed (or an edge that does not change its line: one was lost) cannot be decoded; it
// is counted as illegal and the count is left as it was.
#pragma once

#include <cstdint>

namespace ptz::driver {

class QuadratureDecoder {
 public:
  // The lines' levels when counting starts.
  void reset(bool a, bool b) { state_ = code(a, b); }

  // Both lines sampled at once (a polled encoder).
  void sample(bool a, bool b, double time_s) {
    const uint8_t next = code(a, b);
    if (next == state_) return;
    const int delta = kTable[state_ * 4 + next];
    if (delta == kIllegal) {
      ++illegal_;
    } else {
      count_ += delta;
      last_edge_s_ = time_s;
    }
    state_ = next;
  }

  // One edge of line A (channel 0) or B (channel 1) with the level after it.
  void edge(int channel, bool level, double time_s) {
    const bool a = channel == 0 ? level : (state_ & 2) != 0;
    const bool b = channel == 1 ? level : (state_ & 1) != 0;
    if (code(a, b) == state_) {  // an edge to the level the line already had: one was lost
      ++illegal_;
      return;
    }
    sample(a, b, time_s);
  }

  int64_t count() const { return count_; }
  int64_t illegal() const { return illegal_; }
  double lastEdgeS() const { return last_edge_s_; }

 private:
  static constexpr int kIllegal = 2;
  // kTable[old * 4 + new]: +1 (A leads B), -1, 0 (no change) or illegal (both lines changed).
  static constexpr int8_t kTable[16] = {0, -1, 1, 2, 1, 0, 2, -1, -1, 2, 0, 1, 2, 1, -1, 0};
  static uint8_t code(bool a, bool b) { return static_cast<uint8_t>((a ? 2 : 0) | (b ? 1 : 0)); }

  uint8_t state_ = 0;
  int64_t count_ = 0, illegal_ = 0;
  double last_edge_s_ = 0;
};

}  // namespace ptz::driver
