#include "ptz_driver/visca_ip_head.hpp"

#include <poll.h>

#include <chrono>
#include <cstdlib>

namespace ptz::driver {

ViscaIpHead::ViscaIpHead(ViscaModel model, const std::string& host, int port, int address)
    : model_(std::move(model)), address_(address) {
  socket_.connect(host, port);
}

bool ViscaIpHead::send(uint16_t type, const Bytes& payload, Request what, double now_s) {
  const uint32_t seq = sequence_++;
  if (!socket_.send(visca_ip::wrap(type, seq, payload))) return false;
  ++stats_.sent;
  outstanding_[seq] = {what, now_s, false};
  return true;
}

void ViscaIpHead::start(double now_s) {
  send(visca_ip::kControl, {0x01}, Request::kReset, now_s);
  sequence_ = 0;  // the camera expects 0 next
}

void ViscaIpHead::command(const PtzPose& pose, double now_s) {
  if (buffer_full_) return;  // wait for a reply before sending more
  const int32_t pan = model_.panUnits(pose.pan_rad), tilt = model_.tiltUnits(pose.tilt_rad);
  // Remembered only once sent: a command that did not leave is sent again next time.
  if ((pan != sent_pan_ || tilt != sent_tilt_) &&
      send(visca_ip::kCommand,
           visca::panTiltAbsolute(address_, model_.pan_speed_max, model_.tilt_speed_max, pan, tilt,
                                  model_.pan_nibbles),
           Request::kCommand, now_s)) {
    sent_pan_ = pan;
    sent_tilt_ = tilt;
  }
  const int zoom = model_.zoomPosition(pose.zoom);
  if (zoom != sent_zoom_ &&
      send(visca_ip::kCommand, visca::zoomDirect(address_, zoom), Request::kCommand, now_s)) {
    sent_zoom_ = zoom;
  }
}

bool ViscaIpHead::stop(double now_s, double timeout_s) {
  // Motion must stop: sent again until the camera answers both, within the timeout.
  sent_pan_.reset();
  sent_tilt_.reset();
  sent_zoom_.reset();
  const int64_t replies_before = stats_.replies;
  for (int attempt = 0; attempt < 3; ++attempt) {
    send(visca_ip::kCommand,
         visca::panTiltStop(address_, model_.pan_speed_max, model_.tilt_speed_max),
         Request::kCommand, now_s);
    send(visca_ip::kCommand, visca::zoomStop(address_), Request::kCommand, now_s);
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::microseconds(static_cast<int64_t>(timeout_s * 1e6 / 3));
    while (std::chrono::steady_clock::now() < deadline) {
      pollfd pfd{socket_.fd(), POLLIN, 0};
      ::poll(&pfd, 1, 5);
      receive(now_s);
      if (stats_.replies - replies_before >= 2) return true;
    }
  }
  return false;
}

void ViscaIpHead::inquire(double now_s, double timeout_s) {
  if (inquiry_sent_s_ >= 0 && now_s - inquiry_sent_s_ < timeout_s) return;
  if (inquiry_sent_s_ >= 0) ++stats_.timeouts;
  // Forget unanswered requests older than the timeout: a lost datagram is not coming. A lost
  // command is sent again (the next command() call).
  for (auto it = outstanding_.begin(); it != outstanding_.end();) {
    const Pending& p = it->second;
    // An acknowledged command may take as long as its motion; one never acknowledged is lost.
    if (now_s - p.sent_s <= (p.acked ? 30.0 : timeout_s)) {
      ++it;
      continue;
    }
    if (p.what == Request::kCommand && !p.acked) {
      sent_pan_.reset();
      sent_tilt_.reset();
      sent_zoom_.reset();
    }
    it = outstanding_.erase(it);
  }
  send(visca_ip::kInquiry, visca::panTiltPositionInquiry(address_), Request::kPanTiltInquiry,
       now_s);
  send(visca_ip::kInquiry, visca::zoomPositionInquiry(address_), Request::kZoomInquiry, now_s);
  inquiry_sent_s_ = now_s;
}

void ViscaIpHead::receive(double now_s) {
  Bytes datagram;
  while (socket_.receive(&datagram)) {
    visca_ip::Message m;
    std::string error;
    if (!visca_ip::unwrap(datagram.data(), datagram.size(), &m, &error)) {
      ++stats_.malformed;
      continue;
    }
    const auto it = outstanding_.find(m.sequence);
    if (m.type == visca_ip::kControlReply || it == outstanding_.end()) continue;
    visca::ReplyParser parser;
    parser.feed(m.payload.data(), m.payload.size());
    bool done = false;  // the request is answered for good (not just acknowledged)
    stats_.malformed += parser.malformed();
    while (const auto r = parser.next()) {
      ++stats_.replies;
      buffer_full_ = false;
      const Request what = it->second.what;
      const double sent_s = it->second.sent_s;
      if (r->kind == visca::Reply::Kind::kError) {
        done = true;
        ++stats_.errors;
        stats_.last_error = visca::errorName(r->error);
        if (r->error == visca::kBufferFull) {
          ++stats_.buffer_full;
          buffer_full_ = true;
        }
        if (what == Request::kCommand) {  // refused: send it again (when there is room)
          sent_pan_.reset();
          sent_tilt_.reset();
          sent_zoom_.reset();
        }
        continue;
      }
      if (r->kind == visca::Reply::Kind::kAck) {  // completion or error still to come
        it->second.acked = true;
        continue;
      }
      if (r->kind != visca::Reply::Kind::kInquiry) {
        done = true;
        continue;
      }
      done = true;
      int32_t pan = 0, tilt = 0;
      int zoom = 0;
      if (what == Request::kPanTiltInquiry &&
          visca::decodePanTiltPosition(*r, model_.pan_nibbles, &pan, &tilt)) {
        pan_units_ = pan;
        tilt_units_ = tilt;
        stats_.round_trip_ms.push_back((now_s - sent_s) * 1000);
        measured_at_s_ = (sent_s + now_s) / 2;
      } else if (what == Request::kZoomInquiry && visca::decodeZoomPosition(*r, &zoom)) {
        zoom_position_ = zoom;
        inquiry_sent_s_ = -1;  // both answered: the next inquiry may go
      }
    }
    if (done) outstanding_.erase(it);
  }
}

std::optional<PtzPose> ViscaIpHead::measured() const {
  if (!pan_units_ || !zoom_position_) return std::nullopt;
  return PtzPose{model_.panRad(*pan_units_), model_.tiltRad(*tilt_units_),
                 model_.zoomRatio(*zoom_position_)};
}

}  // namespace ptz::driver
