#include "ptz_driver/io/gpio_event_merger.hpp"

#include <algorithm>

namespace ptz::driver {

void GpioEventMerger::take(double cutoff_s, std::vector<LineEvent>* out) {
  // Stable: a line's events keep their order (the kernel's) when their times are equal.
  std::stable_sort(pending_.begin(), pending_.end(),
                   [](const LineEvent& a, const LineEvent& b) { return a.time_s < b.time_s; });
  const auto later =
      std::upper_bound(pending_.begin(), pending_.end(), cutoff_s,
                       [](double cutoff, const LineEvent& e) { return cutoff < e.time_s; });
  out->insert(out->end(), pending_.begin(), later);
  pending_.erase(pending_.begin(), later);
}

}  // namespace ptz::driver
