// Stops the heads once, whichever way ptz-driver leaves its loop: stop() on the normal path,
// the destructor when an exception unwinds past it. Only the GPIO heads stop their motors when
// destroyed; a VISCA or Pelco-D head's absolute move would otherwise run on to its target.
#pragma once

#include <functional>
#include <vector>

#include "ptz_driver/heads/common/head.hpp"

namespace ptz::driver {

class HeadsStop {
 public:
  // clock: the heads' time (seconds); unconfirmed(i): head i did not confirm its stop within
  // timeout_s, or its stop threw.
  HeadsStop(std::vector<PtzHead*> heads, double timeout_s, std::function<double()> clock,
            std::function<void(size_t)> unconfirmed);
  ~HeadsStop();  // stop() unless done
  HeadsStop(const HeadsStop&) = delete;
  HeadsStop& operator=(const HeadsStop&) = delete;

  // Stops every head, the first time only; throws nothing (it may run while unwinding).
  void stop() noexcept;

 private:
  std::vector<PtzHead*> heads_;
  double timeout_s_;
  std::function<double()> clock_;
  std::function<void(size_t)> unconfirmed_;
  bool done_ = false;
};

}  // namespace ptz::driver
