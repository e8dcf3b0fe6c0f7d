#include "tools/logs/run_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <sstream>

#include <Eigen/Geometry>

#include "common/rig.hpp"
#include "common/transport/transport.hpp"

namespace ptz::tools {
namespace {

// A share of an object's pixels that counts as all of them (antialiased edges, rounding).
constexpr double kFullyVisible = 0.98;

// The offset of p from one image's centre, px; false when p is behind the camera (or the
// model gives no number). Brown distortion is a polynomial fitted inside the image: far outside
// it diverges (1e12 px near 90 deg off the axis) or folds back in, so there the pinhole offset.
bool offsetFromCentre(const CameraView& v, const Eigen::Vector3d& p, double* dx, double* dy,
                      bool* inside) {
  const Eigen::Vector3d c = v.toCamera(p);
  if (!c.allFinite() || !(c.z() > 0)) return false;
  const Intrinsics& k = v.intrinsics;
  const Eigen::Vector2d pinhole(k.fx * c.x() / c.z() + k.cx, k.fy * c.y() / c.z() + k.cy);
  const Eigen::Vector2d distorted = v.projectCamera(c);
  const auto within = [&](const Eigen::Vector2d& q, double margin) {
    return q.x() >= -margin * v.width && q.y() >= -margin * v.height &&
           q.x() <= v.width - 1 + margin * v.width && q.y() <= v.height - 1 + margin * v.height;
  };
  *inside = distorted.allFinite() && within(distorted, 0) && within(pinhole, 0.5);
  const Eigen::Vector2d& px = *inside ? distorted : pinhole;
  if (!px.allFinite()) return false;
  // VGA-equivalent px: the same share of the image at every resolution.
  const double to_vga = vgaPxPerPx(v.width);
  *dx = (px.x() - (v.width - 1) / 2.0) * to_vga;
  *dy = (px.y() - (v.height - 1) / 2.0) * to_vga;
  return true;
}

// Differences of times from outside in double: no overflow whatever the values.
double secondsBetween(int64_t from_utime, int64_t to_utime) {
  return (static_cast<double>(to_utime) - static_cast<double>(from_utime)) * 1e-6;
}

double distance(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

double rms(const std::vector<double>& v) {
  if (v.empty()) return NAN;
  double s = 0;
  for (double x : v) s += x * x;
  return std::sqrt(s / v.size());
}

// The angle of the rotation between two unit quaternions (w, x, y, z), degrees, the truth's taken
// up to `quarter_turns` turns of pi/2 about its own y axis (4: an upright box symmetric under
// them; 1: a tagged box, all of whose orientation is seen); NaN for a non-finite or zero one.
double orientationErrorDeg(const std::array<double, 4>& estimate,
                           const std::array<double, 4>& truth, int quarter_turns) {
  const Eigen::Quaterniond e(estimate[0], estimate[1], estimate[2], estimate[3]);
  const Eigen::Quaterniond t(truth[0], truth[1], truth[2], truth[3]);
  if (!e.coeffs().allFinite() || !t.coeffs().allFinite() || e.norm() < 1e-9 || t.norm() < 1e-9) {
    return NAN;
  }
  double best = INFINITY;
  for (int k = 0; k < quarter_turns; ++k) {
    const Eigen::Quaterniond sym(Eigen::AngleAxisd(k * M_PI / 2, Eigen::Vector3d::UnitY()));
    const Eigen::Quaterniond d = (t.normalized() * sym).conjugate() * e.normalized();
    best = std::min(best, 2 * std::atan2(d.vec().norm(), std::abs(d.w())));
  }
  return best * 180 / M_PI;
}

std::string number(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

}  // namespace

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

struct RunMetrics::Scored {
  std::map<int64_t, FrameScore> frames;
  std::map<int64_t, std::vector<double>> centring;
  std::vector<double> error_m, error_pct, settled_error_pct, reacquire_s, orientation_error_deg;
  int64_t outside = 0, switches = 0, reappearances = 0;
  int64_t first_utime = 0;
  double period_s = 0;  // 0: unknown
};

RunMetrics::RunMetrics(std::string target_class, double settle_s)
    : target_class_(std::move(target_class)), settle_s_(settle_s) {}

int RunMetrics::intern(const std::string& s) {
  auto [it, added] = name_index_.emplace(s, static_cast<int>(names_.size()));
  if (added) names_.push_back(s);
  return it->second;
}

void RunMetrics::noteFrame(int64_t seq, int64_t utime) {
  frame_utime_.emplace(seq, utime);
}

void RunMetrics::onFrame(const ptzstereo::stereo_frame_t& m) {
  ++frames_seen_;
  frame_publish_utime_.emplace(m.seq, m.publish_utime);
  noteFrame(m.seq, m.utime);
}

void RunMetrics::onTruth(const ptzstereo::sim_truth_t& m) {
  noteFrame(m.frame_seq, m.utime);
  const CameraView views[2] = {toView(m.left_camera), toView(m.right_camera)};
  std::vector<TruthObject> objects;
  for (const auto& o : m.objects) {
    TruthObject t;
    t.name = intern(o.name);
    t.class_name = intern(o.class_name);
    t.position_m = {o.position_m[0], o.position_m[1], o.position_m[2]};
    t.orientation_symmetry = o.shape == "box" ? 4 : o.shape == "tagged_box" ? 1 : 0;
    for (int i = 0; i < 4; ++i) t.orientation_wxyz[static_cast<size_t>(i)] = o.orientation_wxyz[i];
    const Eigen::Vector3d p(o.position_m[0], o.position_m[1], o.position_m[2]);
    t.in_front = t.inside = t.fully_visible = true;
    for (int cam = 0; cam < 2; ++cam) {
      bool inside = false;
      const double dx_limit_px = (views[cam].width - 1) / 2.0;
      const double dy_limit_px = (views[cam].height - 1) / 2.0;
      double& dx = t.offset_px[2 * cam];
      double& dy = t.offset_px[2 * cam + 1];
      t.in_front &= offsetFromCentre(views[cam], p, &dx, &dy, &inside);
      t.inside &= inside;
      // The apparent radius at its depth (pinhole): the whole disk inside the image.
      const double z_m = views[cam].toCamera(p).z();
      const double r_px = z_m > 0 ? views[cam].intrinsics.fx * o.radius_m / z_m : INFINITY;
      t.fully_visible &= inside && o.visible_fraction[cam] >= kFullyVisible &&
                         std::abs(dx) + r_px <= dx_limit_px && std::abs(dy) + r_px <= dy_limit_px;
    }
    t.inside &= t.in_front;
    t.fully_visible &= t.inside;
    objects.push_back(t);
  }
  truth_.emplace(m.frame_seq, std::move(objects));
}

void RunMetrics::onPose(const ptzstereo::object_pose_t& m) {
  ++poses_;
  noteFrame(m.frame_seq, m.utime);
  Pose p;
  p.utime = m.utime;
  p.target = m.target_index >= 0 && m.target_index < static_cast<int32_t>(m.objects.size());
  if (!p.target) {
    ++poses_without_target_;
  } else {
    const auto& o = m.objects[static_cast<size_t>(m.target_index)];
    p.class_name = intern(o.class_name);
    p.estimate_m = {o.position_m[0], o.position_m[1], o.position_m[2]};
    p.finite = std::all_of(p.estimate_m.begin(), p.estimate_m.end(),
                           [](double v) { return std::isfinite(v); });
    p.has_orientation = o.has_orientation;
    for (int i = 0; i < 4; ++i) p.orientation_wxyz[static_cast<size_t>(i)] = o.orientation_wxyz[i];
  }
  pose_.emplace(m.frame_seq, p);
}

void RunMetrics::onSetpoint(const ptzstereo::ptz_setpoint_t& m) {
  // Both publish times are wall-clock time, in lockstep too; matched to the frame in summary().
  setpoint_publish_.emplace_back(m.frame_seq, m.publish_utime);
  // Only where utime is wall-clock time (realtime runs): in lockstep it is sim time.
  const double latency_ms = secondsBetween(m.utime, m.publish_utime) * 1000;
  if (latency_ms >= 0 && latency_ms < 60'000) latency_ms_.push_back(latency_ms);
}

void RunMetrics::onControlState(const ptzstereo::control_state_t& m) {
  ++control_states_;
  noteFrame(m.frame_seq, m.utime);
  control_state_.emplace(m.frame_seq, m.state);
}

void RunMetrics::onStatus(const ptzstereo::process_status_t& m) {
  for (const auto& c : m.counters) counters_[m.process + "." + c.name] = c.value;
}

RunMetrics::Scored RunMetrics::score() const {
  Scored s;
  if (frame_utime_.empty()) return s;
  s.first_utime = frame_utime_.begin()->second;
  std::vector<double> periods_s;
  for (auto it = frame_utime_.begin(), prev = it++; it != frame_utime_.end(); prev = it++) {
    s.first_utime = std::min(s.first_utime, it->second);
    const double dt_s = secondsBetween(prev->second, it->second);
    const double frames = static_cast<double>(it->first) - static_cast<double>(prev->first);
    if (dt_s > 0 && frames > 0) periods_s.push_back(dt_s / frames);
  }
  // The median step: robust to skipped frames and restarts.
  if (!periods_s.empty()) s.period_s = percentile(periods_s, 50);
  const auto found = name_index_.find(target_class_);
  const int target_class = found == name_index_.end() ? -1 : found->second;
  // The true object a pose's target is: the nearest of the estimate's class, else of the target
  // class, else of any class.
  const auto nearest = [&](const std::vector<TruthObject>& objects, const Pose& p) {
    for (int pass = 0; pass < 3; ++pass) {
      const TruthObject* best = nullptr;
      double best_m = std::numeric_limits<double>::infinity();
      for (const auto& o : objects) {
        if ((pass == 0 && o.class_name != p.class_name) ||
            (pass == 1 && o.class_name != target_class)) {
          continue;
        }
        const double d = distance(o.position_m, p.estimate_m);
        if (d < best_m) best = &o, best_m = d;
      }
      if (best) return best;
    }
    return static_cast<const TruthObject*>(nullptr);
  };
  // Centring counts from settle_s after the first lock (the first pose with a target): before it
  // the heads were searching, or had not yet turned to what they found.
  std::optional<int64_t> lock_utime;
  for (const auto& [seq, p] : pose_) {
    if (p.target) {
      lock_utime = p.utime;
      break;
    }
  }
  int tracked = -1;              // name of the true object last tracked
  int watched = -1;              // the object whose visibility is followed
  bool hidden = false;           // it, since it was last fully visible
  bool pending = false;          // fully visible again, not yet the target
  int64_t reappeared_utime = 0;  // since then
  for (const auto& [seq, utime] : frame_utime_) {
    bool on_tracked = false;  // this frame's pose has the tracked object as its target
    FrameScore& f = s.frames[seq];
    f.utime = utime;
    if (auto c = control_state_.find(seq); c != control_state_.end()) f.control_state = c->second;
    const auto t = truth_.find(seq);
    const std::vector<TruthObject>* objects = t == truth_.end() ? nullptr : &t->second;
    if (const auto p = pose_.find(seq); p != pose_.end()) {
      f.pose = true;
      f.target = p->second.target;
      const TruthObject* o =
          f.target && p->second.finite && objects ? nearest(*objects, p->second) : nullptr;
      if (o) {
        f.tracked = names_[static_cast<size_t>(o->name)];
        f.tracked_truth_m = o->position_m;
        const double err_m = distance(p->second.estimate_m, o->position_m);
        const double range_m = std::hypot(o->position_m[0], o->position_m[1], o->position_m[2]);
        s.error_m.push_back(err_m);
        if (range_m > 0) s.error_pct.push_back(100 * err_m / range_m);
        if (range_m > 0 && lock_utime && secondsBetween(*lock_utime, utime) >= settle_s_) {
          s.settled_error_pct.push_back(100 * err_m / range_m);
        }
        if (o->orientation_symmetry > 0 && p->second.has_orientation) {
          const double e = orientationErrorDeg(p->second.orientation_wxyz, o->orientation_wxyz,
                                               o->orientation_symmetry);
          if (std::isfinite(e)) s.orientation_error_deg.push_back(e);
        }
        if (tracked >= 0 && o->name != tracked) ++s.switches;
        tracked = o->name;
        on_tracked = true;
      }
    }
    // Re-acquisition: from the frame the tracked object is fully visible again to its first pose.
    if (watched != tracked) {  // another object: its own story
      watched = tracked;
      hidden = false;
      pending = false;
    }
    const TruthObject* seen = nullptr;
    for (size_t i = 0; objects && tracked >= 0 && i < objects->size(); ++i) {
      if ((*objects)[i].name == tracked) seen = &(*objects)[i];
    }
    if (seen && !seen->fully_visible) {
      if (pending) {  // hidden again before it was re-acquired
        s.reacquire_s.push_back(secondsBetween(reappeared_utime, utime));
        pending = false;
      }
      hidden = true;
    } else if (seen && hidden) {
      hidden = false;
      ++s.reappearances;
      pending = true;
      reappeared_utime = utime;
    }
    if (pending && on_tracked) {
      s.reacquire_s.push_back(secondsBetween(reappeared_utime, utime));
      pending = false;
    }
    if (!objects || !lock_utime || secondsBetween(*lock_utime, utime) < settle_s_) continue;
    // Centring of the object being tracked (else, a pose's estimate not being a number, the target
    // class's).
    const TruthObject* o = nullptr;
    for (const auto& c : *objects) {
      if (!o && c.name == tracked) o = &c;
    }
    for (const auto& c : *objects) {
      if (!o && c.class_name == target_class) o = &c;
    }
    if (!o) continue;
    if (!o->in_front) {
      ++s.outside;
      continue;
    }
    s.centring[seq].assign(o->offset_px.begin(), o->offset_px.end());
    if (!o->inside) ++s.outside;
  }
  if (pending) {  // never re-acquired: at least as long as it stayed visible
    s.reacquire_s.push_back(secondsBetween(reappeared_utime, s.frames.rbegin()->second.utime));
  }
  return s;
}

std::map<int64_t, std::vector<double>> RunMetrics::centeringByFrame() const {
  return score().centring;
}

std::map<int64_t, FrameScore> RunMetrics::frames() const {
  return score().frames;
}

RunSummary RunMetrics::summary() const {
  const Scored sc = score();
  RunSummary s;
  auto counter = [&](const std::string& key, int64_t fallback) {
    auto it = counters_.find(key);
    return it == counters_.end() ? fallback : it->second;
  };
  // The simulator's count, else every frame seen by any of its messages.
  const int64_t seen = std::max(frames_seen_, static_cast<int64_t>(frame_utime_.size()));
  s.frames_not_published = counter("ptz-sim.STEREO_FRAME.publish_failures", 0);
  // A refused frame's SIM_TRUTH may still have gone out: seen, but not published.
  s.frames_published =
      std::max(seen - s.frames_not_published, counter("ptz-sim.frames_published", seen));
  s.frames_processed = poses_;
  std::vector<double> chain_ms;
  for (const auto& [seq, publish_utime] : setpoint_publish_) {
    auto it = frame_publish_utime_.find(seq);
    if (it != frame_publish_utime_.end()) {
      chain_ms.push_back(secondsBetween(it->second, publish_utime) * 1000);
    }
  }
  s.latency_ms_p50 = percentile(latency_ms_, 50);
  s.latency_ms_p99 = percentile(latency_ms_, 99);
  s.chain_latency_ms_p50 = percentile(chain_ms, 50);
  s.chain_latency_ms_p99 = percentile(chain_ms, 99);
  if (counters_.count("ptz-control.delay_us_p99")) {
    s.delay_ms_p99 = counters_.at("ptz-control.delay_us_p99") / 1000.0;
    s.phase_margin_deg = counter("ptz-control.phase_margin_millideg", 0) / 1000.0;
  }
  std::vector<double> radial;
  double max_px = NAN;
  for (const auto& [seq, o] : sc.centring) {
    for (size_t i = 0; i + 1 < o.size(); i += 2) {
      const double r = std::hypot(o[i], o[i + 1]);
      radial.push_back(r);
      max_px = std::isnan(max_px) ? r : std::max(max_px, r);
    }
  }
  s.centering_rms_px = rms(radial);
  s.centering_max_px = max_px;
  s.centering_samples = static_cast<int64_t>(radial.size());
  s.frames_target_outside_image = sc.outside;
  s.position_error_rms_m = rms(sc.error_m);
  s.position_error_rms_pct_of_range = rms(sc.error_pct);
  if (!sc.error_pct.empty()) {
    s.position_error_max_pct_of_range = *std::max_element(sc.error_pct.begin(), sc.error_pct.end());
  }
  s.position_error_settled_rms_pct_of_range = rms(sc.settled_error_pct);
  s.position_samples = static_cast<int64_t>(sc.error_m.size());
  s.orientation_error_rms_deg = rms(sc.orientation_error_deg);
  s.orientation_samples = static_cast<int64_t>(sc.orientation_error_deg.size());
  s.target_switches = sc.switches;
  s.reappearances = sc.reappearances;
  if (!sc.reacquire_s.empty()) {
    s.reacquire_max_s = *std::max_element(sc.reacquire_s.begin(), sc.reacquire_s.end());
  }
  // Frames the simulator made but could not send were lost to the loop as much as any other.
  const int64_t frames = s.frames_published + s.frames_not_published;
  int64_t with_target = 0;
  for (const auto& [seq, p] : pose_) {
    if (!p.target) continue;
    if (with_target++ == 0) s.time_to_acquire_s = secondsBetween(sc.first_utime, p.utime);
  }
  const auto times_period = [&](int64_t n) {
    if (n == 0) return 0.0;
    return sc.period_s > 0 ? n * sc.period_s : std::numeric_limits<double>::quiet_NaN();
  };
  s.frames_without_pose = frames - static_cast<int64_t>(pose_.size());
  s.poses_without_target = poses_without_target_;
  s.target_lost_s = times_period(frames - with_target);
  if (control_states_ > 0) {
    int64_t searching = 0, coasting = 0;
    for (const auto& [seq, state] : control_state_) {
      searching += state == ptzstereo::control_state_t::STATE_SEARCHING;
      coasting += state == ptzstereo::control_state_t::STATE_COASTING;
    }
    s.search_time_s = times_period(searching);
    s.coast_time_s = times_period(coasting);
  }
  s.frames_skipped_late = counter("ptz-sim.frames_skipped_late", 0);
  return s;
}

std::string RunSummary::toJson() const {
  std::ostringstream j;
  j << "{\n"
    << "  \"frames_published\": " << frames_published << ",\n"
    << "  \"frames_not_published\": " << frames_not_published << ",\n"
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
    << "  \"position_error_max_pct_of_range\": " << number(position_error_max_pct_of_range) << ",\n"
    << "  \"position_error_settled_rms_pct_of_range\": "
    << number(position_error_settled_rms_pct_of_range) << ",\n"
    << "  \"orientation_error_rms_deg\": " << number(orientation_error_rms_deg) << ",\n"
    << "  \"orientation_samples\": " << orientation_samples << ",\n"
    << "  \"target_lost_s\": " << number(target_lost_s) << ",\n"
    << "  \"poses_without_target\": " << poses_without_target << ",\n"
    << "  \"frames_without_pose\": " << frames_without_pose << ",\n"
    << "  \"time_to_acquire_s\": " << number(time_to_acquire_s) << ",\n"
    << "  \"search_time_s\": " << number(search_time_s) << ",\n"
    << "  \"coast_time_s\": " << number(coast_time_s) << ",\n"
    << "  \"target_switches\": " << target_switches << ",\n"
    << "  \"reappearances\": " << reappearances << ",\n"
    << "  \"reacquire_max_s\": " << number(reacquire_max_s) << ",\n"
    << "  \"frames_skipped_late\": " << frames_skipped_late << "\n"
    << "}\n";
  return j.str();
}

}  // namespace ptz::tools
