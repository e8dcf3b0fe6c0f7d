#include "control/stability/track_analysis.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <deque>
#include <limits>

namespace ptz::control {
namespace {

std::complex<double> pf(const TrackLoopParams& l, double w) {
  const std::complex<double> s(0, w);
  return std::exp(-s * l.delay_s) / (1.0 + l.time_constant_s * s) *
         (1.0 + l.lead_s * s / (1.0 + l.rate_filter_s * s));
}

}  // namespace

TrackMargins trackLoopMargins(const TrackLoopParams& loop) {
  TrackMargins m;
  // 1 - g H = 0 needs g H real and 1: for g > 0 where arg H = 0 (H(0) = 1 is one such point),
  // for g < 0 where arg H = 180 deg. Dense log grid, crossings refined by bisection.
  double g_pos = 1.0, g_neg = std::numeric_limits<double>::infinity();
  const int n = 200000;
  const double w_min = 1e-3, w_max = 1e4;
  auto at = [&](int i) { return w_min * std::pow(w_max / w_min, static_cast<double>(i) / n); };
  std::complex<double> prev = pf(loop, at(0));
  m.peak_gain = std::abs(prev);
  for (int i = 1; i <= n; ++i) {
    const double w = at(i);
    const std::complex<double> h = pf(loop, w);
    m.peak_gain = std::max(m.peak_gain, std::abs(h));
    // Crossing of the real axis: the imaginary part changes sign.
    if ((prev.imag() < 0) != (h.imag() < 0)) {
      double lo = at(i - 1), hi = w;
      for (int k = 0; k < 60; ++k) {
        const double mid = std::sqrt(lo * hi);
        ((pf(loop, mid).imag() < 0) == (prev.imag() < 0) ? lo : hi) = mid;
      }
      const std::complex<double> c = pf(loop, std::sqrt(lo * hi));
      if (c.real() > 0) g_pos = std::min(g_pos, 1.0 / c.real());
      if (c.real() < 0) g_neg = std::min(g_neg, -1.0 / c.real());
    }
    prev = h;
  }
  m.g_max_any_delay = 1.0 / m.peak_gain;
  m.g_max_positive = g_pos;
  m.g_max_negative = g_neg;
  return m;
}

std::vector<double> trackStepResponse(const TrackLoopParams& loop, double g, double duration_s,
                                      double step_s) {
  const int steps = static_cast<int>(duration_s / step_s);
  std::deque<double> line(static_cast<size_t>(std::lround(loop.delay_s / step_s)), 0.0);
  const double a = std::exp(-step_s / loop.time_constant_s);
  const double b = std::exp(-step_s / loop.rate_filter_s);
  double theta = 0, filtered = 0;  // filtered: theta*_measured through 1 / (1 + Tv s)
  std::vector<double> y;
  y.reserve(static_cast<size_t>(steps) + 1);
  y.push_back(theta);
  for (int k = 0; k < steps; ++k) {
    const double measured = 1.0 + g * theta;
    // F = 1 + lead s / (1 + Tv s) = 1 + (lead / Tv) (1 - 1 / (1 + Tv s)).
    const double u = measured + loop.lead_s / loop.rate_filter_s * (measured - filtered);
    filtered = b * filtered + (1 - b) * measured;
    line.push_back(u);
    const double u_delayed = line.front();
    line.pop_front();
    theta = a * theta + (1 - a) * u_delayed;
    y.push_back(theta);
    if (!std::isfinite(theta) || std::abs(theta) > 1e9) break;
  }
  return y;
}

}  // namespace ptz::control
