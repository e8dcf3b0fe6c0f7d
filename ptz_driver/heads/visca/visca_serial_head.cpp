#include "ptz_driver/heads/visca/visca_serial_head.hpp"

#include <algorithm>

namespace ptz::driver {
namespace {
constexpr double kCompletionMaxWaitS = 30.0;  // an absolute move takes at most this long
bool isCommand(ViscaHeadCore::Request r) {
  return ViscaHeadCore::isCommand(r);
}
bool isInquiry(ViscaHeadCore::Request r) {
  return !ViscaHeadCore::isCommand(r);
}
bool isAny(ViscaHeadCore::Request) {
  return true;
}
}  // namespace

ViscaSerialHead::ViscaSerialHead(ViscaModel model, std::shared_ptr<ViscaSerialLine> line,
                                 int address)
    : core_(std::move(model), address, true), line_(std::move(line)) {
  line_->attach(address);
}

ViscaHeadCore::Send ViscaSerialHead::sender(double now_s, bool paced) {
  return [this, now_s, paced](const Bytes& packet, Request what) {
    // One pan-tilt and one zoom command at a time on their way to an ACK.
    if (paced && isCommand(what) &&
        std::any_of(awaiting_.begin(), awaiting_.end(),
                    [what](const Pending& p) { return p.what == what && !p.late(); })) {
      return false;
    }
    if (!line_->send(packet)) return false;
    ++core_.stats().sent;
    awaiting_.push_back({what, now_s});
    return true;
  };
}

void ViscaSerialHead::start(double now_s) {
  (void)now_s;
  if (!line_->firstStart()) return;  // the other camera of the chain did it
  for (const Bytes& b : {visca::addressSet(), visca::ifClear()}) {
    if (line_->send(b)) ++core_.stats().sent;
  }
}

void ViscaSerialHead::followReopen(double now_s) {
  if (line_->reopens() == line_reopens_) return;
  line_reopens_ = line_->reopens();
  awaiting_.clear();  // their replies died with the old port: none is matched to a new request
  sockets_.clear();
  core_.lostTrack();
  start(now_s);
}

void ViscaSerialHead::command(const PtzPose& pose, double now_s) {
  followReopen(now_s);
  core_.command(pose, now_s, sender(now_s, true));
}

bool ViscaSerialHead::stop(double now_s, double timeout_s) {
  return core_.stop(timeout_s, line_->fd(), sender(now_s, false), [&] { receive(now_s); });
}

void ViscaSerialHead::inquire(double now_s, double timeout_s) {
  followReopen(now_s);
  for (auto it = awaiting_.begin(); it != awaiting_.end();) {
    if (it->late() && now_s > it->late_until_s) {
      it = awaiting_.erase(it);  // its reply was lost indeed
      continue;
    }
    if (!it->late() && now_s - it->sent_s > timeout_s) {
      core_.lost(it->what);
      it->late_until_s = now_s + timeout_s;
    }
    ++it;
  }
  for (auto it = sockets_.begin(); it != sockets_.end();) {
    it = now_s - it->second.sent_s > kCompletionMaxWaitS ? sockets_.erase(it) : std::next(it);
  }
  core_.inquire(now_s, timeout_s, sender(now_s, true));
}

void ViscaSerialHead::receive(double now_s) {
  line_->pump(&core_.book(), now_s);
  followReopen(now_s);
  while (const auto r = line_->nextUnrouted()) onBroadcast(*r);
  while (const auto r = line_->next(core_.address())) handle(*r, now_s);
  core_.continueRound(now_s, sender(now_s, true));
}

void ViscaSerialHead::onBroadcast(const visca::Reply& r) {
  using Kind = visca::Reply::Kind;
  if (r.kind != Kind::kIfClear && (r.kind != Kind::kAddress || r.bytes.size() != 4)) {
    ++core_.stats().malformed;  // a reply from an address no head has
    return;
  }
  ++core_.stats().replies;
  if (r.kind == Kind::kIfClear) return;
  // Address Set comes back with the next free address: the chain has one camera fewer.
  const int cameras = r.bytes[2] - 1;
  for (int a : line_->addresses()) {
    if (a > cameras) {
      core_.book().error("no camera at VISCA address " + std::to_string(a) + " on " +
                         line_->device() + ": Address Set found " + std::to_string(cameras));
    }
  }
}

std::optional<ViscaSerialHead::Pending> ViscaSerialHead::takeFirst(
    const std::function<bool(Request)>& fits) {
  const auto it = std::find_if(awaiting_.begin(), awaiting_.end(),
                               [fits](const Pending& p) { return fits(p.what); });
  if (it == awaiting_.end()) return std::nullopt;
  // Replies come in order: whatever was sent before this one lost its reply (the late ones
  // were counted when they timed out).
  for (auto lost = awaiting_.begin(); lost != it; ++lost) {
    if (!lost->late()) core_.lost(lost->what);
  }
  const Pending p = *it;
  awaiting_.erase(awaiting_.begin(), it + 1);
  return p;
}

void ViscaSerialHead::handle(const visca::Reply& r, double now_s) {
  using Kind = visca::Reply::Kind;
  std::optional<Pending> p;
  bool acked_before = false;
  const auto in_socket = sockets_.find(r.socket);
  if ((r.kind == Kind::kCompletion || r.kind == Kind::kError) && r.socket != 0 &&
      in_socket != sockets_.end()) {
    p = in_socket->second;  // the end of a command the camera took
    acked_before = true;
    sockets_.erase(in_socket);
  } else if (r.kind == Kind::kAck || r.kind == Kind::kCompletion) {
    p = takeFirst(isCommand);  // a completion without its ACK: the ACK was lost
  } else if (r.kind == Kind::kInquiry) {
    // By its shape: a late zoom inquiry ahead must not take the pan-tilt answer.
    p = takeFirst([&](Request what) { return isInquiry(what) && core_.answers(what, r); });
  } else if (r.kind == Kind::kError) {
    p = takeFirst(isAny);  // refused on arrival: the oldest request
  }
  if (!p) {
    ++core_.stats().malformed;  // a reply to nothing we asked
    return;
  }
  const bool done =
      p->late() ? core_.onLateReply(r) : core_.onReply(p->what, r, p->sent_s, now_s, acked_before);
  if (!done) sockets_[r.socket] = *p;  // ACKed: its completion will name the socket
}

}  // namespace ptz::driver
