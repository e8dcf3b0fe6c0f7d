// One Pelco-D head with absolute positioning (0x4B pan, 0x4D tilt, 0x4F zoom) on an RS-485 bus
// it may share with others (replies routed by address). The bus is half duplex and slow (a
// frame is 7 bytes, 29 ms at 2400 baud): a head talks only when the line has sent what it had
// and no reply is awaited, heads on one bus take turns, and a head alternates its commands with
// its position queries, so the newest pose goes and the position still gets read.
//   position_query: the head answers 0x51/0x53/0x55 with 0x59/0x5B/0x5D: measured() is
//     measured, one query at a time (pan, then tilt, then zoom), dated mid pan round trip.
//   otherwise (most heads): measuresPosition() is false and measured() is an estimate of where
//     the commanded motion has got to, from the shared plant model (Pt1Axis with the
//     configured limits). start() sends the head home and the estimate begins there once the
//     longest move home would have ended; a stop before then leaves the pose unknown until
//     the head has been sent home again (by the next command or findPosition). Nothing
//     confirms a command or the stop.
// After the line's port was reopened (adapter unplugged and back) the query out and the
// commands sent are forgotten and the pose is unknown until measured again (position_query)
// or, estimated, until the head has been sent home again (as after a stop during homing).
#pragma once

#include <array>
#include <memory>
#include <optional>

#include "common/plant.hpp"
#include "ptz_driver/heads/common/head.hpp"
#include "ptz_driver/heads/common/head_book.hpp"
#include "ptz_driver/heads/common/serial_line.hpp"
#include "ptz_driver/heads/pelco_d/pelco_d.hpp"
#include "ptz_driver/heads/pelco_d/pelco_model.hpp"

namespace ptz::driver {

using PelcoDLine = SerialLine<pelco_d::ReplyParser, pelco_d::Reply>;

class PelcoDHead : public PtzHead {
 public:
  // The head at `address` (1..255, its DIP switches) on `line`; plant: the motor model and
  // limits of the estimate (without position_query).
  PelcoDHead(PelcoModel model, std::shared_ptr<PelcoDLine> line, int address, bool position_query,
             const PtzPlant::Params& plant);

  void start(double now_s) override;
  void command(const PtzPose& pose, double now_s) override;
  // Waits (reading replies) for the bus to be free, then sends the stop frame
  // (FF aa 00 00 00 00 cs) twice; true when the bus was free and both frames have left the
  // port within timeout_s. Pelco-D heads do not confirm it.
  bool stop(double now_s, double timeout_s) override;
  // After a stop during the homing: sends the head home again.
  void findPosition(double now_s) override;
  void inquire(double now_s, double timeout_s) override;
  void receive(double now_s) override;

  std::optional<PtzPose> measured() const override;
  double measuredAtS() const override;
  bool measuresPosition() const override { return position_query_; }
  int fd() const override { return line_->fd(); }
  HeadStats& stats() override { return book_.stats(); }
  std::string problem(double now_s) const override { return line_->problem(now_s); }

 private:
  // Sends what waits when the bus is free: the commands for the newest pose, or the next
  // position query, taking turns.
  void service(double now_s);
  // After a reopen of the line: forgets what was sent and asked; the pose is unknown.
  void followReopen();
  // False when a frame could not be sent (the port closed).
  bool sendCommands(double now_s);
  void sendQuery(double now_s);
  void sendHome(double now_s);
  bool send(const Bytes& frame);
  // Takes the replies that came (routing, matching them to the query out); sends nothing.
  void read(double now_s);
  // The estimate's clock: seconds since start() (the plant model counts from 0).
  double sinceStartS(double now_s) const { return now_s - start_s_; }
  void estimateTo(double now_s);

  PelcoModel model_;
  std::shared_ptr<PelcoDLine> line_;
  int address_;
  bool position_query_;
  PtzPlant::Params plant_;
  HeadBook book_;
  std::optional<PtzPose> wanted_;  // the newest commanded pose
  bool command_turn_ = true;       // commands and queries alternate
  double timeout_s_ = 0.1;
  // position_query: the query awaiting its reply and when it went; the next one of the round.
  std::optional<HeadBook::Axis> query_, next_query_;
  double query_sent_s_ = 0;
  // Without position_query: pan, tilt, zoom as the plant model moves them, valid once homed.
  std::array<Pt1Axis, 3> estimate_;
  double start_s_ = 0, homed_at_s_ = -1, estimate_at_s_ = 0;
  bool position_unknown_ = false;  // stopped before home, or reopened: home first
  int64_t line_reopens_ = 0;       // the line's reopens this head has followed
};

}  // namespace ptz::driver
