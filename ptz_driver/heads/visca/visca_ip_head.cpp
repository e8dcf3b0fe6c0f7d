#include "ptz_driver/heads/visca/visca_ip_head.hpp"

namespace ptz::driver {

ViscaIpHead::ViscaIpHead(ViscaModel model, const std::string& host, int port, int address)
    : core_(std::move(model), address, false) {
  socket_.connect(host, port);
}

ViscaHeadCore::Send ViscaIpHead::sender(double now_s) {
  return [this, now_s](const Bytes& packet, Request what) {
    const uint32_t seq = sequence_++;
    const uint16_t type = ViscaHeadCore::isCommand(what) ? visca_ip::kCommand : visca_ip::kInquiry;
    if (!socket_.send(visca_ip::wrap(type, seq, packet))) return false;
    ++core_.stats().sent;
    outstanding_[seq] = {what, now_s, false};
    return true;
  };
}

void ViscaIpHead::start(double now_s) {
  (void)now_s;
  if (socket_.send(visca_ip::resetSequence(sequence_))) ++core_.stats().sent;
  sequence_ = 0;  // the camera expects 0 next
}

void ViscaIpHead::command(const PtzPose& pose, double now_s) {
  core_.command(pose, now_s, sender(now_s));
}

bool ViscaIpHead::stop(double now_s, double timeout_s) {
  return core_.stop(timeout_s, socket_.fd(), sender(now_s), [&] { receive(now_s); });
}

void ViscaIpHead::inquire(double now_s, double timeout_s) {
  // Forget requests unanswered for longer than the timeout: a lost datagram is not coming.
  for (auto it = outstanding_.begin(); it != outstanding_.end();) {
    const Pending& p = it->second;
    // An acknowledged command may take as long as its motion; one never acknowledged is lost.
    if (now_s - p.sent_s <= (p.acked ? 30.0 : timeout_s)) {
      ++it;
      continue;
    }
    if (!p.acked) core_.lost(p.what);
    it = outstanding_.erase(it);
  }
  core_.inquire(now_s, timeout_s, sender(now_s));
}

void ViscaIpHead::receive(double now_s) {
  Bytes datagram;
  while (socket_.receive(&datagram)) {
    visca_ip::Message m;
    std::string error;
    if (!visca_ip::unwrap(datagram.data(), datagram.size(), &m, &error)) {
      ++core_.stats().malformed;
      continue;
    }
    const auto it = outstanding_.find(m.sequence);
    if (m.type == visca_ip::kControlReply || it == outstanding_.end()) continue;
    visca::ReplyParser parser;
    parser.feed(m.payload.data(), m.payload.size());
    core_.stats().malformed += parser.malformed();
    bool done = false;  // the request is answered for good (not just acknowledged)
    while (const auto r = parser.next()) {
      Pending& p = it->second;
      done |= core_.onReply(p.what, *r, p.sent_s, now_s, p.acked);
      p.acked |= r->kind == visca::Reply::Kind::kAck;
    }
    if (done) outstanding_.erase(it);
  }
}

}  // namespace ptz::driver
