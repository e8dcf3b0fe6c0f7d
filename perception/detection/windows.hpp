// Windows for speed (no LCM): with confirmed tracks, detection runs on a window around each
// track's predicted image in each camera instead of the whole frame, and looks for new objects in
// one band of the image's rows a frame (so the whole image every few frames, about a third of a
// whole scan's cost a frame with the bands' overlap: no frame pays a whole scan), or scans the
// whole frame every few frames; and whenever a window could miss its object. A window's regions
// are those of a full scan: the detector works on a crop with enough margin for its
// filters, and keeps only regions strictly inside the window. A window across the image's border
// is cut to the image (the image's edge is exact). A full scan of a wide image finds its objects on
// the image reduced by a power of two and detects at full resolution in windows around them
// (pyramid.hpp).
#pragma once

#include <opencv2/core.hpp>

#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "common/rig.hpp"
#include "perception/detection/detector.hpp"
#include "perception/tracking/tracker.hpp"

namespace ptz::perception {

struct WindowParams {
  bool enabled = true;
  int full_scan_every = 5;  // frames: every n-th frame is scanned whole (1: always), or n bands
  // The image scanned for new objects a band of rows a frame (n = full_scan_every bands, band k of
  // frame k mod n) instead of whole every n-th frame. A band finds its objects as a full scan does
  // (candidates, on the reduced image for a wide one, then exact windows around them), so no frame
  // costs a whole scan. Each band reaches band_overlap_fraction of the image's height into its
  // neighbours: an object that short is whole in one band, and an object whose rows differ that
  // little between the two images (vertical disparity) is in the same frame's band in both.
  bool full_scan_in_bands = true;
  double band_overlap_fraction = 0.05;
  double margin_px = 16;            // added around each track's projected extent
  double sigma_scale = 3;           // k: the track's radius plus k sigma of its position covariance
  double max_cover_fraction = 0.5;  // windows covering more of an image than this: full scan
  double grow_factor = 2;           // a window whose region crosses its edge grows by this, once
  // Full scans of images wider than this go through the image reduced by 2, 4 or 8 to this width
  // or less (pyramid.hpp); 0: every full scan at full resolution.
  int full_scan_max_width_px = 960;
};

// The image rectangle of a sphere of radius_m around p_head (all of it, distortion included,
// through the eight corners of its bounding cube in the camera frame), grown by margin_px.
// False when any of the cube is not in front of the camera.
bool projectSphere(const CameraView& view, const Eigen::Vector3d& p_head, double radius_m,
                   double margin_px, cv::Rect* rect);

// The same for a box of half-extents half_m along the camera's axes around p_head.
bool projectBox(const CameraView& view, const Eigen::Vector3d& p_head,
                const Eigen::Vector3d& half_m, double margin_px, cv::Rect* rect);

// A track's window in a view at t_s: its predicted position, a box of its radius + k sigma of the
// predicted position covariance along each camera axis, the margin. False as projectBox.
bool trackWindow(const CameraView& view, const Track& track, double t_s, const WindowParams& p,
                 cv::Rect* rect);

// Overlapping (or touching) rectangles replaced by their bounding box until none overlap.
std::vector<cv::Rect> mergeRects(std::vector<cv::Rect> rects);

// What a frame scans: the whole of both images, or windows in each.
struct ScanPlan {
  bool full = true;
  std::string reason;    // why full: disabled, no_tracks, periodic, behind, cover, cut
  bool pyramid = false;  // a full scan done in both images through the reduced image
  // Windowed with bands: the band scanned for new objects in both images (full-image rows, the
  // whole width); empty: none.
  cv::Rect band;
  std::vector<cv::Rect> left, right;
  int unbounded = 0;  // coasting tracks whose window is unbounded, left to the periodic scan
};

// A camera's pixels: the parts `rects` of the image (full-image coordinates) as 8-bit BGR,
// (*parts)[i] those of rects[i].
using DecodeParts = std::function<bool(const std::vector<cv::Rect>& rects,
                                       std::vector<cv::Mat>* parts, std::string* why)>;
// A camera's image rows [row0, row1) (row0 a multiple of scale) reduced by `scale` (2, 4 or 8):
// rows row0 / scale .. ceil(row1 / scale) of the whole image reduced to reducedSize(), 8-bit BGR.
using DecodeReduced =
    std::function<bool(int scale, int row0, int row1, cv::Mat* reduced, std::string* why)>;
// What a scan of a frame looks at: the windows around its tracks (what the frame's messages wait
// for), its band or strip for new objects (ptz-detect searches it after the messages are out), or
// both.
enum class ScanParts { kWindows, kNew, kBoth };
// The pixels of `rect` (full-image coordinates, inside the image) of one camera's image, 8-bit BGR:
// how the markers' and the clicked objects' searches read a frame.
using CropPixels = std::function<bool(const cv::Rect& rect, cv::Mat* out, std::string* why)>;
// fn(0) and fn(1) at once, both cameras' halves of a scan: fn(1) on a thread of the calling
// thread's own (made at its first call, so of that thread's priority), fn(0) in the caller; returns
// once both have, rethrowing either's exception. Not OpenCV's pool: its one pool is shared by every
// thread, and a call from another thread (ptz-detect's search for new objects) made it serial. A
// call from inside fn runs both in turn.
void forBothCameras(const std::function<void(int side)>& fn);
// A camera's pixels: parts at full resolution, and rows reduced (when empty: the rows from
// `parts`, reduced by cv::resize INTER_AREA). Implicit: parts alone will do.
struct ImagePixels {
  ImagePixels(DecodeParts parts_at_full, DecodeReduced reduced_whole = {})
      : parts(std::move(parts_at_full)), reduced(std::move(reduced_whole)) {}
  DecodeParts parts;
  DecodeReduced reduced;
};

class WindowScanner {
 public:
  // exact_margin_px: the detector's (Detector::exactMarginPx). classes: the tracks' classes that
  // get windows (the detector's; empty: every track's); a track of another class (a tag, a person)
  // is looked for by its own scanner, and only keeps the frame windowed.
  WindowScanner(WindowParams params, cv::Size image_size, int exact_margin_px,
                std::vector<std::string> classes = {});

  // The plan of the next frame at t_s from the tracks (predicted to t_s) and the frame's views;
  // advances the periodic count (or the band).
  ScanPlan plan(const std::vector<Track>& tracks, double t_s, const CameraView& left,
                const CameraView& right);

  // Detects in one frame as planned, both sides on two cores: the whole images, or the windows
  // (with a band: and windows around the band's candidates; a window whose region crosses its
  // edge grows once; still crossing, or grown beyond the
  // image or the cover limit: the frame is scanned whole). A full scan of an image wider than
  // full_scan_max_width_px goes through the pyramid (the same regions; pyramid.hpp). False when
  // a decode fails (*why).
  bool detect(const Detector& detector, ScanPlan* plan, const ImagePixels& left,
              const ImagePixels& right, std::vector<Region>* left_regions,
              std::vector<Region>* right_regions, std::string* why);

  // The band of the last windowed plan was not searched (ptz-detect's search for new objects was
  // busy): the next windowed plan takes it again, so no rows are left out for long.
  void retryBand() { next_band_ = (next_band_ + p_.full_scan_every - 1) % p_.full_scan_every; }
  // A windowed plan's band searched on its own (ptz-detect's search for new objects, once the
  // frame's messages are out; `band` and the frame's windows `tracked` as detect() left them):
  // windows around the band's candidates not inside a tracked window, grown once where a region
  // crosses their edge (still crossing: its side's regions are dropped, counted
  // band_windows_cut), their regions in both images. Counts bands_scanned. False when a decode
  // fails (*why).
  bool detectBand(const Detector& detector, const cv::Rect& band,
                  const std::vector<cv::Rect> tracked[2], const ImagePixels& left,
                  const ImagePixels& right, std::vector<Region>* left_regions,
                  std::vector<Region>* right_regions, std::string* why);

  // frames_scanned_full, frames_scanned_windowed, bands_scanned (the bands searched, in the frame
  // or by detectBand),
  // full_scans_<reason>, windows_grown,
  // windows_cut_to_full_scan, windows_unbounded (coasting tracks left to the periodic scan in
  // windowed frames); of the full scans frames_scanned_pyramid, pyramid_fallbacks_<reason> (cut,
  // cover: an image then scanned at full resolution), pyramid_windows_grown; since the start.
  const std::map<std::string, int64_t>& counts() const { return counts_; }
  const WindowParams& params() const { return p_; }

 private:
  bool bands() const { return p_.full_scan_in_bands && p_.full_scan_every > 1; }
  // Why windows cannot be used as they are ("" when they can): cover.
  std::string refuse(const std::vector<cv::Rect>& windows) const;
  // Regions of every window of one side; *cut when one crosses its window's edge.
  bool detectSide(const Detector& detector, const std::vector<cv::Rect>& windows,
                  const DecodeParts& decode, std::vector<Region>* regions, bool* cut,
                  std::string* why) const;
  // Windows grown by grow_factor about their centres, cut to the image, merged.
  std::vector<cv::Rect> grow(const std::vector<cv::Rect>& windows) const;
  // Windows (full-image px) around the candidates in the rows `band` of one side but those
  // touching a track's window (`tracked`): found on the band reduced by `scale` (1: at full
  // resolution) as a pyramid's level, each candidate's box scaled back with the pyramid's margin.
  bool bandWindows(const Detector& detector, int scale, const cv::Rect& band,
                   const ImagePixels& pixels, const std::vector<cv::Rect>& tracked,
                   std::vector<cv::Rect>* windows, std::string* why) const;
  // Band k of full_scan_every (full-image rows, whole width, its overlap included).
  cv::Rect bandRows(int k, int scale) const;
  // The whole image at full resolution.
  bool fullSide(const Detector& detector, const DecodeParts& decode, std::vector<Region>* regions,
                std::string* why) const;
  // A full scan through the image reduced by `scale` (pyramid.cpp); *fallback names why the image
  // must be scanned at full resolution instead ("" when its regions are found), *grown counts
  // window growths.
  bool pyramidSide(const Detector& detector, int scale, const ImagePixels& pixels,
                   std::vector<Region>* regions, std::string* fallback, int* grown,
                   std::string* why) const;

  WindowParams p_;
  cv::Size size_;
  int margin_px_;
  std::vector<std::string> classes_;
  int since_full_ = 0;  // windowed frames since the last full scan
  int next_band_ = 0;   // the band the next windowed frame scans
  std::map<std::string, int64_t> counts_;
};

}  // namespace ptz::perception
