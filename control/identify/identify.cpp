#include "control/identify/identify.hpp"

#include <opencv2/core/optim.hpp>

#include <cmath>

namespace ptz::control {

std::vector<double> simulateAxis(const AxisRecord& r, double K, double T, double tau) {
  std::vector<double> out;
  if (r.positions.empty()) return out;
  double t = r.positions.front().first;
  double y = r.positions.front().second;
  // At rest before the first setpoint acts: the input that holds y.
  double u = K != 0 ? y / K : 0;
  size_t next = 0;  // next setpoint to take effect
  while (next < r.setpoints.size() && r.setpoints[next].first + tau <= t) {
    u = r.setpoints[next++].second;
  }
  for (const auto& [tm, measured] : r.positions) {
    (void)measured;
    while (t < tm) {
      double end = tm;
      if (next < r.setpoints.size()) end = std::min(end, r.setpoints[next].first + tau);
      y = K * u + (y - K * u) * std::exp(-(end - t) / T);
      t = end;
      while (next < r.setpoints.size() && r.setpoints[next].first + tau <= t) {
        u = r.setpoints[next++].second;
      }
    }
    out.push_back(y);
  }
  return out;
}

namespace {

class SquaredError : public cv::MinProblemSolver::Function {
 public:
  explicit SquaredError(const AxisRecord& r) : r_(r) {}
  int getDims() const override { return 3; }
  double calc(const double* x) const override {
    if (!(x[1] > 1e-4) || x[2] < 0) return 1e30;  // T > 0, tau >= 0
    const std::vector<double> y = simulateAxis(r_, x[0], x[1], x[2]);
    double sum = 0;
    for (size_t i = 0; i < y.size(); ++i) sum += std::pow(y[i] - r_.positions[i].second, 2);
    return sum;
  }

 private:
  const AxisRecord& r_;
};

}  // namespace

AxisFit identifyAxis(const AxisRecord& r) {
  AxisFit fit;
  if (r.positions.size() < 10 || r.setpoints.size() < 2) {
    fit.error = "too few samples: need a step test (setpoints that change, positions recorded)";
    return fit;
  }
  bool changes = false;
  for (const auto& s : r.setpoints) changes |= s.second != r.setpoints.front().second;
  if (!changes) {
    fit.error = "the setpoint never changes: no step to identify the axis from";
    return fit;
  }
  const cv::Mat_<double> initial_step = (cv::Mat_<double>(1, 3) << 0.2, 0.1, 0.05);
  auto solver = cv::DownhillSolver::create(
      cv::makePtr<SquaredError>(r), initial_step,
      cv::TermCriteria(cv::TermCriteria::MAX_ITER + cv::TermCriteria::EPS, 5000, 1e-14));
  cv::Mat_<double> x = (cv::Mat_<double>(1, 3) << 1.0, 0.2, 0.05);
  // Restarting from the result lets the simplex escape an early collapse.
  double cost = 0;
  for (int restart = 0; restart < 3; ++restart) cost = solver->minimize(x);
  fit.gain = x(0);
  fit.time_constant_s = x(1);
  fit.dead_time_s = x(2);
  fit.rms_residual = std::sqrt(cost / r.positions.size());
  fit.ok = std::isfinite(cost) && fit.time_constant_s > 0;
  if (!fit.ok) fit.error = "the fit did not converge";
  return fit;
}

}  // namespace ptz::control
