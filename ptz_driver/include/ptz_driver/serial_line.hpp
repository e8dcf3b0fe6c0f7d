// One serial line and the heads on it: a VISCA daisy chain or a Pelco-D RS-485 bus carries
// several heads on one port, so the port and the reply parser are shared and every reply is
// routed by the address in it. A line with one head is the same thing with one address.
#pragma once

#include <deque>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "ptz_driver/head_book.hpp"
#include "ptz_driver/pelco_d.hpp"
#include "ptz_driver/serial_port.hpp"
#include "ptz_driver/visca.hpp"

namespace ptz::driver {

// What each parser counts as garbage (bad packets, skipped bytes, bad checksums).
inline int64_t garbageOf(const visca::ReplyParser& p) {
  return p.malformed();
}
inline int64_t garbageOf(const pelco_d::ReplyParser& p) {
  return p.badChecksums() + p.skippedBytes();
}

template <class Parser, class Reply>
class SerialLine {
 public:
  SerialLine(const std::string& device, int baud, const std::string& baud_parameter)
      : port_(device, baud, baud_parameter) {}

  void attach(int address) { inbox_[address]; }
  std::vector<int> addresses() const {
    std::vector<int> a;
    for (const auto& [address, inbox] : inbox_) a.push_back(address);
    return a;
  }
  // True the first time only: what a line needs once (VISCA's Address Set) goes once.
  bool firstStart() { return !std::exchange(started_, true); }

  bool send(const Bytes& packet) {
    if (port_.write(packet)) return true;
    error_ = port_.error();
    return false;
  }
  // Nothing left to go out: the next packet may be sent (the line's pace, not ours).
  bool idle() { return port_.outputPending() == 0; }
  // A half-duplex bus (RS-485): one talks at a time, nobody while a reply is awaited, and the
  // heads that want the bus take turns (the last to talk waits while another wants it).
  // The reply from `address` is awaited until until_s; it has come once pump() has it whole,
  // whichever head reads it (a stop must not wait for a reply already in).
  void awaitReply(int address, double until_s) {
    awaited_from_ = address;
    reply_awaited_until_s_ = until_s;
  }
  // The reply from `address` came (or will not): the bus is free, unless another's is awaited.
  void replyCame(int address) {
    if (address == awaited_from_) reply_awaited_until_s_ = -1;
  }
  // Nothing goes out and no reply is awaited: what is sent now collides with nothing.
  bool free(double now_s) { return now_s >= reply_awaited_until_s_ && idle(); }
  bool mayTalk(int address, double now_s) {
    wanting_.insert(address);
    if (!free(now_s)) return false;
    return last_talker_ != address || wanting_.size() == 1;
  }
  void talked(int address) {
    last_talker_ = address;
    wanting_.erase(address);
  }
  void doesNotWant(int address) { wanting_.erase(address); }

  // Reads what arrived and routes every reply to its address's inbox; replies from addresses
  // nobody attached and broadcasts go to unrouted. The garbage seen since the last call and a
  // transport error (the device gone; once, until it works again) go to the caller's book, so
  // a shared line's are counted once.
  void pump(HeadBook* book) {
    Bytes data;
    const bool ok = port_.read(&data) && error_.empty();
    if (!ok && !failed_) book->error(error_.empty() ? port_.error() : error_);  // once
    failed_ = !ok;
    error_.clear();
    parser_.feed(data.data(), data.size());
    while (auto r = parser_.next()) {
      replyCame(r->address);
      const auto it = inbox_.find(r->address);
      (it == inbox_.end() ? unrouted_ : it->second).push_back(std::move(*r));
    }
    const int64_t garbage = garbageOf(parser_);
    book->stats().malformed += garbage - std::exchange(garbage_counted_, garbage);
  }
  std::optional<Reply> next(int address) { return pop(&inbox_[address]); }
  std::optional<Reply> nextUnrouted() { return pop(&unrouted_); }

  // -1 once the device has failed: a hung-up descriptor would wake every poll at once.
  int fd() const { return failed_ ? -1 : port_.fd(); }
  const std::string& device() const { return port_.device(); }

 private:
  static std::optional<Reply> pop(std::deque<Reply>* q) {
    if (q->empty()) return std::nullopt;
    Reply r = std::move(q->front());
    q->pop_front();
    return r;
  }

  SerialPort port_;
  Parser parser_;
  std::map<int, std::deque<Reply>> inbox_;
  std::deque<Reply> unrouted_;
  int64_t garbage_counted_ = 0;
  bool started_ = false;
  double reply_awaited_until_s_ = -1;
  int awaited_from_ = -1;
  std::set<int> wanting_;
  int last_talker_ = -1;
  std::string error_;  // of a write
  bool failed_ = false;
};

using ViscaSerialLine = SerialLine<visca::ReplyParser, visca::Reply>;
using PelcoDLine = SerialLine<pelco_d::ReplyParser, pelco_d::Reply>;

}  // namespace ptz::driver
