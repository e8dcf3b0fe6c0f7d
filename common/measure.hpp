// What every part measures with, LCM or not: the wall clock messages are stamped in, and
// percentiles of samples (medians and p99 in statuses and benchmarks).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ptz {

// Wall clock, microseconds since the Unix epoch.
int64_t wallUtime();

// Percentile of a sample set (p in [0, 100], interpolated between ranks); NaN when empty.
double percentile(std::vector<double> values, double p);

// A number as printf's %g writes it (six significant digits), for messages.
std::string formatNumber(double v);

}  // namespace ptz
