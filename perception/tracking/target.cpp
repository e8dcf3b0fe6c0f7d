#include "perception/tracking/target.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ptz::perception {
namespace {

bool lockable(const Track& t) {
  return t.state != TrackState::kTentative;
}

constexpr double kPredictionHorizonS = 5.0;  // re-acquisition by prediction, at most this late
// Re-acquisition by prediction takes the nearest candidate only when it is at most this share of
// the next one's distance from the prediction.
constexpr double kUnambiguousRatio = 0.5;

std::string describe(const Track& t) {
  return "track " + std::to_string(t.id) + " (" + t.class_name + ")";
}

}  // namespace

TargetSelector::TargetSelector(std::string default_class, std::vector<std::string> known_classes,
                               double pick_radius_px)
    : default_class_(std::move(default_class)),
      known_classes_(std::move(known_classes)),
      pick_radius_px_(pick_radius_px),
      class_(default_class_) {}

void TargetSelector::lock(const Track& t, const std::string& why) {
  locked_id_ = t.id;
  class_ = t.class_name;
  reason_ = "locked on " + describe(t) + " " + why;
  lost_.reset();
}

void TargetSelector::release(const std::string& why) {
  locked_id_ = -1;
  lost_.reset();
  reason_ = why;
}

int64_t TargetSelector::choose(double t_s, const std::vector<Track>& tracks) {
  if (locked_id_ >= 0) {
    for (const auto& t : tracks) {
      if (t.id == locked_id_) {
        lost_ = t;  // the newest state, for the case it goes
        return locked_id_;
      }
    }
    reason_ = "lost track " + std::to_string(locked_id_) + " (" + class_ + ")";
    locked_id_ = -1;
  }
  // A loss long past says nothing of where the target went.
  if (lost_ && t_s - lost_->t_s > kPredictionHorizonS) lost_.reset();
  const Track* best = nullptr;
  double best_cost = std::numeric_limits<double>::infinity();
  double second_cost = best_cost, beside_cost = best_cost;
  int beside = 0;
  for (const auto& t : tracks) {
    if (!lockable(t) || t.class_name != class_) continue;
    // Born beside the lost target (a merge of look-alikes): it may be the target or the other
    // one; handing it the target is a guess. It competes (a near one makes the choice a tie)
    // but never wins.
    const bool born_beside = lost_ && t.bornBeside(lost_->id);
    beside += born_beside;
    double cost;
    if (lost_) {
      // Where the lost target was heading (constant velocity, at most 1 s on: the acceleration
      // of an old state is no guide).
      const double dt = std::clamp(t_s - lost_->t_s, 0.0, 1.0);
      cost = (t.position() - (lost_->position() + dt * lost_->velocity())).norm();
    } else {
      // The angle from the optical axis at home (+z).
      const Eigen::Vector3d p = t.position();
      cost = std::atan2(std::hypot(p.x(), p.y()), p.z());
    }
    if (born_beside) {
      beside_cost = std::min(beside_cost, cost);
    } else if (cost < best_cost) {
      second_cost = best_cost;
      best_cost = cost;
      best = &t;
    } else {
      second_cost = std::min(second_cost, cost);
    }
  }
  second_cost = std::min(second_cost, beside_cost);
  // By prediction only when one candidate is clearly the nearest: two about as near the lost
  // target's path are a coin toss, which waits for them to part.
  if (best && lost_ && best_cost > kUnambiguousRatio * second_cost) {
    reason_ = "lost track " + std::to_string(lost_->id) + " (" + class_ + "): tracks near its " +
              "prediction too alike to choose";
    return locked_id_;
  }
  if (!best && beside > 0) {
    reason_ = "lost track " + std::to_string(lost_->id) + " (" + class_ + "): only tracks born " +
              "beside it, which may be another look-alike";
  }
  if (best) {
    const bool again = lost_.has_value();
    const int64_t lost_id = again ? lost_->id : -1;
    lock(*best, again ? "by prediction after losing track " + std::to_string(lost_id)
                      : "by class (nearest the home optical axis)");
  }
  return locked_id_;
}

bool TargetSelector::request(const TargetRequest& r, const std::vector<Track>& tracks,
                             const CameraView& left, const CameraView& right, std::string* why) {
  auto refuse = [&](const std::string& text) {
    if (why) *why = text;
    return false;
  };
  switch (r.mode) {
    case TargetRequest::Mode::kClass: {
      const std::string name = r.class_name.empty() ? default_class_ : r.class_name;
      if (std::find(known_classes_.begin(), known_classes_.end(), name) == known_classes_.end()) {
        return refuse("unknown class '" + name + "'");
      }
      if (name == class_ && locked_id_ >= 0) return true;  // already on one of that class
      class_ = name;
      locked_id_ = -1;
      lost_.reset();
      reason_ = "class " + name + " requested: waiting for a confirmed track";
      return true;
    }
    case TargetRequest::Mode::kTrackId: {
      for (const auto& t : tracks) {
        if (t.id != r.track_id) continue;
        if (!lockable(t)) return refuse("track " + std::to_string(r.track_id) + " is tentative");
        lock(t, "by request for its id");
        return true;
      }
      return refuse("no track " + std::to_string(r.track_id));
    }
    case TargetRequest::Mode::kImagePoint: {
      const CameraView& view = r.camera == Side::kLeft ? left : right;
      if (!r.pixel.allFinite() || r.pixel.x() < 0 || r.pixel.y() < 0 ||
          r.pixel.x() > view.width - 1 || r.pixel.y() > view.height - 1) {
        return refuse("point outside the image");
      }
      const Track* best = nullptr;
      double best_px = std::numeric_limits<double>::infinity();
      for (const auto& t : tracks) {
        if (!lockable(t)) continue;
        const Eigen::Vector2d px = view.project(t.position());
        if (!px.allFinite()) continue;
        const double range = (t.position() - view.position_head_m).norm();
        const double radius_px = range > 0 ? view.intrinsics.fx * t.radius_m / range : 0;
        const double d = (px - r.pixel).norm();
        if (d <= std::max(pick_radius_px_, 1.5 * radius_px) && d < best_px) {
          best_px = d;
          best = &t;
        }
      }
      if (!best) return refuse("no confirmed track under the point");
      lock(*best, "by request for an image point");
      return true;
    }
  }
  return refuse("unknown mode");
}

}  // namespace ptz::perception
