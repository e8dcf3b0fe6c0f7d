#include "perception/detect/detect_pipeline.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "common/measure.hpp"
#include "perception/detect/detect_messages.hpp"
#include "perception/detect/frame_pixels.hpp"
#include "perception/detect/new_objects.hpp"

namespace ptz::perception {
namespace {

// The colour classes' names (the ones the colour windows go around).
std::vector<std::string> colourClassNames(const DetectorParams& dp) {
  std::vector<std::string> names;
  for (const auto& c : dp.classes) names.push_back(c.name);
  return names;
}

// The colour classes, every tagged object's name, the faces' and people's classes (TARGET_SELECT
// may name any).
std::vector<std::string> classNames(const DetectorParams& dp,
                                    const std::vector<MarkerClass>& markers,
                                    const std::vector<PeopleClass>& people) {
  std::vector<std::string> names = colourClassNames(dp);
  for (const auto& n : markerObjectNames(markers)) names.push_back(n);
  for (const auto& c : people) names.push_back(c.name);
  names.push_back(ClickedTracker::kClassName);
  return names;
}

// A camera's view as the frame says its head stood.
CameraView frameView(const StereoRig& rig, Side side, const ptzstereo::image_t& image) {
  return rig.view(side, {image.pan_rad, image.tilt_rad, image.zoom});
}

}  // namespace

DetectPipeline::DetectPipeline(DetectConfig config, StereoRig rig)
    : config_(std::move(config)),
      rig_(std::move(rig)),
      detector_(config_.detector),
      tracker_(config_.tracker),
      class_names_(classNames(detector_.params(), config_.markers, config_.people)),
      selector_(config_.target_class, class_names_, config_.pick_radius_px),
      windows_(config_.windows, {rig_.left.width, rig_.left.height}, detector_.exactMarginPx(),
               colourClassNames(config_.detector)),
      markers_(config_.markers, config_.marker_scan, {rig_.left.width, rig_.left.height}),
      people_(config_.people, config_.people_scan, {rig_.left.width, rig_.left.height}),
      clicked_(config_.clicked),
      new_objects_(std::make_unique<NewObjectSearch>(
          config_, class_names_, cv::Size(rig_.left.width, rig_.left.height),
          config_.new_objects_after_publish && config_.new_objects_background,
          config_.new_objects_nice_increment)),
      color_models_(config_.detector.classes.size()) {}

DetectPipeline::~DetectPipeline() = default;

std::string DetectPipeline::newObjectsThreadProblem() const {
  return new_objects_->threadProblem();
}

bool DetectPipeline::process(const ptzstereo::stereo_frame_t& m, FrameOutputs* out,
                             std::string* why) {
  out->click_note.clear();
  out->new_objects_note.clear();
  // An earlier frame's new objects first: their tracks get windows in this one.
  absorbNewObjects(false, &out->new_objects_note);
  const CameraView lv = frameView(rig_, Side::kLeft, m.left);
  const CameraView rv = frameView(rig_, Side::kRight, m.right);
  const double t_s = m.utime * 1e-6;
  if (t_s < last_t_s_) {  // a new run of the source: a click and its model were the old run's
    pending_click_.reset();
    clicked_.stop();
    recent_views_.clear();
    for (ColorModel& model : color_models_) model.reset();
  }
  last_t_s_ = t_s;
  const auto t0 = std::chrono::steady_clock::now();
  // Windows around the tracks' predicted images, or the whole frames; decoding only what is
  // scanned. Left and right on two cores (the detector's gates are set before, read only there).
  ScanPlan plan = windows_.plan(tracker_.tracks(), t_s, lv, rv);
  // The band for new objects waits for discover(), off the frame's latency.
  pending_band_ = {};
  if (config_.new_objects_after_publish) std::swap(pending_band_.rows, plan.band);
  if (config_.detector.adapt.follow) {
    std::vector<HueGate> gates;
    for (const ColorModel& model : color_models_) {
      gates.push_back(model.gate(t_s, config_.detector.adapt));
    }
    pending_band_.gates = gates;
    detector_.setGates(std::move(gates));
  }
  std::vector<Region> lr, rr;
  FramePixels left_pixels(m.left), right_pixels(m.right);
  if (!windows_.detect(detector_, &plan, left_pixels.pixels(), right_pixels.pixels(), &lr, &rr,
                       why)) {
    return false;
  }
  if (plan.full) {
    pending_band_.rows = {};  // scanned whole: nothing is new to a band
  } else {
    pending_band_.tracked[0] = plan.left;
    pending_band_.tracked[1] = plan.right;
  }
  const std::vector<StereoObject> objects = associate(lr, rr, lv, rv, config_.stereo);
  std::vector<TrackMeasurement> measurements = trackMeasurements(
      objects, lr, rr, lv, rv, class_names_, config_.trusted_area_ratio, tracker_.tracks(), t_s);
  const std::vector<BoxYaw> yaws =
      estimateYaws(m, {&left_pixels, &right_pixels}, objects, measurements, lr, rr, lv, rv);
  for (TrackMeasurement& tm : measurements) {
    if (tm.object_index < 0 || static_cast<size_t>(tm.object_index) >= yaws.size()) continue;
    const BoxYaw& y = yaws[static_cast<size_t>(tm.object_index)];
    tm.has_yaw = y.ok;
    tm.yaw_rad = y.yaw_rad;
    tm.yaw_var_rad2 = y.variance_rad2;
  }
  // Tags, faces and people in the windows around their tracks, from the pixels decoded for the
  // colours; their band and strip for new ones wait for discover() (new_objects_after_publish).
  CropPixels crops[2];
  cropsOf(&left_pixels, &right_pixels, crops);
  MarkerScan markers;
  std::vector<PatchObject> people;
  const ScanParts parts =
      config_.new_objects_after_publish ? ScanParts::kWindows : ScanParts::kBoth;
  if (!scanTagsAndPeople(&markers_, &people_, tracker_.tracks(), config_.windows, parts, t_s, lv,
                         rv, crops, &markers, &people, &scan_errors_, why)) {
    return false;
  }
  for (size_t i = 0; i < markers.objects.size(); ++i) {
    measurements.push_back(
        markerMeasurement(markers.objects[i], static_cast<int>(objects.size() + i)));
  }
  for (size_t i = 0; i < people.size(); ++i) {
    measurements.push_back(
        patchMeasurement(people[i], static_cast<int>(objects.size() + markers.objects.size() + i)));
  }
  std::optional<PatchObject> clicked;
  try {
    clicked = clickedObject(m.seq, t_s, crops, lv, rv, out);
  } catch (const cv::Exception& e) {
    clicked_.stop();
    ++counters_["click_errors"];
    out->click_note = std::string("the click's model failed: ") + e.what();
  }
  if (clicked) {
    measurements.push_back(patchMeasurement(
        *clicked, static_cast<int>(objects.size() + markers.objects.size() + people.size())));
  }
  const std::vector<ViewMeasurement> one_view = viewMeasurements(
      objects, lr, rr, lv, rv, class_names_, config_.stereo.pixel_sigma_px, tracker_.tracks(), t_s);
  tracker_.update(t_s, measurements);
  tracker_.updateFromViews(t_s, one_view, lv, rv);
  const int64_t target_id = chooseTarget(t_s, &out->target_reason_changed);
  learnColour(t_s, target_id, measurements, objects, lr, rr);
  recent_views_.push_back({m.seq, {lv, rv}});
  if (recent_views_.size() > kViewsKept) recent_views_.pop_front();
  processing_ms_.push_back(
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  makeMessages(m, t_s, target_id, lr, rr, objects, yaws, markers, people, clicked, lv, out);
  setCounters(target_id, out->pose.target_index);
  return true;
}

bool DetectPipeline::discover(const ptzstereo::stereo_frame_t& m, bool repeatable,
                              std::string* why) {
  ColourBand band = std::move(pending_band_);
  pending_band_ = {};
  if (!config_.new_objects_after_publish ||
      (band.rows.empty() && config_.markers.empty() && config_.people.empty())) {
    return true;
  }
  // Without a target no pose waits, and finding one is all that matters: the search runs in the
  // frame's turn, at the frames' priority, as in a run to be repeated.
  const bool wait = repeatable || selector_.targetId() < 0;
  // A search that ended meanwhile first (off the frame's latency: its messages are out); one that
  // still runs, when this frame's must not be skipped.
  std::string earlier;
  if (!absorbNewObjects(wait, &earlier)) *why = earlier;
  const bool has_band = !band.rows.empty();
  if (!new_objects_->start(m, frameView(rig_, Side::kLeft, m.left),
                           frameView(rig_, Side::kRight, m.right), tracker_.tracks(),
                           std::move(band), wait)) {
    ++counters_["new_object_searches_skipped"];  // the last frame's still runs
    // Its band is the next windowed frame's again: skips must not leave rows unsearched.
    if (has_band) windows_.retryBand();
    return earlier.empty();
  }
  if (wait) return absorbNewObjects(true, why) && earlier.empty();
  return earlier.empty();
}

bool DetectPipeline::absorbNewObjects(bool wait, std::string* why) {
  std::optional<NewObjectsFound> found = new_objects_->collect(wait);
  if (!found) return true;
  if (!found->ok) {
    ++counters_["discoveries_failed"];
    *why = "frame " + std::to_string(found->seq) + ": " + found->why;
    setTrackAndScanCounters();
    return false;
  }
  const int64_t dropped = tracker_.lateDropped();
  tracker_.updateLate(found->t_s, found->found);
  discovery_ms_.push_back(found->ms);
  setTrackAndScanCounters();
  if (tracker_.lateDropped() > dropped) {
    // Ended too long after its frame (a loaded machine): what it found is of no use. Said, so that
    // a search that never keeps up is not mistaken for an empty scene.
    ++counters_["new_objects_too_late"];
    *why = "frame " + std::to_string(found->seq) + ": it ended more than track_late_max_age_s " +
           "after its frame; its " + std::to_string(found->found.size()) + " finds were dropped";
    return false;
  }
  if (discovery_ms_.size() >= 30) {
    counters_["discovery_us_p50"] = static_cast<int64_t>(percentile(discovery_ms_, 50) * 1000);
    counters_["discovery_us_p99"] = static_cast<int64_t>(percentile(discovery_ms_, 99) * 1000);
    discovery_ms_.clear();
  }
  return true;
}

void DetectPipeline::makeMessages(const ptzstereo::stereo_frame_t& m, double t_s, int64_t target_id,
                                  const std::vector<Region>& lr, const std::vector<Region>& rr,
                                  const std::vector<StereoObject>& objects,
                                  const std::vector<BoxYaw>& yaws, const MarkerScan& markers,
                                  const std::vector<PatchObject>& people,
                                  const std::optional<PatchObject>& clicked, const CameraView& lv,
                                  FrameOutputs* out) const {
  ptzstereo::object_detections_t& det = out->detections;
  det = {};
  det.utime = m.utime;
  det.frame_seq = m.seq;
  for (const auto& r : lr) det.left.push_back(toMessage(r, detector_.params()));
  for (const auto& r : rr) det.right.push_back(toMessage(r, detector_.params()));

  ptzstereo::object_pose_t& pose = out->pose;
  pose = {};
  pose.utime = m.utime;
  pose.frame_seq = m.seq;
  pose.target_index = -1;
  pose.left_ptz = {m.left.pan_rad, m.left.tilt_rad, m.left.zoom};
  pose.right_ptz = {m.right.pan_rad, m.right.tilt_rad, m.right.zoom};
  for (size_t i = 0; i < objects.size(); ++i) {
    const StereoObject& o = objects[i];
    det.left[static_cast<size_t>(o.left)].match_index = o.right;
    det.right[static_cast<size_t>(o.right)].match_index = o.left;
    pose.objects.push_back(
        toMessage(o, class_names_[static_cast<size_t>(o.class_index)],
                  objectRadiusM(lr[static_cast<size_t>(o.left)], o.position_head_m, lv), yaws[i]));
  }
  // Tagged objects after the colour ones (their object_index in the tracker says so); a tag's
  // detection is matched to the other view's of the same id.
  const size_t first_left = det.left.size(), first_right = det.right.size();
  for (int s = 0; s < 2; ++s) {
    auto& list = s == 0 ? det.left : det.right;
    for (const MarkerSighting& t : markers.sightings[s]) {
      list.push_back(
          toMessage(t, markers_.classes()[static_cast<size_t>(t.class_index)].objectName(t.id)));
    }
  }
  // Matched where the tag is once in each view (twice in one: which is which cannot be told).
  const auto count = [](const std::vector<MarkerSighting>& v, const MarkerSighting& t) {
    return std::count_if(v.begin(), v.end(), [&](const MarkerSighting& o) {
      return o.class_index == t.class_index && o.id == t.id;
    });
  };
  for (size_t i = 0; i < markers.sightings[0].size(); ++i) {
    for (size_t j = 0; j < markers.sightings[1].size(); ++j) {
      const MarkerSighting &a = markers.sightings[0][i], &b = markers.sightings[1][j];
      if (a.class_index == b.class_index && a.id == b.id && count(markers.sightings[0], a) == 1 &&
          count(markers.sightings[1], b) == 1) {
        det.left[first_left + i].match_index = static_cast<int32_t>(first_right + j);
        det.right[first_right + j].match_index = static_cast<int32_t>(first_left + i);
      }
    }
  }
  // Faces, people and the clicked object: each one's box or patch in each view, matched, after
  // the tags.
  std::vector<const PatchObject*> patches;
  for (const auto& o : people) patches.push_back(&o);
  if (clicked) patches.push_back(&*clicked);
  std::vector<std::pair<int, int>> patch_indices;
  for (const PatchObject* o : patches) {
    const int l = static_cast<int>(det.left.size()), r = static_cast<int>(det.right.size());
    det.left.push_back(toMessage(*o, 0));
    det.right.push_back(toMessage(*o, 1));
    det.left.back().match_index = r;
    det.right.back().match_index = l;
    patch_indices.emplace_back(l, r);
  }
  det.num_left = static_cast<int32_t>(det.left.size());
  det.num_right = static_cast<int32_t>(det.right.size());
  for (const MarkerObject& o : markers.objects) {
    const int l = o.sightings[0].empty() ? -1 : static_cast<int>(first_left) + o.sightings[0][0];
    const int r = o.sightings[1].empty() ? -1 : static_cast<int>(first_right) + o.sightings[1][0];
    pose.objects.push_back(toMessage(o, l, r));
  }
  for (size_t i = 0; i < patches.size(); ++i) {
    pose.objects.push_back(toMessage(*patches[i], patch_indices[i].first, patch_indices[i].second));
  }
  // The target's object: the measurement that updated the locked track in this frame; or, when
  // one view alone did, the track as it now is (the other view's index -1).
  if (const Track* target = tracker_.find(target_id)) {
    pose.target_index = target->object_index;
    if (target->object_index < 0 && target->view_region_index >= 0) {
      pose.objects.push_back(viewObject(*target));
      pose.target_index = static_cast<int32_t>(pose.objects.size()) - 1;
    }
  }
  pose.num_objects = static_cast<int32_t>(pose.objects.size());

  ptzstereo::object_tracks_t& tracks = out->tracks;
  tracks = {};
  tracks.utime = m.utime;
  tracks.frame_seq = m.seq;
  tracks.left_ptz = pose.left_ptz;
  tracks.right_ptz = pose.right_ptz;
  tracks.target_id = target_id;
  tracks.target_reason = selector_.reason();
  for (const auto& t : tracker_.tracks()) {
    tracks.tracks.push_back(toMessage(t, t_s, tracker_.params()));
  }
  tracks.num_tracks = static_cast<int32_t>(tracks.tracks.size());
}

void DetectPipeline::setTrackAndScanCounters() {
  counters_["tracks_live"] = static_cast<int64_t>(tracker_.tracks().size());
  counters_["tracks_started"] = tracker_.tracksStarted();
  counters_["tracks_recovered"] = tracker_.recoveries();
  counters_["track_view_updates"] = tracker_.viewUpdates();
  counters_["track_yaws_accepted"] = tracker_.yawsAccepted();
  counters_["track_yaws_refused"] = tracker_.yawsRefused();
  counters_["tracks_refused"] = tracker_.tracksRefused();
  counters_["track_rotations_accepted"] = tracker_.rotationsAccepted();
  counters_["track_rotations_refused"] = tracker_.rotationsRefused();
  counters_["late_known"] = tracker_.lateKnown();
  counters_["late_updates"] = tracker_.lateUpdates();
  counters_["late_starts"] = tracker_.lateStarts();
  counters_["late_dropped"] = tracker_.lateDropped();
  for (const auto& [reason, n] : tracker_.untrustedCounts()) counters_["untrusted_" + reason] = n;
  // The windows' scanners and the search for new objects count alike: their sums.
  using Counts = std::map<std::string, int64_t>;
  Counts sums;
  for (const Counts* counts :
       {&windows_.counts(), &markers_.counts(), &people_.counts(),
        static_cast<const Counts*>(&scan_errors_), &new_objects_->counts()}) {
    for (const auto& [name, n] : *counts) sums[name] += n;
  }
  for (const auto& [name, n] : sums) counters_[name] = n;
}

void DetectPipeline::learnColour(double t_s, int64_t target_id,
                                 const std::vector<TrackMeasurement>& measurements,
                                 const std::vector<StereoObject>& objects,
                                 const std::vector<Region>& lr, const std::vector<Region>& rr) {
  const ColorAdaptParams& adapt = config_.detector.adapt;
  // Another target is another object: what was learned of the last one is not its colour.
  if (target_id != colour_target_id_) {
    for (ColorModel& model : color_models_) model.reset();
    colour_target_id_ = target_id;
  }
  const Track* target = tracker_.find(target_id);
  if (target != nullptr && target->object_index >= 0 &&
      static_cast<size_t>(target->object_index) < objects.size()) {
    const StereoObject& o = objects[static_cast<size_t>(target->object_index)];
    // Only a trusted centre's regions: one touching the border or another object may hold
    // pixels of something else.
    bool trusted = false;
    for (const TrackMeasurement& tm : measurements) {
      if (tm.object_index == target->object_index) trusted = tm.untrusted.empty();
    }
    const auto k = static_cast<size_t>(o.class_index);
    if (trusted && k < color_models_.size()) {
      // Both views' whole regions as one measurement a frame (a split disc or a region cut by
      // its window is not measured).
      color_models_[k].learn(mergeColours(lr[static_cast<size_t>(o.left)].colour,
                                          rr[static_cast<size_t>(o.right)].colour),
                             t_s, adapt);
    }
  }
  // Every class's model as it now stands; the warning lasts while its model is recent.
  appearance_warning_.clear();
  for (size_t k = 0; k < color_models_.size(); ++k) {
    const ColorModel& model = color_models_[k];
    const ColorClass& c = config_.detector.classes[k];
    const HueGate gate = model.gate(t_s, adapt);
    counters_["color_" + c.name + "_hue_offset_cdeg"] = std::lround(model.hueOffsetDeg() * 100);
    counters_["color_" + c.name + "_gate_halfwidth_cdeg"] =
        gate.active ? std::lround(std::min(gate.halfwidth_deg, 180.0) * 100) : 0;
    if (!model.recent(t_s, adapt)) continue;
    const std::string out = model.outOfRange(c, adapt);
    if (!out.empty() && appearance_warning_.empty())
      appearance_warning_ = "class " + c.name + ": " + out;
  }
  if (!appearance_warning_.empty()) ++counters_["appearance_out_of_range_frames"];
}

void DetectPipeline::setCounters(int64_t target_id, int64_t target_index) {
  setTrackAndScanCounters();
  counters_["target_id"] = target_id;
  ++counters_["frames_processed"];
  if (target_index < 0) ++counters_["frames_without_target"];
  if (processing_ms_.size() >= 30) {
    counters_["processing_us_p50"] = static_cast<int64_t>(percentile(processing_ms_, 50) * 1000);
    counters_["processing_us_p99"] = static_cast<int64_t>(percentile(processing_ms_, 99) * 1000);
    processing_ms_.clear();
  }
  if (orientation_us_.size() >= 30) {
    counters_["orientation_us_p50"] = static_cast<int64_t>(percentile(orientation_us_, 50));
    counters_["orientation_us_p99"] = static_cast<int64_t>(percentile(orientation_us_, 99));
    orientation_us_.clear();
  }
}

// A cut, merged or half-hidden region gives no yaw; nor does a region an image border cuts, or a
// view that does not decode.
std::vector<BoxYaw> DetectPipeline::estimateYaws(const ptzstereo::stereo_frame_t& m,
                                                 const std::array<const FramePixels*, 2>& pixels,
                                                 const std::vector<StereoObject>& objects,
                                                 const std::vector<TrackMeasurement>& measurements,
                                                 const std::vector<Region>& lr,
                                                 const std::vector<Region>& rr,
                                                 const CameraView& lv, const CameraView& rv) {
  std::vector<BoxYaw> yaws(objects.size());
  if (!config_.orientation) return yaws;
  std::vector<bool> trusted(objects.size());
  for (const TrackMeasurement& tm : measurements) {
    if (tm.object_index >= 0 && static_cast<size_t>(tm.object_index) < objects.size()) {
      trusted[static_cast<size_t>(tm.object_index)] = tm.untrusted.empty();
    }
  }
  std::vector<std::pair<double, size_t>> boxes;  // distance from the image centre, index
  for (size_t i = 0; i < objects.size(); ++i) {
    const size_t ci = static_cast<size_t>(objects[i].class_index);
    if (!trusted[i] || !classHasOrientation(detector_.params().classes[ci])) continue;
    const cv::Point2d c = lr[static_cast<size_t>(objects[i].left)].centroid_px;
    boxes.emplace_back(std::hypot(c.x - m.left.width / 2.0, c.y - m.left.height / 2.0), i);
  }
  std::sort(boxes.begin(), boxes.end());
  const size_t most = static_cast<size_t>(config_.orientation_max_per_frame);
  if (boxes.size() > most) {
    counters_["orientations_skipped"] += static_cast<int64_t>(boxes.size() - most);
    boxes.resize(most);
  }
  for (const auto& [distance_px, i] : boxes) {
    const StereoObject& o = objects[i];
    const size_t ci = static_cast<size_t>(o.class_index);
    const Region& l = lr[static_cast<size_t>(o.left)];
    const Region& r = rr[static_cast<size_t>(o.right)];
    const cv::Size lsize(m.left.width, m.left.height), rsize(m.right.width, m.right.height);
    const auto t0 = std::chrono::steady_clock::now();
    cv::Mat lcrop, rcrop;
    std::string why;
    // Enough margin that the crop's pixels are the full scan's (the detector's filters).
    const int margin_px = std::max(config_.orientation_margin_px, detector_.exactMarginPx());
    const cv::Rect lc = boxCrop(l.bbox, lsize, margin_px);
    const cv::Rect rc = boxCrop(r.bbox, rsize, margin_px);
    bool lreused = false, rreused = false;
    if (regionCut(l.bbox, lsize) || regionCut(r.bbox, rsize) ||
        !pixels[0]->crop(lc, &lcrop, &lreused, &why) ||
        !pixels[1]->crop(rc, &rcrop, &rreused, &why)) {
      ++counters_["orientations_failed"];
      continue;
    }
    counters_["orientation_views_decoded"] += (lreused ? 0 : 1) + (rreused ? 0 : 1);
    yaws[i] = estimateBoxYaw(makeBoxView(detector_, ci, lcrop, lc.tl(), l.bbox, lv),
                             makeBoxView(detector_, ci, rcrop, rc.tl(), r.bbox, rv),
                             o.position_head_m, config_.orientation_params);
    orientation_us_.push_back(
        std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
    ++counters_[yaws[i].ok ? "orientations_estimated" : "orientations_failed"];
  }
  return yaws;
}

std::optional<PatchObject> DetectPipeline::clickedObject(int64_t seq, double t_s,
                                                         const CropPixels crops[2],
                                                         const CameraView& lv, const CameraView& rv,
                                                         FrameOutputs* out) {
  std::string why;
  if (pending_click_) {
    const auto [side, direction] = *pending_click_;
    pending_click_.reset();
    // Where the click's direction is now: the heads turn about their pivots, so a far point of it.
    const CameraView& view = side == Side::kLeft ? lv : rv;
    const Eigen::Vector2d pixel = view.project(view.position_head_m + 100 * direction);
    PatchObject first;
    if (!clicked_.start(side, pixel, crops, lv, rv, &first, &why)) {
      ++counters_["click_models_refused"];
      out->click_note =
          "frame " + std::to_string(seq) + ": no model of what is under the point: " + why;
      return std::nullopt;
    }
    ++counters_["click_models_started"];
    clicked_seen_s_ = t_s;
    // The new object is the target from now on (the old clicked one's track gone with it).
    tracker_.eraseClass(ClickedTracker::kClassName);
    selector_.release("a click: waiting for its object's confirmed track");
    TargetRequest clicked_class;
    clicked_class.class_name = ClickedTracker::kClassName;
    std::string unused;
    selector_.request(clicked_class, tracker_.tracks(), lv, rv, &unused);
    out->click_note = "frame " + std::to_string(seq) + ": a model of what is under the point, at " +
                      std::to_string((first.position_m - lv.position_head_m).norm()) + " m";
    return first;
  }
  if (!clicked_.active()) return std::nullopt;
  const Track* track = nullptr;
  for (const Track& t : tracker_.tracks()) {
    if (t.class_name == ClickedTracker::kClassName) track = &t;
  }
  std::optional<PatchObject> found = clicked_.find(track, t_s, crops, lv, rv, &why);
  if (found) {
    clicked_seen_s_ = t_s;
    return found;
  }
  ++counters_["click_misses"];
  // Unseen as long as a track coasts: gone; its model with it.
  if (t_s - clicked_seen_s_ > tracker_.params().coast_s) {
    clicked_.stop();
    ++counters_["click_models_lost"];
    out->click_note = "the clicked object is lost (" + why + "); its model dropped";
  }
  return std::nullopt;
}

int64_t DetectPipeline::chooseTarget(double t_s, bool* reason_changed) {
  const int64_t before = selector_.targetId();
  const std::string reason_before = selector_.reason();
  const int64_t id = selector_.choose(t_s, tracker_.tracks());
  if (id != before) ++counters_["target_changes"];
  *reason_changed = selector_.reason() != reason_before;
  return id;
}

bool DetectPipeline::select(const ptzstereo::target_select_t& m, std::string* why) {
  TargetRequest r;
  switch (m.mode) {
    case ptzstereo::target_select_t::MODE_CLASS:
      r.mode = TargetRequest::Mode::kClass;
      r.class_name = m.class_name;
      break;
    case ptzstereo::target_select_t::MODE_TRACK_ID:
      r.mode = TargetRequest::Mode::kTrackId;
      r.track_id = m.track_id;
      break;
    case ptzstereo::target_select_t::MODE_IMAGE_POINT:
      if (m.camera != ptzstereo::target_select_t::CAMERA_LEFT &&
          m.camera != ptzstereo::target_select_t::CAMERA_RIGHT) {
        *why = "camera " + std::to_string(m.camera) + " is neither 0 nor 1";
        return false;
      }
      if (recent_views_.empty()) {
        *why = "no frame seen yet";
        return false;
      }
      r.mode = TargetRequest::Mode::kImagePoint;
      r.camera = m.camera == ptzstereo::target_select_t::CAMERA_LEFT ? Side::kLeft : Side::kRight;
      r.pixel = {m.x_px, m.y_px};
      if (config_.click_to_track) {
        std::string on_track;
        const auto& newest = recent_views_.back().second;
        if (selector_.request(r, tracker_.tracks(), newest.first, newest.second, &on_track)) {
          settleClick();
          return true;
        }
        // On no track: what is under the point in the frame it was made on becomes the target,
        // once the next frame has shown it (the target stays until then, and if it cannot be).
        const auto held = std::find_if(recent_views_.rbegin(), recent_views_.rend(),
                                       [&](const auto& v) { return v.first == m.frame_seq; });
        if (m.frame_seq >= 0 && held == recent_views_.rend()) {
          *why = "frame " + std::to_string(m.frame_seq) +
                 (m.frame_seq > recent_views_.back().first
                      ? " is not processed yet"
                      : " is not one of the last " + std::to_string(kViewsKept) + " processed");
          return false;
        }
        const auto& views = m.frame_seq >= 0 ? held->second : recent_views_.back().second;
        const CameraView& view = r.camera == Side::kLeft ? views.first : views.second;
        if (!r.pixel.allFinite() || r.pixel.x() < 0 || r.pixel.y() < 0 ||
            r.pixel.x() > view.width - 1 || r.pixel.y() > view.height - 1) {
          *why = on_track;
          return false;
        }
        pending_click_ = {r.camera, pixelRay(view, r.pixel)};
        return true;
      }
      break;
    default:
      *why = "mode " + std::to_string(m.mode) + " is none of 0, 1, 2";
      return false;
  }
  const CameraView none;
  const bool seen = !recent_views_.empty();
  if (!selector_.request(r, tracker_.tracks(), seen ? recent_views_.back().second.first : none,
                         seen ? recent_views_.back().second.second : none, why)) {
    return false;
  }
  settleClick();
  return true;
}

void DetectPipeline::settleClick() {
  pending_click_.reset();
  if (selector_.targetClass() != ClickedTracker::kClassName) clicked_.stop();
}

}  // namespace ptz::perception
