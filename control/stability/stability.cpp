#include "control/stability/stability.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <complex>
#include <deque>
#include <limits>

namespace ptz::control {
namespace {
constexpr double kDeg = 180.0 / M_PI;
}

ContinuousMargins continuousMargins(const LoopParams& loop) {
  ContinuousMargins m;
  const double K = loop.gain, T = loop.time_constant_s, tau = loop.delay_s;
  m.has_crossover = std::abs(K) > 1;
  if (m.has_crossover) {
    m.crossover_rad_s = std::sqrt(K * K - 1) / T;
    m.phase_margin_deg = 180.0 - std::atan(m.crossover_rad_s * T) * kDeg;
    m.phase_margin_at_delay_deg = m.phase_margin_deg - m.crossover_rad_s * tau * kDeg;
    m.tau_max_s = m.phase_margin_deg / kDeg / m.crossover_rad_s;
    m.stable = tau < m.tau_max_s;
  } else {
    m.phase_margin_deg = std::numeric_limits<double>::infinity();
    m.phase_margin_at_delay_deg = m.phase_margin_deg;
    m.tau_max_s = std::numeric_limits<double>::infinity();
    m.stable = true;
  }
  if (tau > 0) {
    // Phase -atan(w T) - w tau = -pi: bisection, the left side falls monotonically.
    double lo = 0, hi = M_PI / tau;
    for (int i = 0; i < 200; ++i) {
      const double mid = (lo + hi) / 2;
      (std::atan(mid * T) + mid * tau < M_PI ? lo : hi) = mid;
    }
    m.phase_crossover_rad_s = (lo + hi) / 2;
    const double mag = K / std::hypot(1.0, m.phase_crossover_rad_s * T);
    m.gain_margin_db = -20 * std::log10(mag);
  } else {
    m.gain_margin_db = std::numeric_limits<double>::infinity();
  }
  return m;
}

SampledResult sampledStability(const LoopParams& loop, double frame_rate_hz) {
  const double h = 1.0 / frame_rate_hz, T = loop.time_constant_s, KK = loop.gain;
  const int d = static_cast<int>(std::floor(loop.delay_s / h));
  const double eps = loop.delay_s / h - d;
  const double a = std::exp(-h / T), a_eps = std::exp(-eps * h / T),
               a_rest = std::exp(-(1 - eps) * h / T);
  // y[k+1] = a y[k] + g0 u[k-d] + g1 u[k-d-1], u[k] = -y[k] (unity feedback):
  // characteristic polynomial z^(d+2) - a z^(d+1) + g0 z + g1.
  const double g0 = KK * (1 - a_rest), g1 = KK * a_rest * (1 - a_eps);
  const int n = d + 2;
  std::vector<double> coeff(static_cast<size_t>(n) + 1, 0.0);  // coeff[i] of z^i
  coeff[static_cast<size_t>(n)] = 1;
  coeff[static_cast<size_t>(n - 1)] = -a;
  coeff[1] += g0;
  coeff[0] += g1;
  Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(n, n);
  for (int i = 1; i < n; ++i) companion(i, i - 1) = 1;
  for (int i = 0; i < n; ++i) companion(i, n - 1) = -coeff[static_cast<size_t>(i)];
  const Eigen::VectorXcd poles = companion.eigenvalues();
  SampledResult r;
  r.spectral_radius = poles.cwiseAbs().maxCoeff();
  r.stable = r.spectral_radius < 1.0;
  return r;
}

double sampledTauMax(const LoopParams& loop, double frame_rate_hz) {
  // |K| <= 1: |G| <= 1 at every frequency, stable for any delay (small-gain theorem).
  if (std::abs(loop.gain) <= 1) return std::numeric_limits<double>::infinity();
  LoopParams l = loop;
  // March out in tenths of a frame to the first unstable delay, then bisect. Sampling only
  // adds delay, so the continuous tau_max bounds the search.
  const double step = 0.1 / frame_rate_hz;
  const double limit = continuousMargins(loop).tau_max_s + 2.0 / frame_rate_hz;
  double lo = 0, hi = 0;
  for (l.delay_s = 0; l.delay_s < limit; l.delay_s += step) {
    if (!sampledStability(l, frame_rate_hz).stable) break;
    lo = l.delay_s;
  }
  hi = l.delay_s;
  if (lo == hi) return 0;
  for (int i = 0; i < 60; ++i) {
    l.delay_s = (lo + hi) / 2;
    (sampledStability(l, frame_rate_hz).stable ? lo : hi) = l.delay_s;
  }
  return lo;
}

std::vector<FrequencyPoint> openLoopResponse(const LoopParams& loop, double omega_min,
                                             double omega_max, int points) {
  std::vector<FrequencyPoint> out;
  for (int i = 0; i < points; ++i) {
    const double w = omega_min * std::pow(omega_max / omega_min, i / double(points - 1));
    const std::complex<double> G = loop.gain / std::complex<double>(1.0, w * loop.time_constant_s) *
                                   std::exp(std::complex<double>(0, -w * loop.delay_s));
    const double phase = -std::atan(w * loop.time_constant_s) * kDeg - w * loop.delay_s * kDeg;
    out.push_back({w, 20 * std::log10(std::abs(G)), phase, G.real(), G.imag()});
  }
  return out;
}

std::vector<double> continuousStepResponse(const LoopParams& loop, double duration_s,
                                           double step_s) {
  const int steps = static_cast<int>(duration_s / step_s);
  const int delay_steps = static_cast<int>(std::lround(loop.delay_s / step_s));
  const double a = std::exp(-step_s / loop.time_constant_s);
  std::deque<double> line(static_cast<size_t>(delay_steps), 0.0);  // u(t - tau)
  std::vector<double> y(static_cast<size_t>(steps) + 1, 0.0);
  for (int k = 0; k < steps; ++k) {
    const double u = 1.0 - y[static_cast<size_t>(k)];  // unit step of the reference
    line.push_back(u);
    const double u_delayed = line.front();
    line.pop_front();
    y[static_cast<size_t>(k) + 1] = a * y[static_cast<size_t>(k)] + loop.gain * (1 - a) * u_delayed;
    if (!std::isfinite(y[static_cast<size_t>(k) + 1]) ||
        std::abs(y[static_cast<size_t>(k) + 1]) > 1e9) {
      y.resize(static_cast<size_t>(k) + 2);
      break;
    }
  }
  return y;
}

bool continuousLoopDecays(const LoopParams& loop) {
  // Long enough for many periods of the oscillation near the boundary (period ~ 2 pi / omega).
  const double duration = std::max(30.0, 200 * loop.delay_s);
  const double step = std::min(1e-4, loop.delay_s / 2000 + 1e-6);
  const std::vector<double> y = continuousStepResponse(loop, duration, step);
  if (y.size() < 10) return false;
  const double final_value = loop.gain / (1 + loop.gain);
  // Compare the error envelope in the second and the last quarter of the run.
  auto envelope = [&](size_t from, size_t to) {
    double m = 0;
    for (size_t i = from; i < to && i < y.size(); ++i)
      m = std::max(m, std::abs(y[i] - final_value));
    return m;
  };
  const size_t n = y.size();
  const double early = envelope(n / 4, n / 2), late = envelope(3 * n / 4, n);
  return late < 1e-9 || late < early;
}

}  // namespace ptz::control
