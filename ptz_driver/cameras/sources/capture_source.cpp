#include "ptz_driver/cameras/sources/capture_source.hpp"

#include "common/measure.hpp"
#include "ptz_driver/cameras/sources/jpeg_file.hpp"

#include <unistd.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <ctime>
#include <deque>
#include <thread>

namespace ptz::driver {
namespace {

std::atomic<int> g_abandoned{0};

bool isJpegName(const std::string& path) {
  const auto dot = path.rfind('.');
  if (dot == std::string::npos) return false;
  std::string ext = path.substr(dot);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".jpg" || ext == ".jpeg";
}

// What the reader thread and its FrameSource share; kept alive by both.
struct Shared {
  std::mutex m;
  std::condition_variable cv;
  std::deque<CapturedFrame> queue;
  bool stop = false, done = false, abandoned = false;
  FrameSource::Poll terminal = FrameSource::Poll::kNothing;
  std::string error;
  int64_t overflowed = 0;
  int64_t skipped = 0;       // image files that did not decode
  std::string last_skipped;  // why the last was skipped
};

// The reader thread: opens the source, reads, stamps, paces files, hands frames over.
class Reader {
 public:
  Reader(SourceSpec spec, CaptureOptions o, std::shared_ptr<PlaybackClock> clock,
         std::shared_ptr<FrameNotifier> notifier, std::shared_ptr<Shared> shared)
      : spec_(std::move(spec)),
        o_(std::move(o)),
        clock_(std::move(clock)),
        notifier_(std::move(notifier)),
        sh_(std::move(shared)) {}

  void run() {
    std::string error;
    if (!open(&error)) return finish(FrameSource::Poll::kFailed, error);
    if (!spec_.live()) {
      const auto first =
          o_.timestamps.empty() ? std::nullopt : std::optional<int64_t>(o_.timestamps.front());
      base_utime_ = clock_->start(first, wallUtime());
    }
    while (!stopped()) {
      CapturedFrame f;
      if (spec_.live()) {
        if (!cap_.grab()) return finish(FrameSource::Poll::kFailed, "no frame (unplugged?)");
        stampLive(&f);
        if (!cap_.retrieve(f.image) || f.image.empty()) {
          return finish(FrameSource::Poll::kFailed, "an empty frame");
        }
      } else if (!readFile(&f)) {
        break;
      }
      f.index = index_++;
      if (f.jpeg.empty()) f.resized = normaliseImage(&f.image, o_.width, o_.height);
      if (!deliver(std::move(f))) break;
    }
    if (!finished_) finish(FrameSource::Poll::kNothing, "");
  }

 private:
  // The V4L2 buffer's time where the driver gives one, else the grab's.
  void stampLive(CapturedFrame* f) {
    const int64_t wall_utime = wallUtime();
    int64_t t = wall_utime;
    if (spec_.kind == SourceKind::kV4l2) {
      timespec mono{};
      clock_gettime(CLOCK_MONOTONIC, &mono);
      const double mono_ms = static_cast<double>(mono.tv_sec) * 1e3 + mono.tv_nsec * 1e-6;
      if (const auto buffer_utime =
              bufferTimeToWallUtime(cap_.get(cv::CAP_PROP_POS_MSEC), mono_ms, wall_utime)) {
        t = *buffer_utime;
        f->buffer_time = true;
      }
    }
    f->capture_utime = t - std::llround(o_.latency_s * 1e6);
  }

  bool open(std::string* error) {
    const std::string what = std::string(sourceKindName(spec_.kind)) + " '" + spec_.text + "'";
    switch (spec_.kind) {
      case SourceKind::kV4l2:
        if (spec_.device_index >= 0 ? !cap_.open(spec_.device_index, cv::CAP_V4L2)
                                    : !cap_.open(spec_.text, cv::CAP_V4L2)) {
          *error = what + " does not open (missing, busy or no permission?)";
          return false;
        }
        if (o_.fourcc.size() == 4) {
          const std::string& c = o_.fourcc;
          cap_.set(cv::CAP_PROP_FOURCC, cv::VideoWriter::fourcc(c[0], c[1], c[2], c[3]));
        }
        if (o_.width > 0) cap_.set(cv::CAP_PROP_FRAME_WIDTH, o_.width);
        if (o_.height > 0) cap_.set(cv::CAP_PROP_FRAME_HEIGHT, o_.height);
        if (o_.fps > 0) cap_.set(cv::CAP_PROP_FPS, o_.fps);
        return true;
      case SourceKind::kGstreamer:
      case SourceKind::kRtsp:
        if (!cap_.open(spec_.pipeline, cv::CAP_GSTREAMER)) {
          *error = what + " does not open (GStreamer pipeline '" + spec_.pipeline + "')";
          return false;
        }
        return true;
      case SourceKind::kVideoFile:
        if (::access(spec_.text.c_str(), R_OK) != 0) {
          *error = what + " is missing or unreadable";
          return false;
        }
        if (!cap_.open(spec_.text, cv::CAP_ANY)) {
          *error = what + " does not open (not a video OpenCV decodes)";
          return false;
        }
        file_fps_ = o_.file_fps > 0 ? o_.file_fps : cap_.get(cv::CAP_PROP_FPS);
        break;
      case SourceKind::kImageFolder:
        try {
          files_ = listImageFiles(spec_.text);
        } catch (const std::exception& e) {
          *error = e.what();
          return false;
        }
        file_fps_ = o_.file_fps;
        break;
    }
    if (!(file_fps_ > 0 && file_fps_ < 1e4)) file_fps_ = 30;
    return true;
  }

  // The next frame of a file or folder, stamped and due; false when it ended (or stopped). An
  // image file that does not decode is skipped and counted (its time too: the others keep theirs).
  bool readFile(CapturedFrame* f) {
    for (;;) {
      const size_t i = static_cast<size_t>(file_index_);
      bool got = false, bad = false;
      std::string end_reason, why;
      if (!files_.empty()) {
        if (i < files_.size()) {
          got = readImageFile(files_[i], f, &why);
          bad = !got;
        }
      } else {
        got = cap_.read(f->image) && !f->image.empty();
      }
      if ((got || bad) && !o_.timestamps.empty() && i >= o_.timestamps.size()) {
        got = bad = false;
        end_reason = "its timestamps file ends after " + std::to_string(i) + " times";
      }
      if (got || bad) {
        const int64_t t = o_.timestamps.empty()
                              ? base_utime_ + std::llround(file_index_ * 1e6 / file_fps_)
                              : o_.timestamps[i];
        if (file_index_ == 0) first_utime_ = t;
        last_utime_ = t;
        ++file_index_;
        if (bad) {
          skip(why);
          if (stopped()) return false;
          continue;
        }
        delivered_in_pass_ = true;
        f->capture_utime = t + loop_offset_us_;
        return waitUntil(clock_->dueUtime(f->capture_utime));
      }
      if (end_reason.empty() && file_index_ > 0 && !delivered_in_pass_) {
        end_reason = "none of its " + std::to_string(file_index_) + " image files decodes";
      }
      if (!o_.loop || file_index_ == 0 || !end_reason.empty() || stopped()) {
        finish(FrameSource::Poll::kEnded, end_reason);
        return false;
      }
      // Again from the start, the times continuing one mean frame interval after the last.
      const int64_t n = file_index_;
      const int64_t span = last_utime_ - first_utime_;
      loop_offset_us_ += span + (n > 1 ? span / (n - 1) : std::llround(1e6 / file_fps_));
      file_index_ = 0;
      delivered_in_pass_ = false;
      if (files_.empty() && !cap_.open(spec_.text, cv::CAP_ANY)) {
        finish(FrameSource::Poll::kEnded, "it does not open again to loop");
        return false;
      }
    }
  }

  // A JPEG of the published size, when its output is JPEG, as its bytes; anything else decoded.
  bool readImageFile(const std::string& path, CapturedFrame* f, std::string* why) {
    if (!o_.pass_jpeg || !isJpegName(path)) {
      f->image = cv::imread(path, cv::IMREAD_COLOR);
    } else {
      std::vector<uint8_t> bytes;
      if (!readFileBytes(path, &bytes, why)) return false;
      std::string not_passed;
      int w = 0, h = 0;
      if (checkPassThroughJpeg(bytes.data(), bytes.size(), o_.width, o_.height, &w, &h,
                               &not_passed)) {
        f->jpeg = std::move(bytes);
        f->jpeg_size = cv::Size(w, h);
        return true;
      }
      f->image = cv::imdecode(bytes, cv::IMREAD_COLOR);  // another size, or not a plain JPEG
    }
    if (f->image.empty()) *why = "image file '" + path + "' does not decode";
    return !f->image.empty();
  }

  void skip(const std::string& why) {
    std::lock_guard<std::mutex> lock(sh_->m);
    ++sh_->skipped;
    sh_->last_skipped = why;
  }

  bool stopped() {
    std::lock_guard<std::mutex> lock(sh_->m);
    return sh_->stop;
  }

  bool waitUntil(int64_t wall_utime) {
    std::unique_lock<std::mutex> lock(sh_->m);
    const auto due = std::chrono::system_clock::time_point(std::chrono::microseconds(wall_utime));
    return !sh_->cv.wait_until(lock, due, [&] { return sh_->stop; });
  }

  // Files wait for room in the queue; live sources drop the oldest frame instead.
  bool deliver(CapturedFrame f) {
    {
      std::unique_lock<std::mutex> lock(sh_->m);
      if (spec_.live()) {
        if (sh_->queue.size() >= o_.queue_frames) {
          sh_->queue.pop_front();
          ++sh_->overflowed;
        }
      } else {
        sh_->cv.wait(lock, [&] { return sh_->stop || sh_->queue.size() < o_.queue_frames; });
      }
      if (sh_->stop) return false;
      sh_->queue.push_back(std::move(f));
    }
    notifier_->notify();
    return true;
  }

  void finish(FrameSource::Poll terminal, const std::string& error) {
    finished_ = true;
    cap_.release();
    {
      std::lock_guard<std::mutex> lock(sh_->m);
      sh_->terminal = terminal;
      sh_->error = error;
      sh_->done = true;
      if (sh_->abandoned) --g_abandoned;
    }
    sh_->cv.notify_all();
    notifier_->notify();
  }

  SourceSpec spec_;
  CaptureOptions o_;
  std::shared_ptr<PlaybackClock> clock_;
  std::shared_ptr<FrameNotifier> notifier_;
  std::shared_ptr<Shared> sh_;
  cv::VideoCapture cap_;
  std::vector<std::string> files_;
  double file_fps_ = 30;
  int64_t index_ = 0, file_index_ = 0;
  int64_t base_utime_ = 0, first_utime_ = 0, last_utime_ = 0, loop_offset_us_ = 0;
  bool finished_ = false;
  bool delivered_in_pass_ = false;  // a frame since the file's start (a loop needs one)
};

class CaptureSource : public FrameSource {
 public:
  CaptureSource(const SourceSpec& spec, const CaptureOptions& o,
                std::shared_ptr<PlaybackClock> clock, std::shared_ptr<FrameNotifier> notifier)
      : sh_(std::make_shared<Shared>()) {
    auto reader = std::make_shared<Reader>(spec, o, std::move(clock), std::move(notifier), sh_);
    thread_ = std::thread([reader] { reader->run(); });
  }

  ~CaptureSource() override {
    std::unique_lock<std::mutex> lock(sh_->m);
    sh_->stop = true;
    sh_->cv.notify_all();
    // A reader blocked in its driver (a stalled stream) is left to finish by itself.
    if (sh_->cv.wait_for(lock, std::chrono::milliseconds(100), [&] { return sh_->done; })) {
      lock.unlock();
      thread_.join();
    } else {
      sh_->abandoned = true;
      ++g_abandoned;
      lock.unlock();
      thread_.detach();
    }
  }

  Poll poll(CapturedFrame* frame) override {
    std::lock_guard<std::mutex> lock(sh_->m);
    if (!sh_->queue.empty()) {
      *frame = std::move(sh_->queue.front());
      sh_->queue.pop_front();
      sh_->cv.notify_all();  // room for a file reader waiting to deliver
      return Poll::kFrame;
    }
    return sh_->done ? sh_->terminal : Poll::kNothing;
  }

  std::string error() const override {
    std::lock_guard<std::mutex> lock(sh_->m);
    return sh_->error;
  }

  int64_t overflowed() const override {
    std::lock_guard<std::mutex> lock(sh_->m);
    return sh_->overflowed;
  }

  int64_t skipped() const override {
    std::lock_guard<std::mutex> lock(sh_->m);
    return sh_->skipped;
  }

  std::string lastSkipped() const override {
    std::lock_guard<std::mutex> lock(sh_->m);
    return sh_->last_skipped;
  }

 private:
  std::shared_ptr<Shared> sh_;
  std::thread thread_;
};

}  // namespace

SourceFactory makeCaptureFactory(const SourceSpec& spec, const CaptureOptions& options,
                                 std::shared_ptr<PlaybackClock> clock,
                                 std::shared_ptr<FrameNotifier> notifier) {
  return [=]() -> std::unique_ptr<FrameSource> {
    return std::make_unique<CaptureSource>(spec, options, clock, notifier);
  };
}

int abandonedReaders() {
  return g_abandoned.load();
}

}  // namespace ptz::driver
