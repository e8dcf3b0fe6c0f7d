#include "ptz_driver/heads/visca/visca_head_core.hpp"

namespace ptz::driver {
namespace {
constexpr double kBufferFullMaxWaitS = 1.0;  // a completion lost on the way must not stall us
}

ViscaHeadCore::ViscaHeadCore(ViscaModel model, int address, bool one_inquiry_at_a_time)
    : model_(std::move(model)), address_(address), one_at_a_time_(one_inquiry_at_a_time) {}

void ViscaHeadCore::command(const PtzPose& pose, double now_s, const Send& send) {
  if (!book_.mayCommand(now_s, kBufferFullMaxWaitS)) return;
  const int32_t pan = model_.panUnits(pose.pan_rad), tilt = model_.tiltUnits(pose.tilt_rad);
  if ((book_.changed(HeadBook::kPan, pan) || book_.changed(HeadBook::kTilt, tilt)) &&
      send(visca::panTiltAbsolute(address_, model_.pan_speed_max, model_.tilt_speed_max, pan, tilt,
                                  model_.pan_nibbles),
           Request::kPanTilt)) {
    book_.sent(HeadBook::kPan, pan);
    book_.sent(HeadBook::kTilt, tilt);
  }
  const int zoom = model_.zoomPosition(pose.zoom);
  if (book_.changed(HeadBook::kZoom, zoom) &&
      send(visca::zoomDirect(address_, zoom), Request::kZoom)) {
    book_.sent(HeadBook::kZoom, zoom);
  }
}

void ViscaHeadCore::inquire(double now_s, double timeout_s, const Send& send) {
  if (!book_.inquiryDue(now_s, timeout_s)) return;
  zoom_inquiry_due_ = false;
  if (!send(visca::panTiltPositionInquiry(address_), Request::kPanTiltInquiry)) return;
  if (!one_at_a_time_) send(visca::zoomPositionInquiry(address_), Request::kZoomInquiry);
  book_.inquirySent(now_s);
}

void ViscaHeadCore::continueRound(double now_s, const Send& send) {
  if (!zoom_inquiry_due_) return;
  if (send(visca::zoomPositionInquiry(address_), Request::kZoomInquiry)) {
    zoom_inquiry_due_ = false;
    book_.inquirySent(now_s);
  }
}

bool ViscaHeadCore::stop(double timeout_s, int fd, const Send& send,
                         const std::function<void()>& receive) {
  book_.forgetSent();  // whatever comes next goes out again
  book_.bufferFreed();
  const int64_t before = stops_confirmed_;
  for (int attempt = 0; attempt < 3; ++attempt) {
    const int64_t at_attempt = stops_confirmed_;
    send(visca::panTiltStop(address_, model_.pan_speed_max, model_.tilt_speed_max), Request::kStop);
    send(visca::zoomStop(address_), Request::kStop);
    if (waitUntil(fd, timeout_s / 3, receive, [&] { return stops_confirmed_ - at_attempt >= 2; })) {
      return true;
    }
  }
  return stops_confirmed_ - before >= 2;
}

bool ViscaHeadCore::onReply(Request what, const visca::Reply& r, double sent_s, double now_s,
                            bool acked_before) {
  using Kind = visca::Reply::Kind;
  ++book_.stats().replies;
  if (what == Request::kStop && !acked_before &&
      !(r.kind == Kind::kError && r.error == visca::kBufferFull)) {
    ++stops_confirmed_;
  }
  switch (r.kind) {
    case Kind::kAck:
      return false;
    case Kind::kCompletion:
      book_.bufferFreed();  // a socket is free again
      return true;
    case Kind::kError:
      book_.error(visca::errorName(r.error));
      if (r.error == visca::kBufferFull) book_.bufferFull(now_s);
      if (what == Request::kPanTilt || what == Request::kZoom) book_.forgetSent();  // again
      if (!isCommand(what)) book_.roundDone();  // the inquiry was refused: ask again
      return true;
    case Kind::kInquiry:
      break;
    default:
      ++book_.stats().malformed;
      return true;
  }
  int32_t pan = 0, tilt = 0;
  int zoom = 0;
  if (what == Request::kPanTiltInquiry &&
      visca::decodePanTiltPosition(r, model_.pan_nibbles, &pan, &tilt)) {
    book_.measured(HeadBook::kPan, pan);
    book_.measured(HeadBook::kTilt, tilt);
    book_.roundTrip(sent_s, now_s);
    zoom_inquiry_due_ = one_at_a_time_;
  } else if (what == Request::kZoomInquiry && visca::decodeZoomPosition(r, &zoom)) {
    book_.measured(HeadBook::kZoom, zoom);
    book_.roundDone();  // both answered: the next round may go
  } else {
    ++book_.stats().malformed;  // an answer that is not what was asked
  }
  return true;
}

bool ViscaHeadCore::answers(Request what, const visca::Reply& r) const {
  int32_t pan = 0, tilt = 0;
  int zoom = 0;
  return what == Request::kPanTiltInquiry
             ? visca::decodePanTiltPosition(r, model_.pan_nibbles, &pan, &tilt)
             : what == Request::kZoomInquiry && visca::decodeZoomPosition(r, &zoom);
}

bool ViscaHeadCore::onLateReply(const visca::Reply& r) {
  using Kind = visca::Reply::Kind;
  ++book_.stats().late_replies;
  switch (r.kind) {
    case Kind::kAck:
      return false;
    case Kind::kCompletion:
      book_.bufferFreed();
      return true;
    case Kind::kError:
      book_.error(visca::errorName(r.error));  // by name; too old to hold commands back
      return true;
    default:
      return true;
  }
}

void ViscaHeadCore::lost(Request what) {
  if (isCommand(what)) {
    ++book_.stats().timeouts;
    if (what != Request::kStop) book_.forgetSent();
    return;
  }
  if (book_.inquiryOut()) ++book_.stats().timeouts;  // once per round
  zoom_inquiry_due_ = false;
  book_.roundDone();
}

std::optional<PtzPose> ViscaHeadCore::measured() const {
  if (!book_.hasMeasurement()) return std::nullopt;
  return PtzPose{model_.panRad(book_.measuredUnits(HeadBook::kPan)),
                 model_.tiltRad(book_.measuredUnits(HeadBook::kTilt)),
                 model_.zoomRatio(book_.measuredUnits(HeadBook::kZoom))};
}

}  // namespace ptz::driver
