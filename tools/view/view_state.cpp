#include "tools/view/view_state.hpp"

#include <algorithm>
#include <cstdlib>
#include <iterator>

namespace ptz::tools {
namespace {

void keepLastSecond(std::deque<int64_t>* times_us, int64_t now_us) {
  times_us->push_back(now_us);
  while (times_us->front() < now_us - 1'000'000) times_us->pop_front();
}

template <class Map>
void eraseUpTo(Map* by_seq, int64_t seq) {
  by_seq->erase(by_seq->begin(), by_seq->upper_bound(seq));
}

}  // namespace

// Those farthest from the newest frame go first: bogus frame_seqs can neither grow the maps nor
// crowd out the rest.
template <class Map>
void ViewState::keepRecent(Map* by_seq) const {
  const auto far = [&](int64_t seq) {
    return std::abs(static_cast<double>(seq) - static_cast<double>(newest_frame_seq_));
  };
  while (by_seq->size() > kKept) {
    if (far(by_seq->begin()->first) >= far(by_seq->rbegin()->first)) {
      by_seq->erase(by_seq->begin());
    } else {
      by_seq->erase(std::prev(by_seq->end()));
    }
  }
}

void ViewState::forgetUpTo(int64_t seq) {
  eraseUpTo(&detections_by_seq_, seq);
  eraseUpTo(&poses_by_seq_, seq);
  eraseUpTo(&tracks_by_seq_, seq);
}

void ViewState::onFrame(const ptzstereo::stereo_frame_t& m, int64_t now_us, bool paused) {
  newest_frame_seq_ = m.seq;
  keepLastSecond(&frame_times_us_, now_us);
  if (paused) {
    ++frames_not_drawn_;
    forgetUpTo(m.seq);  // its detections, poses and tracks will never be drawn either
    return;
  }
  // Kept as it came: only the frame that is drawn is decoded (a newer one replaces it).
  if (pending_) ++frames_not_drawn_;
  pending_ = Pending{m, now_us};
}

void ViewState::onDetections(const ptzstereo::object_detections_t& m) {
  detections_by_seq_[m.frame_seq] = m;
  keepRecent(&detections_by_seq_);
}

void ViewState::onPose(const ptzstereo::object_pose_t& m) {
  poses_by_seq_[m.frame_seq] = m;
  keepRecent(&poses_by_seq_);
}

void ViewState::onTracks(const ptzstereo::object_tracks_t& m) {
  tracks_by_seq_[m.frame_seq] = m;
  keepRecent(&tracks_by_seq_);
  tracks_seen_ = true;
}

void ViewState::onControlStatus(const ptzstereo::process_status_t& m) {
  for (const auto& c : m.counters) {
    if (c.name == "delay_us_p50") delay_ms_p50_ = c.value / 1000.0;
    if (c.name == "delay_us_p99") delay_ms_p99_ = c.value / 1000.0;
  }
}

const ptzstereo::stereo_frame_t* ViewState::ready(int64_t now_us) const {
  if (!pending_) return nullptr;
  const int64_t seq = pending_->frame.seq;
  // Tracks are waited for once a ptz-detect has sent some (an older log has none).
  const bool complete = detections_by_seq_.count(seq) && poses_by_seq_.count(seq) &&
                        (!tracks_seen_ || tracks_by_seq_.count(seq));
  if (!complete && now_us - pending_->received_us < max_wait_us_) return nullptr;
  return &pending_->frame;
}

ViewInput ViewState::input(int64_t now_us, bool paused) const {
  ViewInput in;
  if (!pending_) return in;
  const ptzstereo::stereo_frame_t& m = pending_->frame;
  const int64_t seq = m.seq;
  in.left_ptz = {m.left.pan_rad, m.left.tilt_rad, m.left.zoom};
  in.right_ptz = {m.right.pan_rad, m.right.tilt_rad, m.right.zoom};
  in.seq = seq;
  if (detections_by_seq_.count(seq)) in.detections = detections_by_seq_.at(seq);
  if (poses_by_seq_.count(seq)) in.pose = poses_by_seq_.at(seq);
  if (tracks_by_seq_.count(seq)) in.tracks = tracks_by_seq_.at(seq);
  in.setpoint = setpoint_;
  in.control = control_;
  in.delay_ms_p50 = delay_ms_p50_;
  in.delay_ms_p99 = delay_ms_p99_;
  in.frame_rate_hz = static_cast<double>(frame_times_us_.size());
  // This frame and those drawn within the second before it.
  in.drawn_rate_hz = 1.0 + static_cast<double>(std::count_if(
                               drawn_times_us_.begin(), drawn_times_us_.end(),
                               [now_us](int64_t t) { return t >= now_us - 1'000'000; }));
  in.frames_dropped = frames_not_drawn_;
  in.paused = paused;
  return in;
}

void ViewState::done(bool drawn, int64_t now_us) {
  if (!pending_) return;
  const int64_t seq = pending_->frame.seq;
  pending_.reset();
  if (!drawn) return;
  keepLastSecond(&drawn_times_us_, now_us);
  forgetUpTo(seq);  // only the frames still to come are worth keeping
}

size_t ViewState::keptForFrames() const {
  return detections_by_seq_.size() + poses_by_seq_.size() + tracks_by_seq_.size();
}

}  // namespace ptz::tools
