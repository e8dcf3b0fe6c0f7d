// A scripted camera for tests of ptz-camera's library: each connection (FrameSource) it makes
// opens or not, hands over the frames queued on the camera, then fails, ends or stays quiet.
#pragma once

#include <deque>
#include <memory>
#include <string>

#include "ptz_driver/cameras/sources/frame_source.hpp"

namespace ptz::test {

struct FakeCamera {
  bool opens = true;                             // false: every new connection fails at once
  std::deque<ptz::driver::CapturedFrame> queue;  // what the current connection delivers next
  bool fail_after_queue = false;                 // then the read fails (unplugged)
  bool end_after_queue = false;                  // then end of file
  int connections = 0;

  void push(int64_t capture_utime, int64_t index = 0) {
    ptz::driver::CapturedFrame f;
    f.capture_utime = capture_utime;
    f.index = index;
    queue.push_back(f);
  }
};

class FakeSource : public ptz::driver::FrameSource {
 public:
  explicit FakeSource(std::shared_ptr<FakeCamera> camera)
      : camera_(std::move(camera)), opened_(camera_->opens) {
    ++camera_->connections;
  }
  Poll poll(ptz::driver::CapturedFrame* frame) override {
    if (!opened_) {
      error_ = "no such camera";
      return Poll::kFailed;
    }
    if (!camera_->queue.empty()) {
      *frame = camera_->queue.front();
      camera_->queue.pop_front();
      return Poll::kFrame;
    }
    if (camera_->fail_after_queue) {
      error_ = "unplugged";
      return Poll::kFailed;
    }
    return camera_->end_after_queue ? Poll::kEnded : Poll::kNothing;
  }
  std::string error() const override { return error_; }

 private:
  std::shared_ptr<FakeCamera> camera_;
  bool opened_;
  std::string error_;
};

inline ptz::driver::SourceFactory fakeFactory(std::shared_ptr<FakeCamera> camera) {
  return [camera] { return std::make_unique<FakeSource>(camera); };
}

}  // namespace ptz::test
