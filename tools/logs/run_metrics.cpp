#include "tools/logs/run_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "common/rig.hpp"
#include "common/transport.hpp"

namespace ptz::tools {
namespace {

CameraView toView(const ptzstereo::camera_model_t& m) {
  CameraView v;
  v.width = m.width;
  v.height = m.height;
  v.intrinsics = {m.fx_px, m.fy_px, m.cx_px, m.cy_px, {}};
  for (int i = 0; i < 5; ++i) v.intrinsics.distortion[i] = m.distortion[i];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) v.rotation_head_camera(r, c) = m.rotation_head_camera[r * 3 + c];
    v.position_head_m[r] = m.position_head_m[r];
  }
  return v;
}

double rms(const std::vector<double>& v) {
  if (v.empty()) return NAN;
  double s = 0;
  for (double x : v) s += x * x;
  return std::sqrt(s / v.size());
}

std::string number(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

}  // namespace

RunMetrics::RunMetrics(std::string target_class, double settle_s)
    : target_class_(std::move(target_class)), settle_s_(settle_s) {}

void RunMetrics::onFrame(const ptzstereo::stereo_frame_t& m) {
  ++frames_seen_;
  frame_publish_utime_[m.seq] = m.publish_utime;
  if (first_utime_ < 0) first_utime_ = m.utime;
  if (last_frame_utime_ >= 0 && frame_period_us_ == 0)
    frame_period_us_ = m.utime - last_frame_utime_;
  last_frame_utime_ = m.utime;
}

void RunMetrics::onTruth(const ptzstereo::sim_truth_t& m) {
  if (first_utime_ < 0) first_utime_ = m.utime;
  // The frame period from the truth too, for listeners that do not take the frames.
  if (last_truth_utime_ >= 0 && frame_period_us_ == 0)
    frame_period_us_ = m.utime - last_truth_utime_;
  last_truth_utime_ = m.utime;
  for (const auto& o : m.objects) {
    if (o.class_name != target_class_) continue;
    truth_position_[m.frame_seq] = {o.position_m[0], o.position_m[1], o.position_m[2]};
    if ((m.utime - first_utime_) * 1e-6 < settle_s_) break;
    const Eigen::Vector3d p(o.position_m[0], o.position_m[1], o.position_m[2]);
    std::vector<double> offsets;
    bool outside = false;
    for (const auto* cam : {&m.left_camera, &m.right_camera}) {
      const CameraView v = toView(*cam);
      const Eigen::Vector2d px = v.project(p);
      const Eigen::Vector2d centre((v.width - 1) / 2.0, (v.height - 1) / 2.0);
      offsets.push_back(px.x() - centre.x());
      offsets.push_back(px.y() - centre.y());
      outside |= !px.allFinite() || px.x() < 0 || px.y() < 0 || px.x() > v.width - 1 ||
                 px.y() > v.height - 1;
    }
    centering_[m.frame_seq] = offsets;
    outside_ += outside ? 1 : 0;
    break;
  }
}

void RunMetrics::onPose(const ptzstereo::object_pose_t& m) {
  ++poses_;
  if (m.target_index < 0 || m.target_index >= static_cast<int32_t>(m.objects.size())) {
    ++poses_without_target_;
    return;
  }
  auto it = truth_position_.find(m.frame_seq);
  if (it == truth_position_.end()) return;
  const auto& o = m.objects[static_cast<size_t>(m.target_index)];
  const Eigen::Vector3d est(o.position_m[0], o.position_m[1], o.position_m[2]);
  const Eigen::Vector3d truth(it->second[0], it->second[1], it->second[2]);
  const double err = (est - truth).norm();
  position_error_m_.push_back(err);
  position_error_pct_.push_back(100 * err / truth.norm());
}

void RunMetrics::onSetpoint(const ptzstereo::ptz_setpoint_t& m) {
  // Both publish times are wall-clock time, in lockstep too.
  auto it = frame_publish_utime_.find(m.frame_seq);
  if (it != frame_publish_utime_.end()) {
    chain_latency_ms_.push_back((m.publish_utime - it->second) / 1000.0);
  }
  // Only where utime is wall-clock time (realtime runs): in lockstep it is sim time.
  const double latency_ms = (m.publish_utime - m.utime) / 1000.0;
  if (latency_ms >= 0 && latency_ms < 60'000) latency_ms_.push_back(latency_ms);
}

void RunMetrics::onStatus(const ptzstereo::process_status_t& m) {
  for (const auto& c : m.counters) counters_[m.process + "." + c.name] = c.value;
}

RunSummary RunMetrics::summary() const {
  RunSummary s;
  auto counter = [&](const std::string& key, int64_t fallback) {
    auto it = counters_.find(key);
    return it == counters_.end() ? fallback : it->second;
  };
  s.frames_published = std::max(frames_seen_, counter("ptz-sim.frames_published", frames_seen_));
  s.frames_processed = poses_;
  s.latency_ms_p50 = percentile(latency_ms_, 50);
  s.latency_ms_p99 = percentile(latency_ms_, 99);
  s.chain_latency_ms_p50 = percentile(chain_latency_ms_, 50);
  s.chain_latency_ms_p99 = percentile(chain_latency_ms_, 99);
  if (counters_.count("ptz-control.delay_us_p99")) {
    s.delay_ms_p99 = counters_.at("ptz-control.delay_us_p99") / 1000.0;
    s.phase_margin_deg = counters_.at("ptz-control.phase_margin_millideg") / 1000.0;
  }
  std::vector<double> radial;
  double max_px = NAN;
  for (const auto& [seq, o] : centering_) {
    for (size_t i = 0; i + 1 < o.size(); i += 2) {
      const double r = std::hypot(o[i], o[i + 1]);
      radial.push_back(r);
      max_px = std::isnan(max_px) ? r : std::max(max_px, r);
    }
  }
  s.centering_rms_px = rms(radial);
  s.centering_max_px = max_px;
  s.centering_samples = static_cast<int64_t>(radial.size());
  s.frames_target_outside_image = outside_;
  s.position_error_rms_m = rms(position_error_m_);
  s.position_error_rms_pct_of_range = rms(position_error_pct_);
  s.position_samples = static_cast<int64_t>(position_error_m_.size());
  s.target_lost_s = poses_without_target_ * frame_period_us_ * 1e-6;
  s.poses_without_target = poses_without_target_;
  s.frames_skipped_late = counter("ptz-sim.frames_skipped_late", 0);
  return s;
}

std::string RunSummary::toJson() const {
  std::ostringstream j;
  j << "{\n"
    << "  \"frames_published\": " << frames_published << ",\n"
    << "  \"frames_processed\": " << frames_processed << ",\n"
    << "  \"latency_ms_p50\": " << number(latency_ms_p50) << ",\n"
    << "  \"latency_ms_p99\": " << number(latency_ms_p99) << ",\n"
    << "  \"chain_latency_ms_p50\": " << number(chain_latency_ms_p50) << ",\n"
    << "  \"chain_latency_ms_p99\": " << number(chain_latency_ms_p99) << ",\n"
    << "  \"delay_ms_p99\": " << number(delay_ms_p99) << ",\n"
    << "  \"phase_margin_deg\": " << number(phase_margin_deg) << ",\n"
    << "  \"centering_rms_px\": " << number(centering_rms_px) << ",\n"
    << "  \"centering_max_px\": " << number(centering_max_px) << ",\n"
    << "  \"frames_target_outside_image\": " << frames_target_outside_image << ",\n"
    << "  \"position_error_rms_m\": " << number(position_error_rms_m) << ",\n"
    << "  \"position_error_rms_pct_of_range\": " << number(position_error_rms_pct_of_range) << ",\n"
    << "  \"target_lost_s\": " << number(target_lost_s) << ",\n"
    << "  \"poses_without_target\": " << poses_without_target << ",\n"
    << "  \"frames_skipped_late\": " << frames_skipped_late << "\n"
    << "}\n";
  return j.str();
}

}  // namespace ptz::tools
