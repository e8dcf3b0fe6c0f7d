// The edge events of several GPIO lines as one stream in time order, when each line's events are
// read from a queue of its own, one line after the other (libgpiod 1.6: one descriptor per line).
// Reading them all and sorting the batch is not enough: an edge on line A that comes after A was
// read but before B was read waits in A's queue for the next batch, while B's later edges are in
// this one, so B's edge would be decoded before A's (a quadrature pair swapped counts the wrong
// way, and is not even illegal). Hence a cutoff, taken on the events' clock before any line is
// read: every event at or before it was already queued, so it is in the batch; only those are
// delivered, later ones wait for the next batch.
#pragma once

#include <cstddef>
#include <vector>

#include "ptz_driver/io/gpio_lines.hpp"

namespace ptz::driver {

class GpioEventMerger {
 public:
  // An event as read from its line (each line's events in the order they were read).
  void add(const LineEvent& event) { pending_.push_back(event); }
  // Appends the pending events at or before cutoff_s to `out`, oldest first (a line's own
  // events in the order read), and keeps the later ones for the next call.
  void take(double cutoff_s, std::vector<LineEvent>* out);
  size_t pending() const { return pending_.size(); }

 private:
  std::vector<LineEvent> pending_;
};

}  // namespace ptz::driver
