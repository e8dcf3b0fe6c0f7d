// One serial line and the heads on it: a VISCA daisy chain or a Pelco-D RS-485 bus carries
// several heads on one port, so the port and the reply parser are shared and every reply is
// routed by the address in it. A line with one head is the same thing with one address.
// A port that fails (hang-up, read or write error: the adapter unplugged) is closed and the
// same device path opened again with back-off (0.5 s doubling to 8 s), so a driver that runs
// for hours recovers when the adapter comes back. A reopened line starts over: nothing
// pending, nothing started (reopens() tells the heads to forget theirs too).
// No protocol here: Parser is the protocol's reply parser (feed(data, size); next() ->
// optional<Reply> with an `address`; garbage(): bad bytes and packets so far), Reply its reply;
// each protocol folder names its line (ViscaSerialLine, PelcoDLine).
#pragma once

#include <algorithm>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "ptz_driver/heads/common/head_book.hpp"
#include "ptz_driver/io/backoff.hpp"
#include "ptz_driver/io/serial_port.hpp"

namespace ptz::driver {

template <class Parser, class Reply>
class SerialLine {
 public:
  // Opens the port; throws as SerialPort does.
  SerialLine(const std::string& device, int baud, const std::string& baud_parameter)
      : device_(device),
        baud_(baud),
        port_(std::make_unique<SerialPort>(device, baud, baud_parameter)) {}

  void attach(int address) { inbox_[address]; }
  std::vector<int> addresses() const {
    std::vector<int> a;
    for (const auto& [address, inbox] : inbox_) a.push_back(address);
    return a;
  }
  // True the first time only (after each reopen again): what a line needs once (VISCA's
  // Address Set) goes once.
  bool firstStart() { return !std::exchange(started_, true); }

  // False while the port is closed (nothing goes out) and when the write fails.
  bool send(const Bytes& packet) {
    if (!port_ || !error_.empty()) return false;
    if (port_->write(packet)) return true;
    error_ = port_->error();
    return false;
  }
  // Nothing left to go out: the next packet may be sent (the line's pace, not ours).
  bool idle() { return !port_ || port_->outputPending() == 0; }
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
  // nobody attached and broadcasts go to unrouted. A failed port is closed and, when the
  // back-off allows, opened again. The garbage seen since the last call, a port failure (once
  // per outage, naming the device and the next attempt) and a reopen (stats().reopens) go to
  // the caller's book, so a shared line's are counted once.
  void pump(HeadBook* book, double now_s) {
    if (!port_ && !reopen(book, now_s)) return;
    Bytes data;
    if (!port_->read(&data) || !error_.empty()) {
      fail(book, now_s, error_.empty() ? port_->error() : error_);
      return;
    }
    parser_.feed(data.data(), data.size());
    while (auto r = parser_.next()) {
      replyCame(r->address);
      const auto it = inbox_.find(r->address);
      (it == inbox_.end() ? unrouted_ : it->second).push_back(std::move(*r));
    }
    const int64_t garbage = parser_.garbage();
    book->stats().malformed += garbage - std::exchange(garbage_counted_, garbage);
  }
  std::optional<Reply> next(int address) { return pop(&inbox_[address]); }
  std::optional<Reply> nextUnrouted() { return pop(&unrouted_); }

  // -1 while the port is closed (reopens are tried from pump(), on the caller's clock).
  int fd() const { return port_ ? port_->fd() : -1; }
  const std::string& device() const { return device_; }
  // How often the port was opened again; a head that sees it change starts over.
  int64_t reopens() const { return reopens_; }
  // What is wrong, for the status: "" while the port is open, else e.g. "serial device
  // '/dev/ttyUSB0' hung up (adapter unplugged?), reopening in 1.0 s".
  std::string problem(double now_s) const {
    if (port_) return "";
    return why_ + ", reopening in " + secondsText(std::max(0.0, retry_.retryAtS() - now_s));
  }

 private:
  void fail(HeadBook* book, double now_s, std::string why) {  // a copy: the port goes
    port_.reset();  // closed: a hung-up descriptor would wake every poll at once
    error_.clear();
    why_ = why;
    book->error(why + ", reopening in " + secondsText(retry_.failed(now_s)));
  }
  // Opens the device again when due; true when it is open (as new: nothing of before stands).
  bool reopen(HeadBook* book, double now_s) {
    if (!retry_.due(now_s)) return false;
    try {
      port_ = std::make_unique<SerialPort>(device_, baud_);
    } catch (const std::exception& e) {  // still gone: the next attempt waits longer
      why_ = e.what();
      retry_.failed(now_s);
      return false;
    }
    retry_.succeeded();
    ++reopens_;
    ++book->stats().reopens;
    parser_ = Parser{};  // a packet cut by the unplugging is not completed by the new bytes
    garbage_counted_ = 0;
    for (auto& [address, inbox] : inbox_) inbox.clear();
    unrouted_.clear();
    started_ = false;
    reply_awaited_until_s_ = -1;
    awaited_from_ = -1;
    wanting_.clear();
    last_talker_ = -1;
    return true;
  }

  static std::optional<Reply> pop(std::deque<Reply>* q) {
    if (q->empty()) return std::nullopt;
    Reply r = std::move(q->front());
    q->pop_front();
    return r;
  }

  std::string device_;
  int baud_;
  std::unique_ptr<SerialPort> port_;  // null while closed
  Backoff retry_{0.5, 8.0};
  int64_t reopens_ = 0;
  std::string why_;  // why the port is closed
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
};

}  // namespace ptz::driver
