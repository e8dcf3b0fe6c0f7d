#include "perception/detect/new_objects.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>

#include "perception/detect/frame_pixels.hpp"
#include "perception/detection/stereo.hpp"

namespace ptz::perception {
namespace {

// The calling thread below the frames: a real-time one made SCHED_OTHER (below every real-time
// thread, and level with the machine's other work, which a loaded machine needs), any other made
// nicer by `increment`. Its nice value, or -100 and *problem.
int lowerThisThread(int increment, std::string* problem) {
  int policy = 0;
  sched_param param{};
  if (pthread_getschedparam(pthread_self(), &policy, &param) == 0 &&
      (policy == SCHED_FIFO || policy == SCHED_RR)) {
    param.sched_priority = 0;
    const int err = pthread_setschedparam(pthread_self(), SCHED_OTHER, &param);
    if (err != 0) *problem = std::string("SCHED_OTHER refused: ") + std::strerror(err);
    increment = 0;
  }
  const auto tid = static_cast<id_t>(gettid());
  errno = 0;
  const int now = getpriority(PRIO_PROCESS, tid);
  if (now == -1 && errno != 0) {
    *problem = std::string("getpriority: ") + std::strerror(errno);
    return -100;
  }
  const int nice = std::min(19, now + increment);
  if (setpriority(PRIO_PROCESS, tid, nice) != 0) {
    *problem = "nice " + std::to_string(nice) + " refused: " + std::strerror(errno);
    return -100;
  }
  return problem->empty() ? nice : -100;
}

}  // namespace

bool scanTagsAndPeople(MarkerScanner* marker_scanner, PeopleScanner* people_scanner,
                       const std::vector<Track>& tracks, const WindowParams& windows,
                       ScanParts parts, double t_s, const CameraView& lv, const CameraView& rv,
                       const CropPixels crops[2], MarkerScan* markers,
                       std::vector<PatchObject>* people, std::map<std::string, int64_t>* errors,
                       std::string* why) {
  if (marker_scanner->enabled()) {
    try {
      if (!marker_scanner->scan(tracks, t_s, lv, rv, windows, crops, markers, why, parts)) {
        return false;
      }
    } catch (const cv::Exception& e) {
      *markers = {};
      ++(*errors)["marker_errors"];
    }
  }
  // Faces and people: found in the left view, ranged in the right.
  if (people_scanner->enabled()) {
    try {
      if (!people_scanner->scan(tracks, t_s, lv, rv, crops, people, why, parts)) return false;
    } catch (const cv::Exception& e) {
      people->clear();
      ++(*errors)["people_errors"];
    }
  }
  return true;
}

TrackMeasurement markerMeasurement(const MarkerObject& o, int object_index) {
  TrackMeasurement m;
  m.class_name = o.name;
  m.position_m = o.pose.position_head_m;
  m.covariance_m2 = o.pose.covariance.bottomRightCorner<3, 3>();
  m.radius_m = o.radius_m;
  m.object_index = object_index;
  m.has_rotation = true;
  m.rotation = Eigen::Quaterniond(o.pose.rotation_head_object).normalized();
  m.rotation_covariance_rad2 = o.pose.covariance.topLeftCorner<3, 3>();
  return m;
}

TrackMeasurement patchMeasurement(const PatchObject& o, int object_index) {
  TrackMeasurement m;
  m.class_name = o.class_name;
  m.position_m = o.position_m;
  m.covariance_m2 = o.covariance_m2;
  m.radius_m = o.radius_m;
  m.object_index = object_index;
  return m;
}

NewObjectSearch::NewObjectSearch(const DetectConfig& config, std::vector<std::string> class_names,
                                 cv::Size image, bool background, int nice_increment)
    : config_(config),
      class_names_(std::move(class_names)),
      detector_(config.detector),
      windows_(config.windows, image, detector_.exactMarginPx()),
      markers_(config.markers, config.marker_scan, image),
      people_(config.people, config.people_scan, image),
      background_(background),
      nice_increment_(nice_increment) {
  if (background_) thread_ = std::thread([this] { loop(); });
}

NewObjectSearch::~NewObjectSearch() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;  // a running search ends at its next part
  }
  wake_.notify_all();
  thread_.join();
}

bool NewObjectSearch::start(const ptzstereo::stereo_frame_t& frame, const CameraView& lv,
                            const CameraView& rv, const std::vector<Track>& tracks, ColourBand band,
                            bool in_caller) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (busy_ || result_) return false;  // one runs, or its result waits for collect()
  busy_ = true;
  frame_ = frame;
  views_[0] = lv, views_[1] = rv;
  tracks_ = tracks;
  band_ = std::move(band);
  if (background_ && !in_caller) {
    wake_.notify_all();
    return true;
  }
  lock.unlock();
  NewObjectsFound found = search();
  lock.lock();
  result_ = std::move(found);
  busy_ = false;
  return true;
}

std::optional<NewObjectsFound> NewObjectSearch::collect(bool wait) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (wait) done_.wait(lock, [this] { return !busy_; });
  if (busy_ || !result_) return std::nullopt;
  counts_ = scanner_counts_;
  std::optional<NewObjectsFound> out = std::move(result_);
  result_.reset();
  return out;
}

std::string NewObjectSearch::threadProblem() {
  std::lock_guard<std::mutex> lock(mutex_);
  return thread_problem_;
}

void NewObjectSearch::loop() {
  std::string problem;
  const int nice = lowerThisThread(nice_increment_, &problem);
  std::unique_lock<std::mutex> lock(mutex_);
  thread_problem_ = problem, thread_nice_ = nice;
  while (true) {
    wake_.wait(lock, [this] { return stop_ || (busy_ && !result_); });
    if (stop_) return;
    lock.unlock();
    NewObjectsFound found = search();
    lock.lock();
    result_ = std::move(found);
    busy_ = false;
    done_.notify_all();
  }
}

void NewObjectSearch::failed(const char* what, NewObjectsFound* out) noexcept {
  // OpenCV's or libapriltag's refusal of this frame's parts, or memory: it finds nothing, the
  // process goes on (on its own thread an exception would end it), and says so (the caller's
  // discoveries_failed and stderr, with this).
  out->found.clear();
  out->ok = false;
  try {
    out->why = std::string("the search threw: ") + what;
    ++errors_["new_object_errors"];
    std::lock_guard<std::mutex> lock(mutex_);
    scanner_counts_["new_object_errors"] = errors_["new_object_errors"];
  } catch (...) {
  }
}

NewObjectsFound NewObjectSearch::search() {
  const auto t0 = std::chrono::steady_clock::now();
  NewObjectsFound out;
  out.seq = frame_.seq;
  out.t_s = frame_.utime * 1e-6;
  const auto stopping = [this] {
    std::lock_guard<std::mutex> lock(mutex_);
    return stop_;
  };
  try {
    FramePixels left_pixels(frame_.left), right_pixels(frame_.right);
    // New colour objects: the band's regions paired and made measurements, as a frame's are.
    std::vector<Region> lr, rr;
    if (!band_.rows.empty()) {
      detector_.setGates(band_.gates);
      out.ok = windows_.detectBand(detector_, band_.rows, band_.tracked, left_pixels.pixels(),
                                   right_pixels.pixels(), &lr, &rr, &out.why);
    }
    if (out.ok && !(lr.empty() && rr.empty())) {
      const std::vector<StereoObject> objects =
          associate(lr, rr, views_[0], views_[1], config_.stereo);
      for (TrackMeasurement& m :
           trackMeasurements(objects, lr, rr, views_[0], views_[1], class_names_,
                             config_.trusted_area_ratio, tracks_, out.t_s)) {
        m.object_index = -1;  // in none of the frame's messages
        out.found.push_back(std::move(m));
      }
    }
    if (stopping()) return out;
    CropPixels crops[2];
    cropsOf(&left_pixels, &right_pixels, crops);
    MarkerScan markers;
    std::vector<PatchObject> people;
    out.ok = out.ok && scanTagsAndPeople(&markers_, &people_, tracks_, config_.windows,
                                         ScanParts::kNew, out.t_s, views_[0], views_[1], crops,
                                         &markers, &people, &errors_, &out.why);
    if (out.ok) {
      for (const MarkerObject& o : markers.objects) out.found.push_back(markerMeasurement(o, -1));
      for (const PatchObject& o : people) out.found.push_back(patchMeasurement(o, -1));
    }
    out.ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    // The counts as of this search, for collect() (the scanners are this thread's meanwhile).
    std::map<std::string, int64_t> counts = errors_;
    for (const auto* c : {&windows_.counts(), &markers_.counts(), &people_.counts()}) {
      for (const auto& [name, n] : *c) counts[name] = n;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (background_) counts["new_objects_thread_nice"] = thread_nice_;
    scanner_counts_ = std::move(counts);
  } catch (const std::exception& e) {
    failed(e.what(), &out);
  } catch (...) {
    failed("an exception of no known type", &out);
  }
  return out;
}

}  // namespace ptz::perception
