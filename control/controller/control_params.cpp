#include "control/controller/control_params.hpp"

#include <algorithm>

#include "common/freshness.hpp"
#include "common/plant.hpp"
#include "common/rig.hpp"

namespace ptz::control {

void declareControlParams(Params& p) {
  addFreshnessParams(p, "tracks", 500.0, "an OBJECT_TRACKS");
  addPlantParams(p);  // the limits; the motor model itself is the plant's business
  const ControllerParams d;
  declareRigParams(p);
  p.add("mode", "track",
        "track (default: zero steady-state error, feed-forward), paper, or smith (long delays)");
  p.add("paper_gain", d.paper_gain, "", "P gain of the paper mode", Range::above(0));
  p.add("zoom_mode", "size", "size (keep target_radius_vga_px) or hold");
  p.add(
      "target_radius_vga_px", d.target_radius_vga_px, "px",
      "reference apparent radius of the target in VGA-equivalent px (scaled with the image width)",
      Range::above(0));
  p.add("max_zoom", d.max_zoom, "ratio", "highest zoom the controller asks for", Range::above(0));
  p.add("lead_s", d.lead_s, "s",
        "track: feed-forward horizon, the motor's time constant T plus the capture -> command "
        "delay (lockstep: ~0 + half a frame; on a real rig: T + delay_us_p50 of the status)",
        Range::atLeast(0));
  p.add("rate_filter_s", d.rate_filter_s, "s", "time constant of the angular rate estimate",
        Range::above(0));
  p.add("max_setpoint_rate", d.max_setpoint_rate, "rad/s", "setpoint slew limit (zoom: ratio/s)",
        Range::above(0));
  p.add("lost_hold_s", d.lost_hold_s, "s",
        "hold the last setpoint this long without a target before searching (or going home)",
        Range::atLeast(0));
  p.add("lost_mode", d.lost_mode.c_str(), "search (scan the search region) or home (return home)");
  p.add("coast_s", d.coast_s, "s",
        "follow a hidden target's predicted path this long before searching", Range::atLeast(0));
  p.add("limit_wait_s", d.limit_wait_s, "s",
        "wait this long at an axis limit for a target lost beyond it", Range::atLeast(0));
  const SearchParams sd;
  p.add("search_pan_min_rad", sd.pan_min_rad, "rad", "search region: lowest pan (within pan_min)",
        Range::between(-6.3, 6.3));
  p.add("search_pan_max_rad", sd.pan_max_rad, "rad", "search region: highest pan (within pan_max)",
        Range::between(-6.3, 6.3));
  p.addOrder("search_pan_min_rad", "search_pan_max_rad");
  p.add("search_tilt_min_rad", sd.tilt_min_rad, "rad",
        "search region: lowest tilt (within tilt_min)", Range::between(-6.3, 6.3));
  p.add("search_tilt_max_rad", sd.tilt_max_rad, "rad",
        "search region: highest tilt (within tilt_max)", Range::between(-6.3, 6.3));
  p.addOrder("search_tilt_min_rad", "search_tilt_max_rad");
  p.add("search_overlap", sd.overlap, "", "search: share of the field of view rows overlap by",
        Range::between(0, 0.9));
  p.add("search_range_m", sd.range_m, "m", "search: distance the cameras converge at",
        Range::above(0));
  p.add("search_dwell_s", sd.dwell_s, "s", "search: time spent looking at the last seen direction",
        Range::atLeast(0));
  p.add("search_rate_rad_s", sd.rate_rad_s, "rad/s",
        "search: sweep speed (at most max_setpoint_rate)", Range::above(0));
  p.add("search_zoom_step", sd.zoom_step, "ratio",
        "search: each zoomed level's zoom is this times the last's, from the widest (at most 8 "
        "levels)",
        Range::between(1.2, 100));
  p.add("search_max_zoom", sd.max_zoom, "ratio",
        "search: the highest zoom it looks with (at most max_zoom and the lens's; the widest: no "
        "zoomed levels)",
        Range::above(0));
  p.add("search_view_dwell_s", sd.view_dwell_s, "s",
        "search: time a zoomed view is looked at once the setpoint is there", Range::atLeast(0));
  p.add("search_min_diameter_px", 5.0, "px",
        "search: the smallest blob ptz-detect finds, across (for the report of the smallest "
        "angular size the search can find: 2 sqrt(min_area_px2 / pi))",
        Range::above(0));
  p.add("home_rate", d.home_rate, "rad/s", "speed of the return home after that (zoom: ratio/s)",
        Range::above(0));
  p.add("min_range_m", d.min_range_m, "m", "nearer targets are implausible and ignored",
        Range::above(0));
  p.add("max_range_m", d.max_range_m, "m", "farther targets are implausible and ignored",
        Range::above(0));
  p.addOrder("min_range_m", "max_range_m");
  p.add("smith_filter_s", d.smith_filter_s, "s",
        "smith: time constant of the filter on the model error seen at capture", Range::atLeast(0));
  p.add("smith_extra_delay_s", d.smith_extra_delay_s, "s",
        "smith: delay from capture to the command (delay_us_p50 of the status) added to "
        "dead_time_s",
        Range::atLeast(0));
  p.add("kf_model", d.kf_model.c_str(),
        "smith: the target filter, ct (coordinated turn: predicts along curves) or cv (constant "
        "velocity)");
  p.add("kf_accel_psd_m2_s3", d.kalman.accel_psd_m2_s3, "m^2/s^3",
        "smith: spectral density of the target's acceleration (Kalman process noise; ct: of its "
        "changes of speed and turn beyond the model)",
        Range::above(0));
  p.add("kf_turn_psd_rad2_s3", d.turn_kalman.turn_psd_rad2_s3, "rad^2/s^3",
        "smith, ct: spectral density of the change of the target's turn rate", Range::above(0));
  p.add("kf_position_sigma_m", d.kf_position_sigma_m, "m",
        "smith: position noise of a pose that carries no covariance", Range::above(0));
  p.add("kf_gate_chi2", d.kalman.gate_chi2, "",
        "smith: poses farther from the prediction (Mahalanobis^2) are outliers", Range::above(0));
  p.add("min_phase_margin_deg", 30.0, "deg",
        "warn when the measured delay leaves the paper's loop less phase margin",
        Range::between(0, 180));
}

ControllerParams controllerParamsFrom(const Params& p) {
  ControllerParams c;
  c.mode = p.getString("mode");
  c.paper_gain = p.getDouble("paper_gain");
  c.zoom_mode = p.getString("zoom_mode");
  c.target_radius_vga_px = p.getDouble("target_radius_vga_px");
  c.max_zoom = p.getDouble("max_zoom");
  c.lead_s = p.getDouble("lead_s");
  c.rate_filter_s = p.getDouble("rate_filter_s");
  c.max_setpoint_rate = p.getDouble("max_setpoint_rate");
  c.lost_hold_s = p.getDouble("lost_hold_s");
  c.lost_mode = p.getString("lost_mode");
  c.coast_s = p.getDouble("coast_s");
  c.limit_wait_s = p.getDouble("limit_wait_s");
  c.home_rate = p.getDouble("home_rate");
  c.min_range_m = p.getDouble("min_range_m");
  c.max_range_m = p.getDouble("max_range_m");
  c.limits = plantParamsFrom(p);
  // The search region within the axis limits.
  const AxisParams& pan = c.limits.axis[0];
  const AxisParams& tilt = c.limits.axis[1];
  c.search.pan_min_rad = std::max(p.getDouble("search_pan_min_rad"), pan.min_position);
  c.search.pan_max_rad = std::min(p.getDouble("search_pan_max_rad"), pan.max_position);
  c.search.tilt_min_rad = std::max(p.getDouble("search_tilt_min_rad"), tilt.min_position);
  c.search.tilt_max_rad = std::min(p.getDouble("search_tilt_max_rad"), tilt.max_position);
  if (c.search.pan_min_rad > c.search.pan_max_rad ||
      c.search.tilt_min_rad > c.search.tilt_max_rad) {
    throw p.invalid("search_pan_min_rad", "the search region lies outside the axis limits");
  }
  c.search.overlap = p.getDouble("search_overlap");
  c.search.range_m = p.getDouble("search_range_m");
  c.search.dwell_s = p.getDouble("search_dwell_s");
  c.search.rate_rad_s = p.getDouble("search_rate_rad_s");
  c.search.zoom_step = p.getDouble("search_zoom_step");
  // Never beyond what the controller asks for when it tracks.
  c.search.max_zoom = std::min(p.getDouble("search_max_zoom"), c.max_zoom);
  c.search.view_dwell_s = p.getDouble("search_view_dwell_s");
  c.smith_filter_s = p.getDouble("smith_filter_s");
  c.smith_extra_delay_s = p.getDouble("smith_extra_delay_s");
  c.kf_model = p.getString("kf_model");
  c.kalman.accel_psd_m2_s3 = p.getDouble("kf_accel_psd_m2_s3");
  c.turn_kalman.accel_psd_m2_s3 = c.kalman.accel_psd_m2_s3;
  c.turn_kalman.turn_psd_rad2_s3 = p.getDouble("kf_turn_psd_rad2_s3");
  c.kf_position_sigma_m = p.getDouble("kf_position_sigma_m");
  c.kalman.gate_chi2 = p.getDouble("kf_gate_chi2");
  c.turn_kalman.gate_chi2 = c.kalman.gate_chi2;
  // The numbers' ranges are their declarations'.
  if (c.mode != "track" && c.mode != "paper" && c.mode != "smith") {
    throw p.invalid("mode", "must be track, paper or smith");
  }
  if (c.kf_model != "ct" && c.kf_model != "cv") throw p.invalid("kf_model", "must be ct or cv");
  if (c.zoom_mode != "size" && c.zoom_mode != "hold") {
    throw p.invalid("zoom_mode", "must be size or hold");
  }
  if (c.lost_mode != "search" && c.lost_mode != "home") {
    throw p.invalid("lost_mode", "must be search or home");
  }
  return c;
}

DelayMonitor delayMonitorFrom(const Params& p) {
  // The paper's loop model of the pan axis: P gain times motor gain, the motor's T.
  const LoopParams pan_loop{p.getDouble("paper_gain") * p.getDouble("pan_gain"),
                            p.getDouble("pan_time_constant_s"), 0.0};
  // Smith mode: the delay its model assumes, checked against the measured one.
  const double smith_delay_s = p.getString("mode") == "smith"
                                   ? p.getDouble("dead_time_s") + p.getDouble("smith_extra_delay_s")
                                   : -1;
  return DelayMonitor(pan_loop, p.getDouble("dead_time_s"), p.getDouble("min_phase_margin_deg"),
                      smith_delay_s);
}

}  // namespace ptz::control
