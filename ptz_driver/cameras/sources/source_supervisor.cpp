#include "ptz_driver/cameras/sources/source_supervisor.hpp"

#include <algorithm>

namespace ptz::driver {

SourceSupervisor::SourceSupervisor(std::string name, SourceFactory factory, SupervisorParams params,
                                   bool live)
    : name_(std::move(name)),
      factory_(std::move(factory)),
      params_(params),
      live_(live),
      retry_(params.retry_initial_s, params.retry_max_s) {}

void SourceSupervisor::step(double now_s, std::vector<CapturedFrame>* frames, size_t max_frames) {
  if (state_ == State::kEnded) return;
  if (state_ == State::kWaiting) {
    if (!retry_.due(now_s)) return;
    source_ = factory_();
    skipped_in_source_ = 0;
    state_ = State::kConnecting;
    attempt_start_s_ = now_s;
    had_frame_ = false;
  }
  CapturedFrame frame;
  for (size_t taken = 0;; ++taken) {
    if (taken == max_frames) {
      if (state_ == State::kStreaming) last_frame_s_ = now_s;  // we paused it, it did not stop
      break;
    }
    const FrameSource::Poll r = source_->poll(&frame);
    noteSkipped();
    if (r == FrameSource::Poll::kNothing) break;
    if (r == FrameSource::Poll::kFrame) {
      frames->push_back(std::move(frame));
      frame = CapturedFrame{};
      ++frames_;
      last_frame_s_ = now_s;
      if (!had_frame_ && reconnects_ > 0) events_.push_back(name_ + ": frames again");
      had_frame_ = true;
      state_ = State::kStreaming;
      retry_.succeeded();  // it worked: the next failure starts over
      continue;
    }
    if (r == FrameSource::Poll::kEnded) {
      overflowed_done_ += source_->overflowed();
      const std::string why = source_->error();
      source_.reset();
      state_ = State::kEnded;
      events_.push_back(name_ + ": " + (why.empty() ? "end of file" : why) + " after " +
                        std::to_string(frames_) + " frames");
      return;
    }
    giveUp(now_s, (had_frame_ ? "read failed: " : "cannot open: ") + source_->error());
    return;
  }
  if (!live_) return;  // a recording waiting for its next frame's time is not silent
  if (state_ == State::kStreaming && now_s - last_frame_s_ > params_.source_timeout_s) {
    giveUp(now_s, "no frame for " + secondsText(now_s - last_frame_s_));
  } else if (state_ == State::kConnecting && now_s - attempt_start_s_ > params_.open_timeout_s) {
    giveUp(now_s, "no frame " + secondsText(now_s - attempt_start_s_) + " after opening");
  }
}

void SourceSupervisor::noteSkipped() {
  const int64_t n = source_->skipped();
  if (n == skipped_in_source_) return;
  skipped_ += n - skipped_in_source_;
  skipped_in_source_ = n;
  last_skipped_ = source_->lastSkipped();
  events_.push_back(name_ + ": " + last_skipped_ + ", skipped (" + std::to_string(skipped_) +
                    " so far)");
}

void SourceSupervisor::giveUp(double now_s, const std::string& why) {
  overflowed_done_ += source_->overflowed();
  source_.reset();  // a real source leaves a reader blocked in its driver to finish by itself
  ++reconnects_;
  why_ = why;
  events_.push_back(name_ + ": " + why + ", reconnecting in " + secondsText(retry_.failed(now_s)));
  state_ = State::kWaiting;
}

int64_t SourceSupervisor::overflowed() const {
  return overflowed_done_ + (source_ ? source_->overflowed() : 0);
}

std::string SourceSupervisor::problem(double now_s) const {
  if (state_ == State::kWaiting && reconnects_ > 0) {
    return name_ + ": " + why_ + ", reconnecting in " +
           secondsText(std::max(0.0, retry_.retryAtS() - now_s));
  }
  if (state_ == State::kConnecting && reconnects_ > 0) {
    return name_ + ": " + why_ + ", reconnecting (attempt " + std::to_string(reconnects_ + 1) + ")";
  }
  return "";
}

std::vector<std::string> SourceSupervisor::takeEvents() {
  std::vector<std::string> out;
  out.swap(events_);
  return out;
}

}  // namespace ptz::driver
