// ptz-report's library: the time series of a run, read from its LCM log, and the report folder
// made of them (CSV, gnuplot PNGs, summary.json, report.md).
#pragma once

#include <array>
#include <map>
#include <string>
#include <vector>

#include "tools/logs/log_reader.hpp"
#include "tools/logs/run_metrics.hpp"

namespace ptz::tools {

struct ReportOptions {
  std::string channel_prefix;
  std::string target_class = "red_ball";
  double settle_s = 2.0;     // for summary.json, as the demo's
  double dead_time_s = 0.0;  // the plant's, added to the measured delay
  double loop_gain = 1.7;    // the paper's loop, for tau_max on the delay histogram
  double time_constant_s = 0.24;
};

struct ReportData {
  // Times in s from the first frame's (or state's) utime: the capture clock of the run.
  struct Ptz {
    double t_s;
    std::array<double, 6> v;  // left pan, tilt, zoom, right pan, tilt, zoom
  };
  std::vector<Ptz> setpoints;  // at the capture time of the frame each answers
  std::vector<Ptz> states;
  struct Centring {
    double t_s;
    std::array<double, 4> px;  // left dx, dy, right dx, dy from the image centre
  };
  std::vector<Centring> centring;
  std::string centring_source;  // "SIM_TRUTH" (the true target) or "OBJECT_DETECTIONS"
  struct Position {
    double t_s;
    std::array<double, 3> estimate_m, truth_m;
    bool has_truth;
  };
  std::vector<Position> positions;
  // The track the system follows (OBJECT_TRACKS target_id, -1: none) and how many are live.
  struct TargetTrack {
    double t_s;
    int64_t target_id;
    int32_t tracks;
  };
  std::vector<TargetTrack> target_tracks;
  // Every live track of every OBJECT_TRACKS (the first kMaxTracksPlotted of each): its id and
  // state (object_track_t::STATE_*) over time.
  static constexpr size_t kMaxTracksPlotted = 16;
  struct TrackPoint {
    double t_s;
    int64_t id;
    int state;
  };
  std::vector<TrackPoint> track_points;
  // ptz-control's state (CONTROL_STATE, control_state_t::STATE_*) per setpoint.
  struct Control {
    double t_s;
    int state;
    int64_t target_id;
  };
  std::vector<Control> control;
  std::vector<double> delay_ms;
  std::string delay_what;  // what delay_ms measures
  double frame_rate_hz = 0;
  double tau_max_ms = 0;  // sampled tau_max of the paper's loop at frame_rate_hz
  // Per channel: messages per bin of log (receive) time; drops: cumulative per bin.
  double bin_s = 1.0;
  std::map<std::string, std::vector<int>> messages_per_bin;
  std::vector<int64_t> frames_missing_cumulative;                  // STEREO_FRAME sequence gaps
  std::map<std::string, std::vector<int64_t>> dropped_cumulative;  // "process.counter"
  std::map<std::string, int64_t> channel_messages;
  int64_t undecodable = 0;
  RunSummary summary;
  std::string breaks;  // where the log is broken ("" when whole)
  double duration_s = 0;
};

// Reads the whole log. Throws LogError for an empty or foreign log or one without any channel a
// report needs (the message names the channels it has).
ReportData collectReport(LogReader& log, const ReportOptions& options);

// Writes the CSVs, PNGs (gnuplot), summary.json and report.md into dir (an existing folder;
// ptz-report gives a temporary one, see OutputDir); returns the files written. Throws
// std::runtime_error when dir cannot be written or gnuplot fails.
std::vector<std::string> writeReport(const ReportData& data, const std::string& log_path,
                                     const std::string& dir);

}  // namespace ptz::tools
