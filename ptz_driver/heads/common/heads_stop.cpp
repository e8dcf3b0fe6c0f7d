#include "ptz_driver/heads/common/heads_stop.hpp"

#include <utility>

namespace ptz::driver {

HeadsStop::HeadsStop(std::vector<PtzHead*> heads, double timeout_s, std::function<double()> clock,
                     std::function<void(size_t)> unconfirmed)
    : heads_(std::move(heads)),
      timeout_s_(timeout_s),
      clock_(std::move(clock)),
      unconfirmed_(std::move(unconfirmed)) {}

HeadsStop::~HeadsStop() {
  stop();
}

void HeadsStop::stop() noexcept {
  if (std::exchange(done_, true)) return;
  for (size_t i = 0; i < heads_.size(); ++i) {
    bool confirmed = false;
    try {  // one head's failure must not keep the others moving
      confirmed = heads_[i]->stop(clock_(), timeout_s_);
    } catch (...) {
    }
    if (confirmed) continue;
    try {
      unconfirmed_(i);
    } catch (...) {  // a report that fails changes nothing about the stop
    }
  }
}

}  // namespace ptz::driver
