#include "perception/tracking/tracker.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include "perception/tracking/yaw.hpp"

namespace ptz::perception {
namespace {

using Matrix9d = Eigen::Matrix<double, 9, 9>;

// A track born this many radii from another's prediction was born beside it (a merge).
constexpr double kBesideRadii = 4;

// Transition and white-jerk process noise of the constant-acceleration model over dt.
void motionModel(double dt, double q, Matrix9d* F, Matrix9d* Q) {
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  F->setIdentity();
  F->block<3, 3>(0, 3) = dt * I;
  F->block<3, 3>(0, 6) = dt * dt / 2 * I;
  F->block<3, 3>(3, 6) = dt * I;
  const double d2 = dt * dt, d3 = d2 * dt, d4 = d3 * dt, d5 = d4 * dt;
  const double blocks[3][3] = {
      {d5 / 20, d4 / 8, d3 / 6}, {d4 / 8, d3 / 3, d2 / 2}, {d3 / 6, d2 / 2, dt}};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) Q->block<3, 3>(3 * r, 3 * c) = q * blocks[r][c] * I;
  }
}

}  // namespace

const char* trackStateName(TrackState s) {
  switch (s) {
    case TrackState::kTentative:
      return "tentative";
    case TrackState::kConfirmed:
      return "confirmed";
    case TrackState::kCoasting:
      return "coasting";
  }
  return "?";
}

Eigen::Vector3d Track::positionAt(double when_s) const {
  const double dt = when_s - t_s;
  return x.head<3>() + dt * x.segment<3>(3) + dt * dt / 2 * x.tail<3>();
}

Eigen::Matrix3d Track::positionCovarianceAt(double when_s) const {
  const double dt = std::max(0.0, when_s - t_s);
  Eigen::Matrix<double, 3, 9> J;
  J << Eigen::Matrix3d::Identity(), dt * Eigen::Matrix3d::Identity(),
      dt * dt / 2 * Eigen::Matrix3d::Identity();
  return J * P * J.transpose();
}

double Track::yawVarianceAt(double when_s, double yaw_psd_rad2_s) const {
  return yaw_var_rad2 + yaw_psd_rad2_s * std::max(0.0, when_s - yaw_t_s);
}

Tracker::Tracker(TrackerParams params) : p_(params) {}

const Track* Tracker::find(int64_t id) const {
  for (const auto& t : tracks_) {
    if (t.id == id) return &t;
  }
  return nullptr;
}

void Tracker::predict(Track* t, double t_s) const {
  const double dt = t_s - t->t_s;
  if (dt <= 0) return;
  Matrix9d F, Q;
  motionModel(dt, p_.jerk_psd_m2_s5, &F, &Q);
  t->x = F * t->x;
  t->P = F * t->P * F.transpose() + Q;
  t->t_s = t_s;
}

Eigen::Matrix3d Tracker::measurementCovariance(const TrackMeasurement& m) const {
  Eigen::Matrix3d R = m.covariance_m2;
  if (!R.allFinite()) R.setZero();
  R = (R + R.transpose()) / 2;
  return R + Eigen::Matrix3d::Identity() * p_.min_position_sigma_m * p_.min_position_sigma_m;
}

double Tracker::distance2(const Track& t, const TrackMeasurement& m, double* log_det) const {
  const Eigen::Matrix3d S = t.positionCovariance() + measurementCovariance(m);
  const Eigen::Vector3d y = m.position_m - t.position();
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(S);
  if (ldlt.info() != Eigen::Success) return INFINITY;
  const double d2 = y.dot(ldlt.solve(y));
  *log_det = ldlt.vectorD().array().max(1e-300).log().sum();
  return std::isfinite(d2) ? d2 : INFINITY;
}

bool Tracker::radiusOutOfLine(const Track& t, const TrackMeasurement& m) const {
  return m.radius_m > 0 && t.radius_m > 0 &&
         std::max(m.radius_m / t.radius_m, t.radius_m / m.radius_m) > p_.max_radius_ratio;
}

void Tracker::eraseClass(const std::string& class_name) {
  tracks_.erase(std::remove_if(tracks_.begin(), tracks_.end(),
                               [&](const Track& t) { return t.class_name == class_name; }),
                tracks_.end());
}

void Tracker::correctYaw(Track* t, const TrackMeasurement& m) {
  if (!m.has_yaw || !std::isfinite(m.yaw_rad) || !(m.yaw_var_rad2 > 0) ||
      !std::isfinite(m.yaw_var_rad2) || !(m.yaw_period_rad > 0)) {
    return;
  }
  const bool fresh =
      !t->has_yaw || t->yaw_period_rad != m.yaw_period_rad || t->yaw_misses >= p_.yaw_reset_misses;
  if (!fresh) {
    const double p = t->yawVarianceAt(t->t_s, p_.yaw_psd_rad2_s);
    const double innovation = wrapAngle(m.yaw_rad - t->yaw_rad, m.yaw_period_rad);
    const double s = p + m.yaw_var_rad2;
    if (innovation * innovation / s > p_.yaw_gate_chi2) {
      ++t->yaw_misses;
      ++yaws_refused_;
      return;
    }
    const double k = p / s;
    t->yaw_rad = wrapAngle(t->yaw_rad + k * innovation, m.yaw_period_rad);
    t->yaw_var_rad2 = (1 - k) * p;
  } else {
    t->yaw_rad = wrapAngle(m.yaw_rad, m.yaw_period_rad);
    t->yaw_var_rad2 = m.yaw_var_rad2;
    t->yaw_period_rad = m.yaw_period_rad;
    t->has_yaw = true;
  }
  t->yaw_t_s = t->t_s;
  t->yaw_misses = 0;
  ++yaws_accepted_;
}

void Tracker::correctRotation(Track* t, const TrackMeasurement& m) {
  if (!m.has_rotation) return;
  switch (
      updateRotation(&t->rotation, t->t_s, m.rotation, m.rotation_covariance_rad2, p_.rotation)) {
    case RotationUpdate::kStarted:
    case RotationUpdate::kAccepted:
      ++rotations_accepted_;
      break;
    case RotationUpdate::kRefused:
    case RotationUpdate::kInvalid:
      ++rotations_refused_;
      break;
  }
}

void Tracker::correct(Track* t, const TrackMeasurement& m) {
  correctYaw(t, m);
  correctRotation(t, m);
  const Eigen::Matrix3d S = t->positionCovariance() + measurementCovariance(m);
  const Eigen::Matrix<double, 9, 3> PHt = t->P.leftCols<3>();
  const Eigen::Matrix<double, 9, 3> K = PHt * S.inverse();
  t->x += K * (m.position_m - t->position());
  // Joseph form: stays symmetric positive definite with tiny measurement noise.
  Matrix9d IKH = Matrix9d::Identity();
  IKH.leftCols<3>() -= K;
  t->P = IKH * t->P * IKH.transpose() + K * measurementCovariance(m) * K.transpose();
  t->P = (t->P + t->P.transpose()) / 2;
}

void Tracker::restart(Track* t, double t_s, const TrackMeasurement& m) {
  t->x.setZero();
  t->x.head<3>() = m.position_m;
  t->P.setZero();
  t->P.topLeftCorner<3, 3>() = measurementCovariance(m);
  t->P.block<3, 3>(3, 3) = Eigen::Matrix3d::Identity() * std::pow(p_.initial_speed_sigma_m_s, 2);
  t->P.block<3, 3>(6, 6) = Eigen::Matrix3d::Identity() * std::pow(p_.initial_accel_sigma_m_s2, 2);
  t->t_s = t->last_update_s = t->last_seen_s = t->last_stereo_s = t_s;
  t->object_index = m.object_index;
  // The same object: its yaw goes on (a wrong one is refused and then restarted by the gate).
  correctYaw(t, m);
  correctRotation(t, m);
}

Track* Tracker::recoverable(double t_s, const TrackMeasurement& m, const std::vector<bool>& taken) {
  Track* best = nullptr;
  double best_m = INFINITY;
  for (size_t i = 0; i < tracks_.size(); ++i) {
    Track& t = tracks_[i];
    if (taken[i] || t.state == TrackState::kTentative || t.class_name != m.class_name) continue;
    const double since_s = t_s - t.last_update_s;
    if (since_s > p_.recover_window_s) continue;  // longer: anything could be there
    if (radiusOutOfLine(t, m)) continue;
    // At least the object's own radius: no other object of its size has its centre that near.
    const double reach_m = std::max(p_.recover_speed_m_s * since_s, t.radius_m);
    const double d = (m.position_m - t.position()).norm();
    if (d <= reach_m && d < best_m) {
      best_m = d;
      best = &t;
    }
  }
  return best;
}

void Tracker::start(double t_s, const TrackMeasurement& m) {
  Track t;
  t.id = next_id_++;
  t.class_name = m.class_name;
  t.x.head<3>() = m.position_m;
  t.P.setZero();
  t.P.topLeftCorner<3, 3>() = measurementCovariance(m);
  t.P.block<3, 3>(3, 3) = Eigen::Matrix3d::Identity() * std::pow(p_.initial_speed_sigma_m_s, 2);
  t.P.block<3, 3>(6, 6) = Eigen::Matrix3d::Identity() * std::pow(p_.initial_accel_sigma_m_s2, 2);
  t.radius_m = m.radius_m;
  t.t_s = t.first_s = t.last_update_s = t.last_seen_s = t.last_stereo_s = t_s;
  t.hits = 1;
  t.object_index = m.object_index;
  t.state = p_.confirm_hits <= 1 ? TrackState::kConfirmed : TrackState::kTentative;
  // Beside the tracks of its class seen in this very frame (a merge); not beside one that merely
  // coasts (that may be this same object come back off its prediction).
  for (const Track& other : tracks_) {
    if (other.state == TrackState::kTentative || other.class_name != m.class_name ||
        other.last_seen_s != t_s) {
      continue;
    }
    const double d = (other.position() - m.position_m).norm();
    const double radius_m = std::max({other.radius_m, m.radius_m, 0.05});
    if (d <= kBesideRadii * radius_m) t.born_beside_ids.push_back(other.id);
  }
  correctYaw(&t, m);
  correctRotation(&t, m);
  tracks_.push_back(t);
}

void Tracker::update(double t_s, const std::vector<TrackMeasurement>& measurements) {
  if (started_ && t_s < last_t_s_) tracks_.clear();  // time went back: a new run of the source
  if (!started_) last_t_s_ = t_s;
  started_ = true;
  for (auto& t : tracks_) {
    predict(&t, t_s);
    t.object_index = -1;
    t.view_region_index = -1;
  }
  // The expired go before pairing: a stale track's grown covariance would gate anything.
  eraseExpired(t_s);
  // Every gated (track, measurement) pair of one class, nearest first, each used once; first the
  // pairs of tracks updated within recover_window_s, then sharp turns recovered, then the pairs
  // of tracks longer unseen (a matching cascade: a long-coasting track's wide gate must not take
  // the measurement of an object whose own track just lost it in a turn).
  std::vector<std::tuple<bool, double, size_t, size_t>> pairs;
  const double max_log_det = 3 * std::log(p_.rank_sigma_cap_m * p_.rank_sigma_cap_m);
  for (size_t i = 0; i < tracks_.size(); ++i) {
    const bool stale = tracks_[i].state != TrackState::kTentative &&
                       t_s - tracks_[i].last_update_s > p_.recover_window_s;
    for (size_t j = 0; j < measurements.size(); ++j) {
      if (tracks_[i].class_name != measurements[j].class_name) continue;
      if (!measurements[j].position_m.allFinite()) continue;
      double log_det = 0;
      const double d2 = distance2(tracks_[i], measurements[j], &log_det);
      // Gated by d2, ranked by the likelihood's cost d2 + ln det S: a coasting track's wide
      // covariance makes every d2 small, which must not let it take another object's
      // measurement before that object's own, tighter track.
      if (d2 <= p_.gate_chi2) pairs.emplace_back(stale, d2 + std::min(log_det, max_log_det), i, j);
    }
  }
  const double frame_dt = std::max(t_s - last_t_s_, 0.0);
  last_t_s_ = t_s;
  std::sort(pairs.begin(), pairs.end());
  std::vector<bool> track_used(tracks_.size()), meas_used(measurements.size());
  std::vector<bool> updated(tracks_.size());
  const auto take = [&](size_t i, size_t j) {
    track_used[i] = meas_used[j] = true;
    updated[i] = apply(&tracks_[i], measurements[j], t_s);
  };
  auto pair = pairs.begin();
  for (; pair != pairs.end() && !std::get<0>(*pair); ++pair) {
    const auto [stale, cost, i, j] = *pair;
    if (!track_used[i] && !meas_used[j]) take(i, j);
  }
  // A trusted measurement no recent track's gate took, near where one that it missed would be
  // (a sharp turn, a bounce), restarts that track.
  for (size_t j = 0; j < measurements.size() && p_.recover_speed_m_s > 0; ++j) {
    const TrackMeasurement& m = measurements[j];
    if (meas_used[j] || !m.untrusted.empty() || !m.position_m.allFinite()) continue;
    if (Track* t = recoverable(t_s, m, track_used)) {
      const size_t i = static_cast<size_t>(t - tracks_.data());
      restart(t, t_s, m);
      ++t->hits;
      ++recoveries_;
      track_used[i] = meas_used[j] = updated[i] = true;
    }
  }
  for (; pair != pairs.end(); ++pair) {
    const auto [stale, cost, i, j] = *pair;
    if (!track_used[i] && !meas_used[j]) take(i, j);
  }
  for (size_t i = 0; i < tracks_.size(); ++i) {
    Track& t = tracks_[i];
    if (t.state == TrackState::kTentative) {
      if (t.hits >= p_.confirm_hits) t.state = TrackState::kConfirmed;
    } else {
      t.state = updated[i] ? TrackState::kConfirmed : TrackState::kCoasting;
    }
    if (!updated[i]) {
      // The acceleration fades, and so does its uncertainty (rows and columns of P scaled as
      // the state is), or the covariance would go on growing as if it did not.
      const double f = std::exp(-frame_dt / p_.coast_accel_decay_s);
      t.x.tail<3>() *= f;
      t.P.bottomRows<3>() *= f;
      t.P.rightCols<3>() *= f;
    }
  }
  eraseExpired(t_s);
  // Trusted measurements no track took start tentative tracks; untrusted ones are no centre.
  for (size_t j = 0; j < measurements.size(); ++j) {
    if (!meas_used[j] && measurements[j].position_m.allFinite())
      startIfTrusted(t_s, measurements[j]);
  }
}

bool Tracker::startIfTrusted(double t_s, const TrackMeasurement& m) {
  if (!m.untrusted.empty()) {
    ++untrusted_counts_[m.untrusted];
    return false;
  }
  if (tracks_.size() >= p_.max_tracks) {
    ++tracks_refused_;
    return false;
  }
  start(t_s, m);
  return true;
}

bool Tracker::apply(Track* t, const TrackMeasurement& m, double t_s) {
  std::string untrusted = m.untrusted;
  // The radius of a tentative track is still being learnt: its first measurement may be off.
  if (untrusted.empty() && t->state != TrackState::kTentative && radiusOutOfLine(*t, m)) {
    untrusted = "size";
  }
  t->last_seen_s = t_s;
  if (!untrusted.empty()) {
    ++t->untrusted_updates;
    ++untrusted_counts_[untrusted];
    return false;
  }
  correct(t, m);
  if (m.radius_m > 0) {
    t->radius_m =
        t->radius_m > 0 ? t->radius_m + p_.radius_filter * (m.radius_m - t->radius_m) : m.radius_m;
  }
  t->last_update_s = t->last_stereo_s = t_s;
  t->object_index = m.object_index;
  ++t->hits;
  return true;
}

void Tracker::updateLate(double t_s, const std::vector<TrackMeasurement>& measurements) {
  // Of a frame after the newest (a new run of the source), or of one long past: of no use.
  if (!started_ || t_s > last_t_s_ || last_t_s_ - t_s > p_.late_max_age_s) {
    late_dropped_ += static_cast<int64_t>(measurements.size());
    return;
  }
  const double dt = last_t_s_ - t_s;  // 0: the frame update() took last
  for (const TrackMeasurement& m : measurements) {
    if (!m.position_m.allFinite()) continue;
    // The nearest gated track of its class, by the update's cost, the measurement moved to now by
    // the track's own motion since t_s (its velocity's uncertainty over that time added).
    Track* nearest = nullptr;
    TrackMeasurement nearest_now;
    double best = std::numeric_limits<double>::infinity();
    for (Track& t : tracks_) {
      if (t.class_name != m.class_name) continue;
      TrackMeasurement now = m;
      if (dt > 0) {
        // An approximation of an out-of-sequence update (the track's motion taken as known but
        // for its velocity's spread); the orientation of then is not now's: left to the windows.
        now.position_m += t.position() - t.positionAt(t_s);
        now.covariance_m2 = m.covariance_m2 + dt * dt * t.velocityCovariance();
        now.has_rotation = now.has_yaw = false;
      }
      double log_det = 0;
      const double d2 = distance2(t, now, &log_det);
      if (d2 <= p_.gate_chi2 && d2 + log_det < best) {
        best = d2 + log_det, nearest = &t, nearest_now = now;
      }
    }
    if (nearest && nearest->last_seen_s >= t_s) {
      ++late_known_;  // a measurement of it at that frame or since came first
      continue;
    }
    if (nearest) {
      if (apply(nearest, nearest_now, last_t_s_)) {
        nearest->object_index = -1;  // in no message of the frame
        ++late_updates_;
        if (nearest->state == TrackState::kCoasting) nearest->state = TrackState::kConfirmed;
        if (nearest->state == TrackState::kTentative && nearest->hits >= p_.confirm_hits) {
          nearest->state = TrackState::kConfirmed;
        }
      }
      continue;
    }
    if (startIfTrusted(t_s, m)) {
      // Born at its frame's time, then predicted to the newest frame's like every track; seen as
      // of the newest: the search's own delay does not count against its tentative gap, the next
      // frames' windows have the whole of it to confirm it.
      Track& born = tracks_.back();
      predict(&born, last_t_s_);
      born.last_seen_s = last_t_s_;
      born.object_index = -1;
      ++late_starts_;
    }
  }
}

void Tracker::updateFromViews(double t_s, const std::vector<ViewMeasurement>& measurements,
                              const CameraView& left, const CameraView& right) {
  struct Gated {
    size_t track, measurement;
    Eigen::Vector2d innovation;
    Eigen::Matrix<double, 2, 3> J;
    Eigen::Matrix2d S;
  };
  std::vector<Gated> gated;
  std::vector<int> per_track(tracks_.size()), per_measurement(measurements.size());
  for (size_t i = 0; i < tracks_.size(); ++i) {
    Track& t = tracks_[i];
    // Only tracks that no measurement touched this frame (seen untrusted is touched), with a
    // recent depth, move; every other non-tentative track not updated by a measurement of its own
    // whose predicted disc overlaps a region counts against that region's uniqueness (by place,
    // not gate: a long-lost track's gate would take in anything).
    if (t.state == TrackState::kTentative || t.t_s != t_s) continue;
    const bool movable = t.state == TrackState::kCoasting && t.object_index < 0 &&
                         t.last_seen_s != t_s && t_s - t.last_stereo_s <= p_.view_max_depth_age_s;
    for (size_t j = 0; j < measurements.size(); ++j) {
      const ViewMeasurement& m = measurements[j];
      if (m.class_name != t.class_name || !m.pixel.allFinite()) continue;
      const CameraView& view = m.side == Side::kLeft ? left : right;
      const Eigen::Vector3d p = t.position();
      const Eigen::Vector2d h = view.project(p);
      if (!h.allFinite()) continue;
      // The apparent radius at the predicted range must be the region's.
      const double range_m = (p - view.position_head_m).norm();
      const double radius_px = range_m > 0 ? view.intrinsics.fx * t.radius_m / range_m : 0;
      if (!movable) {
        // Another object predicted where the region is (their discs overlap) may be what it shows,
        // unless a measurement of its own updated it in this frame (its region is another).
        if (t.object_index < 0 && (m.pixel - h).norm() <= m.radius_px + radius_px) {
          ++per_measurement[j];
        }
        continue;
      }
      if (radius_px > 0 && m.radius_px > 0 &&
          std::max(radius_px / m.radius_px, m.radius_px / radius_px) > p_.max_radius_ratio) {
        continue;
      }
      Gated g{i, j, m.pixel - h, {}, {}};
      constexpr double kStepM = 1e-4;
      for (int a = 0; a < 3; ++a) {
        Eigen::Vector3d q = p;
        q[a] += kStepM;
        g.J.col(a) = (view.project(q) - h) / kStepM;
      }
      g.S = g.J * t.positionCovariance() * g.J.transpose() +
            Eigen::Matrix2d::Identity() * m.sigma_px * m.sigma_px;
      const Eigen::LDLT<Eigen::Matrix2d> ldlt(g.S);
      if (!g.J.allFinite() || ldlt.info() != Eigen::Success) continue;
      const double d2 = g.innovation.dot(ldlt.solve(g.innovation));
      if (!(d2 <= p_.view_gate_chi2)) continue;
      gated.push_back(g);
      ++per_track[i];
      ++per_measurement[j];
    }
  }
  // Only where the pairing is unique: a region near two tracks, or a track near two regions, is
  // no evidence of which is which.
  for (const Gated& g : gated) {
    if (per_track[g.track] != 1 || per_measurement[g.measurement] != 1) continue;
    Track& t = tracks_[g.track];
    const ViewMeasurement& m = measurements[g.measurement];
    Eigen::Matrix<double, 2, 9> H = Eigen::Matrix<double, 2, 9>::Zero();
    H.leftCols<3>() = g.J;
    const Eigen::Matrix<double, 9, 2> K = t.P * H.transpose() * g.S.inverse();
    t.x += K * g.innovation;
    const Matrix9d IKH = Matrix9d::Identity() - K * H;
    t.P = IKH * t.P * IKH.transpose() + K * (m.sigma_px * m.sigma_px) * K.transpose();
    t.P = (t.P + t.P.transpose()) / 2;
    t.state = TrackState::kConfirmed;
    t.last_update_s = t.last_seen_s = t_s;
    t.view_region_index = m.region_index;
    t.view_side = m.side;
    ++t.hits;
    ++view_updates_;
  }
}

void Tracker::eraseExpired(double t_s) {
  tracks_.erase(std::remove_if(tracks_.begin(), tracks_.end(),
                               [&](const Track& t) {
                                 const double unseen = t_s - t.last_seen_s;
                                 const double limit = t.state == TrackState::kTentative
                                                          ? p_.tentative_max_gap_s
                                                          : p_.coast_s;
                                 return unseen > limit || !t.x.allFinite() || !t.P.allFinite();
                               }),
                tracks_.end());
}

}  // namespace ptz::perception
