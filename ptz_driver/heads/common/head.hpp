// One PTZ head as ptz-driver sees it, whatever the wire (VISCA over IP or serial, Pelco-D,
// GPIO DC motors). ptz-driver owns the safety (clamps, slew, deadman, stale setpoints); a head
// only moves where it is told, reports where it is, and stops.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/rig.hpp"  // PtzPose

namespace ptz::driver {

struct HeadStats {
  int64_t sent = 0, replies = 0, errors = 0, timeouts = 0, buffer_full = 0, malformed = 0;
  int64_t late_replies = 0;           // replies to requests already counted in timeouts
  int64_t reopens = 0;                // serial ports opened again after they failed
  std::vector<double> round_trip_ms;  // of position inquiries; cleared by whoever reads it
  std::string last_error;             // the last error the head reported, by name
};

class PtzHead {
 public:
  virtual ~PtzHead() = default;

  // Brings the link up (sequence reset, homing, ...).
  virtual void start(double now_s) = 0;
  // Moves to pose (already within ptz-driver's limits); a head may send only what changed.
  virtual void command(const PtzPose& pose, double now_s) = 0;
  // Stops pan, tilt and zoom where they are; true when the head confirmed it within timeout_s
  // (or, without replies, when the stop was sent).
  virtual bool stop(double now_s, double timeout_s) = 0;
  // Setpoints wait but measured() is empty: a head that lost its position (a stop during its
  // homing) finds it again. Most heads need nothing.
  virtual void findPosition(double now_s) { (void)now_s; }
  // Asks where the head is, unless a question is already out and not timed out.
  virtual void inquire(double now_s, double timeout_s) = 0;
  // Reads whatever the head has sent.
  virtual void receive(double now_s) = 0;

  // The last measured (or, see measuresPosition, estimated) pose and when; nullopt before.
  virtual std::optional<PtzPose> measured() const = 0;
  virtual double measuredAtS() const = 0;
  // False for heads that cannot report their position (most Pelco-D heads): measured() is then
  // an estimate, which PTZ_STATE carries and the status says so.
  virtual bool measuresPosition() const { return true; }
  // A descriptor that becomes readable when the head has sent something; -1 for none.
  virtual int fd() const = 0;
  virtual HeadStats& stats() = 0;
  // What keeps the head from answering now, for the status (e.g. its serial port closed until
  // the next reopen attempt); "" when nothing is known to be wrong.
  virtual std::string problem(double now_s) const {
    (void)now_s;
    return "";
  }
};

}  // namespace ptz::driver
