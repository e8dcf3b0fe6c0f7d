// The bookkeeping every head that speaks a position protocol shares, in the protocol's own
// integer units (VISCA units, Pelco-D hundredths of a degree, zoom positions): what was last
// sent per axis, so only a change goes out and a lost or refused command goes again; what was
// last measured and when (the middle of the inquiry's round trip); the inquiry round in flight
// and its timeout; round trips and errors by name in HeadStats.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "ptz_driver/heads/common/head.hpp"

namespace ptz::driver {

class HeadBook {
 public:
  enum Axis { kPan = 0, kTilt = 1, kZoom = 2 };

  // Whether `units` differs from what was last sent on axis a (or nothing was).
  bool changed(Axis a, int32_t units) const { return sent_[a] != units; }
  void sent(Axis a, int32_t units) { sent_[a] = units; }
  // A command was lost or refused: every axis goes again with the next command.
  void forgetSent() { sent_ = {}; }
  // The link was down (a serial port reopened): nothing sent, measured or asked stands; the
  // position is unknown until measured again. The stats stay.
  void lostTrack() {
    sent_ = {};
    measured_ = {};
    inquiry_sent_s_ = -1;
    buffer_full_since_s_ = -1;
  }

  // Whether the next inquiry round may start: none out, or the one out has waited timeout_s
  // (counted in stats().timeouts).
  bool inquiryDue(double now_s, double timeout_s);
  // An inquiry (of the round) left at now_s: the timeout counts from the latest.
  void inquirySent(double now_s) { inquiry_sent_s_ = now_s; }
  // The round is answered: the next may go.
  void roundDone() { inquiry_sent_s_ = -1; }
  bool inquiryOut() const { return inquiry_sent_s_ >= 0; }

  // A measured axis; for the pan (or pan-tilt) answer also the round trip of the inquiry sent
  // at sent_s and answered at now_s: the measurement is dated mid round trip.
  void measured(Axis a, int32_t units) { measured_[a] = units; }
  void roundTrip(double sent_s, double now_s);
  // All three axes measured at least once.
  bool hasMeasurement() const { return measured_[0] && measured_[1] && measured_[2]; }
  int32_t measuredUnits(Axis a) const { return measured_[a].value_or(0); }
  double measuredAtS() const { return measured_at_s_; }

  // An error the head reported (or the transport met), by name.
  void error(const std::string& name);
  // "Command buffer full": commands wait for a completion, or at most max_wait_s.
  void bufferFull(double now_s);
  void bufferFreed() { buffer_full_since_s_ = -1; }
  bool mayCommand(double now_s, double max_wait_s) const {
    return buffer_full_since_s_ < 0 || now_s - buffer_full_since_s_ > max_wait_s;
  }

  HeadStats& stats() { return stats_; }
  const HeadStats& stats() const { return stats_; }

 private:
  std::array<std::optional<int32_t>, 3> sent_, measured_;
  double measured_at_s_ = 0;
  double inquiry_sent_s_ = -1;
  double buffer_full_since_s_ = -1;
  HeadStats stats_;
};

// Polls fd (-1: none) for up to timeout_s, calling receive() whenever it may have something,
// until done(). Returns done(). For the waits of stop() on exit, the one place a head blocks.
bool waitUntil(int fd, double timeout_s, const std::function<void()>& receive,
               const std::function<bool()>& done);

}  // namespace ptz::driver
