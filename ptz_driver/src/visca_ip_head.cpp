#include "ptz_driver/visca_ip_head.hpp"

#include <cstdlib>

namespace ptz::driver {

ViscaIpHead::ViscaIpHead(ViscaModel model, const std::string& host, int port, int address)
    : model_(std::move(model)), address_(address) {
  socket_.connect(host, port);
}

void ViscaIpHead::send(uint16_t type, const Bytes& payload, Request what, double now_s) {
  const uint32_t seq = sequence_++;
  if (socket_.send(visca_ip::wrap(type, seq, payload))) {
    ++stats_.sent;
    outstanding_[seq] = {what, now_s};
  }
}

void ViscaIpHead::start(double now_s) {
  send(visca_ip::kControl, {0x01}, Request::kReset, now_s);
  sequence_ = 0;  // the camera expects 0 next
}

void ViscaIpHead::command(const PtzPose& pose, double now_s) {
  if (buffer_full_) return;  // wait for a reply before sending more
  const int32_t pan = model_.panUnits(pose.pan_rad), tilt = model_.tiltUnits(pose.tilt_rad);
  if (pan != sent_pan_ || tilt != sent_tilt_) {
    send(visca_ip::kCommand,
         visca::panTiltAbsolute(address_, model_.pan_speed_max, model_.tilt_speed_max, pan, tilt,
                                model_.pan_nibbles),
         Request::kCommand, now_s);
    sent_pan_ = pan;
    sent_tilt_ = tilt;
  }
  const int zoom = model_.zoomPosition(pose.zoom);
  if (zoom != sent_zoom_) {
    send(visca_ip::kCommand, visca::zoomDirect(address_, zoom), Request::kCommand, now_s);
    sent_zoom_ = zoom;
  }
}

void ViscaIpHead::stop(double now_s) {
  send(visca_ip::kCommand,
       visca::panTiltStop(address_, model_.pan_speed_max, model_.tilt_speed_max), Request::kCommand,
       now_s);
  send(visca_ip::kCommand, visca::zoomStop(address_), Request::kCommand, now_s);
  sent_pan_.reset();
  sent_tilt_.reset();
  sent_zoom_.reset();
}

void ViscaIpHead::inquire(double now_s, double timeout_s) {
  if (inquiry_sent_s_ >= 0 && now_s - inquiry_sent_s_ < timeout_s) return;
  if (inquiry_sent_s_ >= 0) ++stats_.timeouts;
  // Forget unanswered requests older than the timeout: a lost datagram is not coming.
  for (auto it = outstanding_.begin(); it != outstanding_.end();) {
    it = now_s - it->second.second > timeout_s ? outstanding_.erase(it) : std::next(it);
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
    stats_.malformed += parser.malformed();
    while (const auto r = parser.next()) {
      ++stats_.replies;
      buffer_full_ = false;
      const Request what = it->second.first;
      const double sent_s = it->second.second;
      if (r->kind == visca::Reply::Kind::kError) {
        ++stats_.errors;
        stats_.last_error = visca::errorName(r->error);
        if (r->error == visca::kBufferFull) {
          ++stats_.buffer_full;
          buffer_full_ = true;
          sent_pan_.reset();  // send it again when there is room
          sent_zoom_.reset();
        }
        continue;
      }
      if (r->kind != visca::Reply::Kind::kInquiry) continue;
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
    outstanding_.erase(it);  // a command's completion after its ACK finds nothing: fine
  }
}

std::optional<PtzPose> ViscaIpHead::measured() const {
  if (!pan_units_ || !zoom_position_) return std::nullopt;
  return PtzPose{model_.panRad(*pan_units_), model_.tiltRad(*tilt_units_),
                 model_.zoomRatio(*zoom_position_)};
}

}  // namespace ptz::driver
