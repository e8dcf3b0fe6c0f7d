#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "common/rig.hpp"
#include "common/transport/transport.hpp"
#include "control/stability/stability.hpp"
#include "ptzstereo/object_detections_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "tools/report/report.hpp"

namespace ptz::tools {
namespace {

template <typename Head>
std::array<double, 6> sixAxes(const Head& l, const Head& r) {
  return {l.pan_rad, l.tilt_rad, l.zoom, r.pan_rad, r.tilt_rad, r.zoom};
}

}  // namespace

ReportData collectReport(LogReader& log, const ReportOptions& o) {
  ReportData d;
  const std::string& px = o.channel_prefix;
  RunMetrics summary_metrics(o.target_class, o.settle_s);
  RunMetrics series_metrics(o.target_class, 0.0);
  std::map<int64_t, int64_t> frame_utime, frame_publish;  // by seq
  std::map<int64_t, std::pair<int, int>> image_size;      // by seq
  std::map<int64_t, ptzstereo::object_detections_t> detections;
  std::vector<ptzstereo::object_pose_t> poses;
  std::vector<ptzstereo::object_tracks_t> tracks;  // without their tracks: the target and count
  std::vector<std::pair<int64_t, ptzstereo::object_track_t>> track_points;  // utime, id, state
  std::vector<ptzstereo::control_state_t> control;
  std::vector<ptzstereo::ptz_setpoint_t> setpoints;
  std::vector<int64_t> frame_periods_us;
  // Log (receive) times, binned once the run's length is known.
  std::map<std::string, std::vector<double>> arrivals;
  std::vector<std::pair<double, int64_t>> missing_at;
  std::map<std::string, std::vector<std::pair<double, int64_t>>> dropped_at;
  int64_t t0 = -1, first_event_us = -1, last_event_us = 0, last_seq = -1, missing = 0;
  const auto setT0 = [&](int64_t utime) {
    if (t0 < 0) t0 = utime;
  };
  while (const lcm::LogEvent* ev = log.next()) {
    // LCM's own check that a UDP multicast provider works: not the run's traffic.
    if (ev->channel == "LCM_SELF_TEST") continue;
    if (first_event_us < 0) first_event_us = ev->timestamp;
    last_event_us = std::max(last_event_us, ev->timestamp);  // a log's times may go back
    const double log_t_s = std::max<int64_t>(0, ev->timestamp - first_event_us) * 1e-6;
    arrivals[ev->channel].push_back(log_t_s);
    ++d.channel_messages[ev->channel];
    const std::string& ch = ev->channel;
    if (ch == px + channels::kStereoFrame) {
      ptzstereo::stereo_frame_t f{};
      if (!decodeEvent(*ev, &f, &d.undecodable)) continue;
      setT0(f.utime);
      if (last_seq >= 0 && f.seq > last_seq + 1) missing += f.seq - last_seq - 1;
      if (!frame_utime.empty()) frame_periods_us.push_back(f.utime - frame_utime.rbegin()->second);
      last_seq = f.seq;
      frame_utime[f.seq] = f.utime;
      frame_publish[f.seq] = f.publish_utime;
      image_size[f.seq] = {f.left.width, f.left.height};
      summary_metrics.onFrame(f);
      series_metrics.onFrame(f);
      missing_at.emplace_back(log_t_s, missing);
    } else if (ch == px + channels::kPtzState) {
      ptzstereo::ptz_state_t s{};
      if (!decodeEvent(*ev, &s, &d.undecodable)) continue;
      setT0(s.utime);
      d.states.push_back({(s.utime - t0) * 1e-6, sixAxes(s.left, s.right)});
    } else if (ch == px + channels::kPtzSetpoint) {
      ptzstereo::ptz_setpoint_t s{};
      if (!decodeEvent(*ev, &s, &d.undecodable)) continue;
      setT0(s.utime);
      setpoints.push_back(s);
      summary_metrics.onSetpoint(s);
    } else if (ch == px + channels::kSimTruth) {
      ptzstereo::sim_truth_t t{};
      if (!decodeEvent(*ev, &t, &d.undecodable)) continue;
      setT0(t.utime);
      frame_utime.emplace(t.frame_seq, t.utime);
      summary_metrics.onTruth(t);
      series_metrics.onTruth(t);
    } else if (ch == px + channels::kObjectPose) {
      ptzstereo::object_pose_t p{};
      if (!decodeEvent(*ev, &p, &d.undecodable)) continue;
      summary_metrics.onPose(p);
      series_metrics.onPose(p);
      poses.push_back(p);
    } else if (ch == px + channels::kObjectTracks) {
      ptzstereo::object_tracks_t m{};
      if (!decodeEvent(*ev, &m, &d.undecodable)) continue;
      for (size_t i = 0; i < m.tracks.size() && i < ReportData::kMaxTracksPlotted; ++i) {
        ptzstereo::object_track_t t{};
        t.id = m.tracks[i].id;
        t.state = m.tracks[i].state;
        track_points.emplace_back(m.utime, t);
      }
      m.tracks.clear();
      tracks.push_back(std::move(m));
    } else if (ch == px + channels::kControlState) {
      ptzstereo::control_state_t m{};
      if (!decodeEvent(*ev, &m, &d.undecodable)) continue;
      summary_metrics.onControlState(m);
      series_metrics.onControlState(m);
      control.push_back(std::move(m));
    } else if (ch == px + channels::kObjectDetections) {
      ptzstereo::object_detections_t m{};
      if (decodeEvent(*ev, &m, &d.undecodable)) detections[m.frame_seq] = m;
    } else if (ch.rfind(px + "PROCESS_STATUS_", 0) == 0) {
      ptzstereo::process_status_t s{};
      if (!decodeEvent(*ev, &s, &d.undecodable)) continue;
      summary_metrics.onStatus(s);
      for (const auto& c : s.counters) {
        // What was lost or not processed: dropped_* counters and frames a process skipped.
        if (c.name.rfind("dropped", 0) == 0 || c.name.rfind("frames_skipped", 0) == 0) {
          dropped_at[s.process + "." + c.name].emplace_back(log_t_s, c.value);
        }
      }
    }
  }
  d.breaks = log.describeBreaks();
  log.requireEvents();
  const std::vector<std::string> timed = {px + channels::kStereoFrame, px + channels::kPtzState,
                                          px + channels::kPtzSetpoint, px + channels::kSimTruth};
  log.requireChannels({}, timed);
  if (t0 < 0) {
    throw LogError(log_exit::kNoChannels, "log '" + log.path() +
                                              "': no message on STEREO_FRAME, PTZ_STATE, "
                                              "PTZ_SETPOINT or SIM_TRUTH decodes");
  }
  d.duration_s = (last_event_us - first_event_us) * 1e-6;
  // Bins of a round width, about 50 over the run.
  for (double w : {0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 30.0, 60.0, 300.0}) {
    d.bin_s = w;
    if (d.duration_s / w <= 60) break;
  }
  const size_t bins = static_cast<size_t>(d.duration_s / d.bin_s) + 1;
  const auto index = [&](double t_s) {
    return std::min(bins - 1, static_cast<size_t>(t_s / d.bin_s));
  };
  for (const auto& [name, times] : arrivals) {
    std::vector<int>& v = d.messages_per_bin[name];
    v.assign(bins, 0);
    for (double t : times) ++v[index(t)];
  }
  // Cumulative series hold their last value through bins without a message.
  auto cumulative = [&](const std::vector<std::pair<double, int64_t>>& at) {
    std::vector<int64_t> v(bins, 0);
    for (const auto& [t, value] : at) v[index(t)] = std::max(v[index(t)], value);
    for (size_t i = 1; i < v.size(); ++i) v[i] = std::max(v[i], v[i - 1]);
    return v;
  };
  d.frames_missing_cumulative = cumulative(missing_at);
  for (const auto& [name, at] : dropped_at) d.dropped_cumulative[name] = cumulative(at);

  for (const auto& s : setpoints) {
    d.setpoints.push_back({(s.utime - t0) * 1e-6, sixAxes(s.left, s.right)});
    const double capture_ms = (s.publish_utime - s.utime) / 1000.0;
    if (capture_ms >= 0 && capture_ms < 60'000) {
      d.delay_ms.push_back(capture_ms + o.dead_time_s * 1000);
      d.delay_what = "frame capture -> setpoint publish, plus the plant dead time";
    } else if (frame_publish.count(s.frame_seq)) {
      // Lockstep: capture times are sim time; the processing chain is what is measured.
      d.delay_ms.push_back((s.publish_utime - frame_publish[s.frame_seq]) / 1000.0 +
                           o.dead_time_s * 1000);
      d.delay_what = "frame publish -> setpoint publish (lockstep log), plus the plant dead time";
    }
  }
  if (!frame_periods_us.empty()) {
    std::nth_element(frame_periods_us.begin(),
                     frame_periods_us.begin() + static_cast<long>(frame_periods_us.size() / 2),
                     frame_periods_us.end());
    const int64_t period = frame_periods_us[frame_periods_us.size() / 2];
    if (period > 0) d.frame_rate_hz = 1e6 / period;
  }
  if (d.frame_rate_hz > 0) {
    d.tau_max_ms =
        1000 * control::sampledTauMax({o.loop_gain, o.time_constant_s, 0.0}, d.frame_rate_hz);
  }
  // In double: times from the log, whatever they are, cannot overflow.
  const auto since_t0_s = [&](int64_t utime) {
    return (static_cast<double>(utime) - static_cast<double>(t0)) * 1e-6;
  };
  for (const auto& m : tracks)
    d.target_tracks.push_back({since_t0_s(m.utime), m.target_id, m.num_tracks});
  for (const auto& [utime, t] : track_points)
    d.track_points.push_back({since_t0_s(utime), t.id, t.state});
  for (const auto& m : control) d.control.push_back({since_t0_s(m.utime), m.state, m.target_id});
  // Centring: the tracked true object when the simulator's truth is logged, else the detections.
  const std::map<int64_t, FrameScore> scored = series_metrics.frames();
  const std::map<int64_t, std::vector<double>> centring = series_metrics.centeringByFrame();
  if (!centring.empty()) {
    d.centring_source = "SIM_TRUTH";
    for (const auto& [seq, off] : centring) {
      if (off.size() == 4 && frame_utime.count(seq)) {
        d.centring.push_back({(frame_utime[seq] - t0) * 1e-6, {off[0], off[1], off[2], off[3]}});
      }
    }
  }
  for (const auto& p : poses) {
    if (p.target_index < 0 || p.target_index >= static_cast<int32_t>(p.objects.size())) continue;
    const auto& obj = p.objects[static_cast<size_t>(p.target_index)];
    const double t_s = (p.utime - t0) * 1e-6;
    ReportData::Position row{
        t_s, {obj.position_m[0], obj.position_m[1], obj.position_m[2]}, {}, false};
    // The truth of the object this target was scored against (RunMetrics: by identity).
    if (auto it = scored.find(p.frame_seq); it != scored.end() && !it->second.tracked.empty()) {
      row.truth_m = it->second.tracked_truth_m;
      row.has_truth = true;
    }
    d.positions.push_back(row);
    auto det = detections.find(p.frame_seq);
    auto size = image_size.find(p.frame_seq);
    if (d.centring_source != "SIM_TRUTH" && det != detections.end() && size != image_size.end() &&
        obj.left_index >= 0 && obj.left_index < det->second.num_left && obj.right_index >= 0 &&
        obj.right_index < det->second.num_right) {
      const double cx = (size->second.first - 1) / 2.0, cy = (size->second.second - 1) / 2.0;
      // In VGA-equivalent pixels, as summary.json's centring (run_metrics).
      const double to_vga = vgaPxPerPx(size->second.first);
      const auto& l = det->second.left[static_cast<size_t>(obj.left_index)];
      const auto& r = det->second.right[static_cast<size_t>(obj.right_index)];
      d.centring.push_back({t_s,
                            {(l.centroid_x_px - cx) * to_vga, (l.centroid_y_px - cy) * to_vga,
                             (r.centroid_x_px - cx) * to_vga, (r.centroid_y_px - cy) * to_vga}});
      d.centring_source = "OBJECT_DETECTIONS";
    }
  }
  d.summary = summary_metrics.summary();
  return d;
}

}  // namespace ptz::tools
