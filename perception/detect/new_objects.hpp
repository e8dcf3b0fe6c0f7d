// ptz-detect's search for new objects (the colours' band, the markers' band and lost tags' windows,
// the people's strip) in a frame whose messages are out (no LCM). It is what a frame costs most
// (the colour band's decoding about 1 ms an image at VGA, the tags' band 10-20 ms), and no pose
// waits for it: on a thread of its own, niced, it runs beside the next frames, which
// do not wait for it unless asked to (a run to be repeated: sim time, a replayed log). It has its
// own detector and scanners (libapriltag keeps state; their counts are added to the windows' ones).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "perception/detect/detect_params.hpp"
#include "perception/tracking/tracker.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz::perception {

// A frame's tags, faces and people in its windows or its band and strip (parts); OpenCV's or
// libapriltag's refusal of some part of a frame costs that frame them (counted in *errors:
// marker_errors, people_errors), never the process. False when a crop fails (*why).
bool scanTagsAndPeople(MarkerScanner* marker_scanner, PeopleScanner* people_scanner,
                       const std::vector<Track>& tracks, const WindowParams& windows,
                       ScanParts parts, double t_s, const CameraView& lv, const CameraView& rv,
                       const CropPixels crops[2], MarkerScan* markers,
                       std::vector<PatchObject>* people, std::map<std::string, int64_t>* errors,
                       std::string* why);

// A tagged object's or a face's or person's measurement for the tracker (object_index: into the
// frame's objects, -1: in no message).
TrackMeasurement markerMeasurement(const MarkerObject& o, int object_index);
TrackMeasurement patchMeasurement(const PatchObject& o, int object_index);

// A windowed frame's band for new colour objects: its rows, the frame's windows in each image
// (what is inside them was found already) and the hue gates its colours were detected with.
struct ColourBand {
  cv::Rect rows;  // empty: none (a frame scanned whole)
  std::vector<cv::Rect> tracked[2];
  std::vector<HueGate> gates;
};

// What one search found.
struct NewObjectsFound {
  int64_t seq = 0;
  double t_s = 0;  // its frame's capture time
  bool ok = true;  // false: a part of the frame did not decode (why)
  std::string why;
  std::vector<TrackMeasurement> found;
  double ms = 0;  // the search's own time
};

class NewObjectSearch {
 public:
  // class_names: the pipeline's (the colour classes first); image: the frames' size. background:
  // on a thread of its own below the caller (a real-time one: SCHED_OTHER; else nice_increment
  // nicer).
  NewObjectSearch(const DetectConfig& config, std::vector<std::string> class_names, cv::Size image,
                  bool background, int nice_increment);
  ~NewObjectSearch();
  NewObjectSearch(const NewObjectSearch&) = delete;
  NewObjectSearch& operator=(const NewObjectSearch&) = delete;

  // The search of a frame (its views; tracks: as updated by it; its colour band), in the
  // background, or at once in the calling thread (in_caller, or not background: a frame that
  // waits for it runs it at its own priority). False when the last one still runs, or its result
  // was not collected: this frame is not searched.
  bool start(const ptzstereo::stereo_frame_t& frame, const CameraView& lv, const CameraView& rv,
             const std::vector<Track>& tracks, ColourBand band, bool in_caller);
  // The search ended since the last call, if any; wait: the running one's, once it ends.
  std::optional<NewObjectsFound> collect(bool wait);
  // The scanners' counts and errors as of the last search collected: bands_scanned,
  // band_windows_cut, marker_*, people_*, new_object_errors (an exception of OpenCV's or
  // libapriltag's: the search's frame found nothing, and its result says why),
  // new_objects_thread_nice (the thread's nice value; -100: it could not be lowered, see
  // threadProblem()).
  const std::map<std::string, int64_t>& counts() const { return counts_; }
  // Why the thread's priority could not be lowered ("" when it was); said once by the caller.
  std::string threadProblem();

 private:
  void loop();
  NewObjectsFound search();  // the job's, in the thread that runs it
  // An exception ended a search: *out found nothing, failed, counted new_object_errors.
  void failed(const char* what, NewObjectsFound* out) noexcept;

  DetectConfig config_;
  std::vector<std::string> class_names_;
  Detector detector_;      // the colours', with each band's gates
  WindowScanner windows_;  // the colour band's
  MarkerScanner markers_;
  PeopleScanner people_;
  bool background_;
  int nice_increment_;
  std::map<std::string, int64_t> counts_, scanner_counts_, errors_;
  // The job and its result; under mutex_ while the thread runs.
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  bool busy_ = false, stop_ = false;
  ptzstereo::stereo_frame_t frame_;
  CameraView views_[2];
  std::vector<Track> tracks_;
  ColourBand band_;
  std::optional<NewObjectsFound> result_;
  std::string thread_problem_;
  int thread_nice_ = 0;
  std::thread thread_;  // last: it starts on the members above
};

}  // namespace ptz::perception
