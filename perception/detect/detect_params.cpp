#include "perception/detect/detect_params.hpp"

#include <algorithm>

#include "common/freshness.hpp"

namespace ptz::perception {

void declareDetectParams(Params& p) {
  p.add("target_class", "red_ball",
        "class of the object of interest until TARGET_SELECT says otherwise");
  p.add("filter_size_px", 3, "px", "median filter size (odd)", Range::between(1, 99));
  p.add("morph_size_px", 3, "px", "opening/closing kernel size", Range::between(1, 99));
  const ColorAdaptParams a;
  p.add(
      "color_intensity_min_fraction", a.intensity_min_fraction, "",
      "colour classes: a pixel needs only this share of the intensity of the class's bright "
      "pixels (95th percentile in the part scanned) when that is below the class's "
      "intensity_min, so the shaded side of an object in dim light stays (0: intensity_min alone)",
      Range::between(0, 1));
  p.add("color_intensity_floor", a.intensity_floor, "grey levels",
        "colour classes: the relative intensity limit never goes below this (the sensor's noise)",
        Range::between(0, 255));
  p.add("color_follow", a.follow,
        "colour classes: the target's hue is learned from its confirmed regions and the class "
        "narrowed to it (inside its configured window), so clutter of a near hue does not merge "
        "with it");
  p.add("color_follow_sigmas", a.follow_sigmas, "",
        "colour follow: the hue kept, in sigmas of the target's hue spread",
        Range::between(0.1, 20));
  p.add("color_follow_min_halfwidth_deg", a.follow_min_halfwidth_deg, "deg",
        "colour follow: the hue kept is never narrower than this either side",
        Range::between(0, 180));
  p.add("color_follow_noise_grey", a.follow_noise_grey, "grey levels",
        "colour follow: the sensor's noise; the hue kept widens by its hue noise at each pixel's "
        "chroma (the dark side of an object)",
        Range::between(0, 50));
  p.add("color_follow_learning_rate", a.follow_learning_rate, "",
        "colour follow: the share of a confirmed region's hue learned per frame",
        Range::between(0, 1));
  p.add("color_follow_min_updates", a.follow_min_updates, "frames",
        "colour follow: confirmed regions learned before the hue gate applies",
        Range::between(1, 1000));
  p.add("color_follow_forget_s", a.follow_forget_s, "s",
        "colour follow: without a confirmed region this long, the class is its window again",
        Range::above(0));
  p.add("max_epipolar_px", 3.0, "px",
        "largest distance of a left/right match from its epipolar line", Range::above(0));
  p.add("max_area_ratio", 2.0, "", "largest left/right area ratio of a match", Range::atLeast(1));
  p.add("pixel_sigma_px", 0.3, "px", "centroid noise for the pose covariance", Range::above(0));
  p.add("min_range_m", 0.3, "m", "nearest accepted object", Range::above(0));
  p.add("max_range_m", 50.0, "m", "farthest accepted object", Range::above(0));
  p.addOrder("min_range_m", "max_range_m");
  p.add("orientation", true,
        "estimate the yaw of objects whose class is not round (boxes) from both views' outlines");
  p.add("orientation_height_ratio", OrientationParams{}.height_ratio, "",
        "orientation: the boxes' height over their footprint's side (0: fitted)",
        Range::between(0, 100));
  p.add("orientation_margin_px", 8, "px", "orientation: crop around a box's region",
        Range::between(1, 256));
  p.add("orientation_max_per_frame", 4, "",
        "orientation: boxes fitted per frame at most (the nearest the image centres first; the "
        "rest counted orientations_skipped)",
        Range::between(0, 64));
  addFreshnessParams(p, "frame", 500.0, "a STEREO_FRAME");
  addFreshnessParams(p, "select", 2000.0, "a TARGET_SELECT request");
  const TrackerParams t;
  p.add("track_yaw_psd_rad2_s", t.yaw_psd_rad2_s, "rad^2/s",
        "tracks: a box's yaw is a random walk of this power spectral density", Range::above(0));
  p.add("track_yaw_gate_chi2", t.yaw_gate_chi2, "",
        "tracks: a measured yaw beyond this innovation^2 / variance is refused (1 dof)",
        Range::above(0));
  p.add("track_jerk_psd_m2_s5", t.jerk_psd_m2_s5, "m^2/s^5",
        "tracks: spectral density of the objects' jerk (constant-acceleration model)",
        Range::above(0));
  p.add("track_gate_chi2", t.gate_chi2, "",
        "tracks: a measurement farther from a track's prediction (Mahalanobis^2) is not its",
        Range::above(0));
  p.add("track_min_position_sigma_m", t.min_position_sigma_m, "m",
        "tracks: noise added to every triangulated position", Range::atLeast(0));
  p.add("track_confirm_hits", t.confirm_hits, "", "tracks: measurements that confirm a track",
        Range::between(1, 1000));
  p.add("track_tentative_max_gap_s", t.tentative_max_gap_s, "s",
        "tracks: an unconfirmed track unseen this long is deleted", Range::above(0));
  p.add("track_coast_s", t.coast_s, "s",
        "tracks: a confirmed track unseen this long is deleted (it coasts until then)",
        Range::above(0));
  p.add("track_recover_speed_m_s", t.recover_speed_m_s, "m/s",
        "tracks: a measurement outside every gate but within this speed times the time since a "
        "coasting track's last update restarts that track (sharp turns; 0: off)",
        Range::atLeast(0));
  p.add("track_rank_sigma_cap_m", t.rank_sigma_cap_m, "m",
        "tracks: pairs rank by Mahalanobis^2 + ln det S, det S capped at this sigma per axis",
        Range::above(0));
  p.add("track_max_radius_ratio", t.max_radius_ratio, "",
        "tracks: a radius off the track's by more than this factor is not trusted as the centre",
        Range::above(1));
  p.add("track_view_max_depth_age_s", t.view_max_depth_age_s, "s",
        "tracks: a track hidden in one view is moved by the other view's region alone, this soon "
        "after its last 3D measurement (its depth then from the prediction; 0: never)",
        Range::atLeast(0));
  p.add("track_late_max_age_s", t.late_max_age_s, "s",
        "tracks: what the search for new objects found in a frame joins the tracks while no "
        "newer frame is more than this later (a search in the background may end frames later)",
        Range::atLeast(0));
  p.add("trusted_area_ratio", 1.3, "",
        "left/right area ratio (zoom-corrected) beyond which an object is not trusted as a centre",
        Range::above(1));
  p.add("pick_radius_px", 15.0, "px",
        "TARGET_SELECT by image point: the largest distance from a track's image", Range::above(0));
  const WindowParams w;
  p.add("windows", w.enabled,
        "with a confirmed track, scan windows around each track's predicted image (and a band of "
        "the image a frame, or the whole frame every window_full_scan_every frames, for new "
        "objects) instead of whole frames");
  p.add("window_full_scan_every", w.full_scan_every, "frames",
        "windows: every n-th frame is scanned whole, for new objects (1: every frame); with "
        "window_full_scan_in_bands, the image is scanned in this many bands, one a frame",
        Range::between(1, 1000));
  p.add("window_full_scan_in_bands", w.full_scan_in_bands,
        "windows: look for new objects in one band of the image's rows a frame instead of the "
        "whole image every window_full_scan_every frames (no frame costs a whole scan)");
  p.add("window_band_overlap_fraction", w.band_overlap_fraction, "",
        "windows, bands: how far (a fraction of the image's height) each band reaches into its "
        "neighbours: the tallest object sure to be whole in a band, and the largest vertical "
        "disparity at which both images' band holds it",
        Range::between(0, 1));
  p.add("window_margin_px", w.margin_px, "px",
        "windows: added on each side of a track's projected extent", Range::between(0, 4096));
  p.add("window_sigma_scale", w.sigma_scale, "",
        "windows: a track's extent is its radius plus this many sigma of its predicted position",
        Range::between(0, 100));
  p.add("full_scan_max_width_px", w.full_scan_max_width_px, "px",
        "full scans of wider images find their objects on the image reduced by 2, 4 or 8 (to this "
        "width or less), then detect at full resolution only around them (0: off)",
        Range::between(0, 4096));
  const MarkerScanParams m;
  p.add("markers_config", "",
        "a YAML file whose section `markers` lists the fiducial marker classes, instead of the "
        "config file's own (\"\": the config file's; none there: no markers)");
  p.add("marker_bands", m.bands, "",
        "markers: the image is searched for new tags in this many bands of rows, one a frame "
        "(tracked "
        "tags are looked for every frame in windows around their tracks)",
        Range::between(1, 64));
  p.add("marker_band_decimate", m.band_decimate, "",
        "markers: libapriltag finds tags in a band on the image reduced by this (1: full "
        "resolution, slower, finds smaller tags; windows are always at full resolution)",
        Range::between(1, 4));
  p.add("marker_window_max_object_areas", m.window_max_object_areas, "",
        "markers: a tagged track's window larger than this many times its object's own image "
        "(a track lost a while, its window grown with its uncertainty) is searched with the band "
        "for new tags, after the frame's messages, instead of before them",
        Range::atLeast(1));
  p.add("marker_corner_sigma_px", m.pose.corner_sigma_px, "px",
        "markers: a tag corner's noise, the floor of the pose's covariance", Range::above(0));
  p.add("marker_max_rms_px", m.pose.max_rms_px, "px",
        "markers: a tagged object's pose whose reprojection RMS over both views exceeds this is "
        "refused (tags that do not belong together)",
        Range::above(0));
  p.add("marker_max_corner_px", m.pose.max_corner_px, "px",
        "markers: a pose with a tag corner this far off its fit in either view is refused (a tag "
        "partly hidden: its corner found on the edge of what hides it)",
        Range::above(0));
  p.add("marker_max_hamming", m.detector.max_hamming, "bits",
        "markers: tags read with more bits corrected than this are refused (false tags grow with "
        "it)",
        Range::between(0, 2));
  p.add(
      "track_rotation_accel_psd_rad2_s3", TrackerParams{}.rotation.accel_psd_rad2_s3, "rad^2/s^3",
      "tracks: a tagged object turns at an angular velocity whose changes are white noise of this "
      "power spectral density per axis",
      Range::above(0));
  p.add("new_objects_after_publish", true,
        "the search for new objects (the colours' band, the tags' band and lost tags' windows, the "
        "people's strip) runs once the frame's messages are out (the frame's pose waits for the "
        "tracked objects' windows alone; a new one is in the messages from the next frame on); "
        "false: before them, in the frame");
  p.add("new_objects_background", true,
        "with a target, that search runs on a thread of its own beside the next frames, which do "
        "not wait for it (a frame that comes while it runs is not searched); without one, and for "
        "frames whose capture times are not the wall clock's (a lockstep simulator, a log replayed "
        "an hour or more later), it runs in the frame's turn, so such a run gives the same tracks "
        "every time; false: always in the frame's turn");
  p.add("new_objects_nice_increment", 10, "",
        "that thread's nice value above ptz-detect's, so the next frames and the loop's other "
        "processes run first (a SCHED_FIFO or RR ptz-detect's is SCHED_OTHER instead, below them "
        "already)",
        Range::between(0, 19));
  const ClickedParams k;
  p.add("click_to_track", true,
        "TARGET_SELECT by an image point on no track starts a model of what is under it (its "
        "appearance, matched in the other view along the epipolar line) and follows it as class "
        "clicked");
  p.add("click_patch_px", k.patch_px, "px", "click to track: the patch's side around the click",
        Range::between(8, 256));
  p.add("click_min_score", k.min_score, "",
        "click to track: a frame's match in each view needs this normalised correlation",
        Range::between(0, 1));
  const PeopleScanParams pp;
  p.add("people_config", "",
        "a YAML file whose section `people` lists the face and person classes, instead of the "
        "config file's own (\"\": the config file's; none there: none)");
  p.add("people_strips", pp.strips, "",
        "faces and people: the left image is searched for new ones in this many vertical strips, "
        "one a frame (tracked ones every frame in windows around their tracks)",
        Range::between(1, 64));
  p.add("people_min_score", pp.min_score, "",
        "faces and people: a detection's inner patch must match the right view along its "
        "epipolar line with this normalised correlation",
        Range::between(0, 1));
  p.add("people_size_tolerance", pp.size_tolerance, "",
        "faces and people: a detection whose box is further than this share from the class's "
        "height_m at its range is refused (a picture of a face, a false hit on the backdrop)",
        Range::between(0.05, 2));
  p.addSection("people",
               "list of {name, detector: hog|cascade, cascade: a Debian opencv-data cascade's "
               "name (default haarcascade_frontalface_default) or a YAML file, height_m, "
               "scan_scale, min_neighbors}");
  p.addSection(
      "markers",
      "list of {name, detector: apriltag|aruco, family (apriltag_36h11, aruco_4x4_50, ...), "
      "size_m, and ids: [..] or any (objects <name>#<id>) or tags: [{id, centre_m, yaw_deg, "
      "pitch_deg}] (one object <name>)}");
  p.addSection("classes",
               "list of {name, hue_min_deg, hue_max_deg, saturation_min, saturation_max, "
               "intensity_min, intensity_max, shape: circle|square|any, "
               "max_shape_distance, max_elongation, min_area_px2, max_area_px2}");
}

TrackerParams trackerParams(const Params& p) {
  TrackerParams t;
  t.jerk_psd_m2_s5 = p.getDouble("track_jerk_psd_m2_s5");
  t.gate_chi2 = p.getDouble("track_gate_chi2");
  t.min_position_sigma_m = p.getDouble("track_min_position_sigma_m");
  t.confirm_hits = p.getInt("track_confirm_hits");
  t.tentative_max_gap_s = p.getDouble("track_tentative_max_gap_s");
  t.coast_s = p.getDouble("track_coast_s");
  t.max_radius_ratio = p.getDouble("track_max_radius_ratio");
  t.recover_speed_m_s = p.getDouble("track_recover_speed_m_s");
  t.rank_sigma_cap_m = p.getDouble("track_rank_sigma_cap_m");
  t.view_max_depth_age_s = p.getDouble("track_view_max_depth_age_s");
  t.late_max_age_s = p.getDouble("track_late_max_age_s");
  t.yaw_psd_rad2_s = p.getDouble("track_yaw_psd_rad2_s");
  t.yaw_gate_chi2 = p.getDouble("track_yaw_gate_chi2");
  t.rotation.accel_psd_rad2_s3 = p.getDouble("track_rotation_accel_psd_rad2_s3");
  return t;
}

WindowParams windowParams(const Params& p) {
  WindowParams w;
  w.enabled = p.getBool("windows");
  w.full_scan_every = p.getInt("window_full_scan_every");
  w.full_scan_in_bands = p.getBool("window_full_scan_in_bands");
  w.band_overlap_fraction = p.getDouble("window_band_overlap_fraction");
  w.margin_px = p.getDouble("window_margin_px");
  w.sigma_scale = p.getDouble("window_sigma_scale");
  w.full_scan_max_width_px = p.getInt("full_scan_max_width_px");
  return w;
}

DetectConfig DetectConfig::fromParams(const Params& p) {
  if (p.configPath().empty()) {
    throw ConfigError(
        "--config FILE is required (it holds the colour classes; see "
        "config/detect_default.yaml)");
  }
  DetectConfig c;
  c.detector =
      DetectorParams::fromConfig(p.section("classes"), "config file '" + p.configPath() + "'");
  c.detector.filter_size_px = p.getInt("filter_size_px");
  c.detector.morph_size_px = p.getInt("morph_size_px");
  ColorAdaptParams& a = c.detector.adapt;
  a.intensity_min_fraction = p.getDouble("color_intensity_min_fraction");
  a.intensity_floor = p.getDouble("color_intensity_floor");
  a.follow = p.getBool("color_follow");
  a.follow_sigmas = p.getDouble("color_follow_sigmas");
  a.follow_min_halfwidth_deg = p.getDouble("color_follow_min_halfwidth_deg");
  a.follow_learning_rate = p.getDouble("color_follow_learning_rate");
  a.follow_noise_grey = p.getDouble("color_follow_noise_grey");
  a.follow_min_updates = p.getInt("color_follow_min_updates");
  a.follow_forget_s = p.getDouble("color_follow_forget_s");
  if (c.detector.filter_size_px % 2 == 0) throw p.invalid("filter_size_px", "must be odd");
  const std::string markers_path = p.getString("markers_config");
  if (markers_path.empty()) {
    c.markers =
        markerClassesFromConfig(p.section("markers"), "config file '" + p.configPath() + "'");
  } else {
    const cv::FileStorage fs = openForRead(markers_path, "markers file");
    if (fs["markers"].empty()) {
      throw ConfigError("markers file '" + markers_path + "': no section `markers`");
    }
    c.markers = markerClassesFromConfig(fs["markers"], "markers file '" + markers_path + "'");
  }
  const std::string people_path = p.getString("people_config");
  if (people_path.empty()) {
    c.people = peopleClassesFromConfig(p.section("people"), "config file '" + p.configPath() + "'");
  } else {
    const cv::FileStorage fs = openForRead(people_path, "people file");
    if (fs["people"].empty()) {
      throw ConfigError("people file '" + people_path + "': no section `people`");
    }
    c.people = peopleClassesFromConfig(fs["people"], "people file '" + people_path + "'");
  }
  for (const auto& person : c.people) {
    const bool colour = std::any_of(c.detector.classes.begin(), c.detector.classes.end(),
                                    [&](const auto& k) { return k.name == person.name; });
    const bool marker = std::any_of(c.markers.begin(), c.markers.end(),
                                    [&](const auto& k) { return k.name == person.name; });
    if (colour || marker || person.name == ClickedTracker::kClassName) {
      throw ConfigError("config file '" + p.configPath() + "', people: class '" + person.name +
                        "' is also a colour or marker class, or reserved (clicked)");
    }
  }
  for (const auto& colour : c.detector.classes) {
    if (colour.name == ClickedTracker::kClassName || colour.name.find('#') != std::string::npos) {
      throw ConfigError("config file '" + p.configPath() + "', classes: '" + colour.name +
                        "' is reserved (clicked objects) or has a '#' (a tag's id)");
    }
  }
  for (const auto& m : c.markers) {
    if (m.name == ClickedTracker::kClassName) {
      throw ConfigError("config file '" + p.configPath() + "', markers: '" + m.name +
                        "' is reserved for clicked objects");
    }
    for (const auto& colour : c.detector.classes) {
      if (colour.name == m.name) {
        throw ConfigError("config file '" + p.configPath() + "', markers: class '" + m.name +
                          "' is also a colour class");
      }
    }
  }
  c.target_class = p.getString("target_class");
  const std::vector<std::string> names = markerObjectNames(c.markers);
  const bool person_class = std::any_of(c.people.begin(), c.people.end(),
                                        [&](const auto& k) { return k.name == c.target_class; });
  if (std::find(names.begin(), names.end(), c.target_class) == names.end() &&
      c.target_class != ClickedTracker::kClassName && !person_class) {
    checkTargetClass(p, c.detector);
  }
  c.marker_scan.bands = p.getInt("marker_bands");
  c.marker_scan.band_decimate = p.getDouble("marker_band_decimate");
  c.marker_scan.window_max_object_areas = p.getDouble("marker_window_max_object_areas");
  c.marker_scan.pose.corner_sigma_px = p.getDouble("marker_corner_sigma_px");
  c.marker_scan.pose.max_rms_px = p.getDouble("marker_max_rms_px");
  c.marker_scan.pose.max_corner_px = p.getDouble("marker_max_corner_px");
  c.marker_scan.pose.min_range_m = p.getDouble("min_range_m");
  c.marker_scan.pose.max_range_m = p.getDouble("max_range_m");
  c.marker_scan.detector.max_hamming = p.getInt("marker_max_hamming");
  c.people_scan.strips = p.getInt("people_strips");
  c.people_scan.min_score = p.getDouble("people_min_score");
  c.people_scan.size_tolerance = p.getDouble("people_size_tolerance");
  c.people_scan.min_range_m = p.getDouble("min_range_m");
  c.people_scan.max_range_m = p.getDouble("max_range_m");
  c.click_to_track = p.getBool("click_to_track");
  c.new_objects_after_publish = p.getBool("new_objects_after_publish");
  c.new_objects_background = p.getBool("new_objects_background");
  c.new_objects_nice_increment = p.getInt("new_objects_nice_increment");
  c.clicked.patch_px = p.getInt("click_patch_px");
  c.clicked.min_score = p.getDouble("click_min_score");
  c.clicked.min_range_m = p.getDouble("min_range_m");
  c.clicked.max_range_m = p.getDouble("max_range_m");
  c.stereo.max_epipolar_px = p.getDouble("max_epipolar_px");
  c.stereo.max_area_ratio = p.getDouble("max_area_ratio");
  c.stereo.pixel_sigma_px = p.getDouble("pixel_sigma_px");
  c.stereo.min_range_m = p.getDouble("min_range_m");
  c.stereo.max_range_m = p.getDouble("max_range_m");
  c.tracker = trackerParams(p);
  c.marker_scan.rotation = c.tracker.rotation;
  c.windows = windowParams(p);
  c.pick_radius_px = p.getDouble("pick_radius_px");
  c.trusted_area_ratio = p.getDouble("trusted_area_ratio");
  c.orientation = p.getBool("orientation");
  c.orientation_params.height_ratio = p.getDouble("orientation_height_ratio");
  c.orientation_margin_px = p.getInt("orientation_margin_px");
  c.orientation_max_per_frame = p.getInt("orientation_max_per_frame");
  return c;
}

}  // namespace ptz::perception
