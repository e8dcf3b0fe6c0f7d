// What the VISCA heads share, whatever carries the bytes (UDP with sequence numbers, or a
// serial line where replies come in order): the commands for what changed by a unit, the
// position inquiries and their answers decoded into a pose, round trips, errors by name,
// "command buffer full", and the confirmed stop. The transports only match replies to requests.
#pragma once

#include <functional>
#include <optional>

#include "ptz_driver/heads/common/head_book.hpp"
#include "ptz_driver/heads/visca/visca_model.hpp"

namespace ptz::driver {

class ViscaHeadCore {
 public:
  // What a packet asked; commands are kPanTilt and after.
  enum class Request { kPanTiltInquiry, kZoomInquiry, kPanTilt, kZoom, kStop };
  static bool isCommand(Request r) { return r >= Request::kPanTilt; }
  // Sends one packet; true when it left (only then is it remembered as sent).
  using Send = std::function<bool(const Bytes& packet, Request what)>;

  // one_inquiry_at_a_time: the camera takes one inquiry at a time (serial VISCA): the zoom
  // inquiry follows the pan-tilt answer (continueRound) instead of going with it.
  ViscaHeadCore(ViscaModel model, int address, bool one_inquiry_at_a_time);

  // Sends pan-tilt and zoom absolute commands for the axes that changed by a unit (clamped to
  // the model's range); after "command buffer full" nothing until a completion (or 1 s).
  void command(const PtzPose& pose, double now_s, const Send& send);
  // Starts a round of position inquiries (pan-tilt and zoom) when the last one is answered or
  // has waited timeout_s (counted).
  void inquire(double now_s, double timeout_s, const Send& send);
  // One at a time: sends the zoom inquiry once the pan-tilt one is answered.
  void continueRound(double now_s, const Send& send);
  // Sends the stops until the camera has answered both (ACK, completion or error other than
  // buffer full), at most three times within timeout_s, reading through receive().
  bool stop(double timeout_s, int fd, const Send& send, const std::function<void()>& receive);

  // One reply to a request `what` sent at sent_s (acked_before: its ACK came earlier). True
  // when the request is answered for good; false for an ACK (a completion is still to come).
  bool onReply(Request what, const visca::Reply& reply, double sent_s, double now_s,
               bool acked_before);
  // Whether an inquiry answer has the shape of the answer to `what` (pan-tilt or zoom).
  bool answers(Request what, const visca::Reply& reply) const;
  // A reply to a request already counted lost: counted (HeadStats::late_replies), an error
  // named, a freed socket noted; not measured (its time is unknown to the round now out).
  // False for an ACK, as onReply.
  bool onLateReply(const visca::Reply& reply);
  // A request went unanswered: counted (an inquiry round once); a command goes again with the
  // next command().
  void lost(Request what);

  // The link was down: nothing sent, asked or measured stands (HeadBook::lostTrack).
  void lostTrack() {
    book_.lostTrack();
    zoom_inquiry_due_ = false;
  }

  std::optional<PtzPose> measured() const;
  double measuredAtS() const { return book_.measuredAtS(); }
  HeadStats& stats() { return book_.stats(); }
  HeadBook& book() { return book_; }
  const ViscaModel& model() const { return model_; }
  int address() const { return address_; }

 private:
  ViscaModel model_;
  int address_;
  HeadBook book_;
  bool one_at_a_time_;
  bool zoom_inquiry_due_ = false;  // one at a time: the pan-tilt answer is in
  int64_t stops_confirmed_ = 0;
};

}  // namespace ptz::driver
