// One PTZ camera over serial VISCA (RS-232/RS-422), alone on its port or on a daisy chain that
// shares one (replies routed by the address in their header). No sequence numbers: a command
// gets an ACK (y0 4z FF, z its socket) then a completion (y0 5z FF) or an error (y0 6z EE FF);
// an inquiry gets its answer directly; replies come in the order the requests went. So requests
// wait in a FIFO for their ACK or answer, and ACKed commands by socket for their completion.
// The camera takes one inquiry at a time (the zoom inquiry follows the pan-tilt answer) and has
// two command sockets; at most one pan-tilt and one zoom command wait for an ACK, which paces
// the commands to what the line and the camera take. A request unanswered for the timeout is
// counted lost, but its reply may still come on a busy line: it stays in the FIFO, late, for
// one more timeout, so a late reply is taken (and counted) as its own, never as the reply to a
// newer request. After the line's port was reopened (adapter unplugged and back) the head starts
// over: pending requests forgotten, Address Set and IF_Clear again, the position unknown until
// answered again. The rest is ViscaHeadCore (shared with VISCA over IP).
#pragma once

#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>

#include "ptz_driver/heads/common/head.hpp"
#include "ptz_driver/heads/common/serial_line.hpp"
#include "ptz_driver/heads/visca/visca.hpp"
#include "ptz_driver/heads/visca/visca_head_core.hpp"

namespace ptz::driver {

using ViscaSerialLine = SerialLine<visca::ReplyParser, visca::Reply>;

class ViscaSerialHead : public PtzHead {
 public:
  // The camera at `address` (1..7, as Address Set numbers the chain) on `line`.
  ViscaSerialHead(ViscaModel model, std::shared_ptr<ViscaSerialLine> line, int address);

  // Once per line (and after each reopen): Address Set (88 30 01 FF) and IF_Clear
  // (88 01 00 01 FF), broadcast.
  void start(double now_s) override;
  void command(const PtzPose& pose, double now_s) override;
  // Sends the stops (whatever waits) until the camera acknowledges both, within timeout_s.
  bool stop(double now_s, double timeout_s) override;
  // Counts requests unanswered for timeout_s as lost (a command goes again; their late replies
  // are still taken for one more timeout_s), then asks.
  void inquire(double now_s, double timeout_s) override;
  void receive(double now_s) override;

  std::optional<PtzPose> measured() const override { return core_.measured(); }
  double measuredAtS() const override { return core_.measuredAtS(); }
  int fd() const override { return line_->fd(); }
  HeadStats& stats() override { return core_.stats(); }
  std::string problem(double now_s) const override { return line_->problem(now_s); }

 private:
  using Request = ViscaHeadCore::Request;
  struct Pending {
    Request what;
    double sent_s;
    double late_until_s = -1;  // >= 0: timed out (counted); its reply is taken until then
    bool late() const { return late_until_s >= 0; }
  };
  // After a reopen of the line: forgets what was pending and measured, starts again.
  void followReopen(double now_s);
  ViscaHeadCore::Send sender(double now_s, bool paced);
  void handle(const visca::Reply& r, double now_s);
  void onBroadcast(const visca::Reply& r);
  // The first request waiting in the FIFO that `fits`; those before it were lost on the way.
  std::optional<Pending> takeFirst(const std::function<bool(Request)>& fits);

  ViscaHeadCore core_;
  std::shared_ptr<ViscaSerialLine> line_;
  std::deque<Pending> awaiting_;    // sent, in order: awaiting an ACK or an answer
  std::map<int, Pending> sockets_;  // ACKed commands by socket: awaiting their completion
  int64_t line_reopens_ = 0;        // the line's reopens this head has followed
};

}  // namespace ptz::driver
