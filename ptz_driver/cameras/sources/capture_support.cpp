// The pieces of capture_source.hpp that need no thread: the playback clock, the notifier, the
// wall clock and image normalisation.
#include <sys/eventfd.h>
#include <unistd.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "ptz_driver/cameras/sources/capture_source.hpp"

namespace ptz::driver {

int64_t PlaybackClock::start(std::optional<int64_t> first_recorded_utime, int64_t now_utime) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!started_) {
    started_ = true;
    wall_start_ = now_utime;
    origin_ = first_recorded_utime.value_or(now_utime);
  } else if (first_recorded_utime) {
    origin_ = std::min(origin_, *first_recorded_utime);
  }
  return wall_start_;
}

int64_t PlaybackClock::dueUtime(int64_t recorded_utime) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return wall_start_ + (recorded_utime - origin_);
}

FrameNotifier::FrameNotifier() : fd_(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {}
FrameNotifier::~FrameNotifier() {
  if (fd_ >= 0) ::close(fd_);
}
void FrameNotifier::notify() {
  const uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(fd_, &one, sizeof one);
}
void FrameNotifier::drain() {
  uint64_t count = 0;
  [[maybe_unused]] const ssize_t n = ::read(fd_, &count, sizeof count);
}

std::optional<int64_t> bufferTimeToWallUtime(double buffer_ms, double mono_now_ms,
                                             int64_t wall_now_utime, double max_age_ms) {
  constexpr double k2To31 = 2147483648.0, k2To32 = 4294967296.0;
  double age_ms = mono_now_ms - buffer_ms;
  // With a 32-bit time_t (armhf) OpenCV's 1000 * tv_sec wraps after 24.9 days of uptime.
  if (std::isfinite(age_ms) && age_ms > max_age_ms && std::fabs(buffer_ms) < k2To31 + 1e3 &&
      mono_now_ms >= k2To31) {
    age_ms = std::fmod(age_ms, k2To32);
  }
  // 0 before the first frame; other clocks (REALTIME, a driver's own) land far outside.
  if (buffer_ms == 0 || !(age_ms >= 0) || age_ms > max_age_ms) return std::nullopt;
  return wall_now_utime - std::llround(age_ms * 1e3);
}

bool normaliseImage(cv::Mat* image, int width, int height) {
  if (image->depth() != CV_8U) {
    const double scale = image->depth() == CV_16U ? 1.0 / 256 : 1.0;
    image->convertTo(*image, CV_8U, scale);
  }
  if (image->channels() == 4) cv::cvtColor(*image, *image, cv::COLOR_BGRA2BGR);
  if (width <= 0 || height <= 0 || (image->cols == width && image->rows == height)) return false;
  cv::resize(*image, *image, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  return true;
}

}  // namespace ptz::driver
