// The scenario suite (test/scenarios/README.md): each scenario file is a ptz-sim config with a
// `scenario` section of its own checks; it runs in lockstep through the real ptz-sim, ptz-detect
// and ptz-control (JPEG frames), and every check is asserted on the run's numbers (RunMetrics).
// PTZ_SCENARIO names the file (ctest runs one test per file); without it, every file runs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "support/closed_loop.hpp"

namespace {

using ptz::tools::RunSummary;

// The checks a scenario may name: "max_<field>" or "min_<field>" of these summary fields.
const std::map<std::string, std::function<double(const RunSummary&)>>& fields() {
  static const std::map<std::string, std::function<double(const RunSummary&)>> f = {
      {"centering_rms_px", [](const RunSummary& s) { return s.centering_rms_px; }},
      {"centering_max_px", [](const RunSummary& s) { return s.centering_max_px; }},
      {"position_error_rms_pct_of_range",
       [](const RunSummary& s) { return s.position_error_rms_pct_of_range; }},
      {"position_error_max_pct_of_range",
       [](const RunSummary& s) { return s.position_error_max_pct_of_range; }},
      {"position_error_settled_rms_pct_of_range",
       [](const RunSummary& s) { return s.position_error_settled_rms_pct_of_range; }},
      {"frames_target_outside_image",
       [](const RunSummary& s) { return static_cast<double>(s.frames_target_outside_image); }},
      {"target_lost_s", [](const RunSummary& s) { return s.target_lost_s; }},
      {"position_samples",
       [](const RunSummary& s) { return static_cast<double>(s.position_samples); }},
      {"frames_processed",
       [](const RunSummary& s) { return static_cast<double>(s.frames_processed); }},
      {"frames_without_pose",
       [](const RunSummary& s) { return static_cast<double>(s.frames_without_pose); }},
      {"target_switches",
       [](const RunSummary& s) { return static_cast<double>(s.target_switches); }},
      {"time_to_acquire_s", [](const RunSummary& s) { return s.time_to_acquire_s; }},
      {"search_time_s", [](const RunSummary& s) { return s.search_time_s; }},
      {"coast_time_s", [](const RunSummary& s) { return s.coast_time_s; }},
      {"reappearances", [](const RunSummary& s) { return static_cast<double>(s.reappearances); }},
      {"reacquire_max_s", [](const RunSummary& s) { return s.reacquire_max_s; }},
      {"orientation_error_rms_deg",
       [](const RunSummary& s) { return s.orientation_error_rms_deg; }},
      {"orientation_samples",
       [](const RunSummary& s) { return static_cast<double>(s.orientation_samples); }},
  };
  return f;
}

// A scenario's arguments; a leading "${source}/" is the source tree (config files by path).
std::vector<std::string> strings(const cv::FileNode& n) {
  static const std::string kSource = "${source}/";
  std::vector<std::string> out;
  for (const auto& item : n) {
    std::string arg = static_cast<std::string>(item);
    if (arg.rfind(kSource, 0) == 0) arg = PTZ_SOURCE_DIR "/" + arg.substr(kSource.size());
    out.push_back(arg);
  }
  return out;
}

void runScenario(const std::string& path) {
  SCOPED_TRACE(path);
  cv::FileStorage fs(path, cv::FileStorage::READ);
  ASSERT_TRUE(fs.isOpened()) << "cannot read " << path;
  const cv::FileNode scenario = fs["scenario"];
  ASSERT_TRUE(scenario.isMap()) << path << ": no `scenario` section";
  const cv::FileNode checks = scenario["checks"];
  ASSERT_TRUE(checks.isMap() && checks.size() > 0) << path << ": scenario.checks is empty";
  // Every check is known before anything runs: a misspelt one must not pass silently.
  for (const auto& c : checks) {
    const std::string name = c.name();
    const bool known = (name.rfind("max_", 0) == 0 || name.rfind("min_", 0) == 0) &&
                       fields().count(name.substr(4));
    ASSERT_TRUE(known) << path << ": scenario.checks." << name << " is no known check";
    ASSERT_TRUE(c.isReal() || c.isInt()) << path << ": scenario.checks." << name;
  }
  std::printf("scenario %s: %s\n", std::filesystem::path(path).stem().c_str(),
              static_cast<std::string>(scenario["description"]).c_str());
  std::vector<std::string> sim_args = {"--config", path, "--encoding", "jpeg"};
  for (const std::string& a : strings(scenario["sim_args"])) sim_args.push_back(a);
  // The class to follow and score (ptz-detect's --target-class too); the ball's by default.
  const std::string target_class = scenario["target_class"].empty()
                                       ? "red_ball"
                                       : static_cast<std::string>(scenario["target_class"]);
  std::vector<std::string> detect_args = {"--target-class", target_class};
  for (const std::string& a : strings(scenario["detect_args"])) detect_args.push_back(a);
  // A click (optional): on an object, in a frame, as an operator clicks in ptz-view.
  const cv::FileNode click = scenario["click"];
  const std::string click_object = click.empty() ? "" : static_cast<std::string>(click["object"]);
  const int64_t click_frame = click.empty() ? -1 : static_cast<int>(click["frame"]);
  auto run = ptz::test::runLoop(sim_args, strings(scenario["control_args"]), detect_args,
                                target_class, click_object, click_frame);
  const RunSummary s = run->metrics.summary();
  std::printf("%s", s.toJson().c_str());
  EXPECT_EQ(run->counters["ptz-sim"]["lockstep_timeouts"], 0);
  for (const auto& c : checks) {
    const std::string name = c.name();
    const double limit = static_cast<double>(c);
    const double value = fields().at(name.substr(4))(s);
    if (name.rfind("max_", 0) == 0) {
      EXPECT_LE(value, limit) << name;  // NaN fails: a number that never came is no pass
    } else {
      EXPECT_GE(value, limit) << name;
    }
  }
}

}  // namespace

TEST(Scenario, MeetsItsChecks) {
  const char* one = std::getenv("PTZ_SCENARIO");
  std::vector<std::string> paths;
  if (one && *one) {
    paths.push_back(one);
  } else {
    for (const auto& e : std::filesystem::directory_iterator(PTZ_SOURCE_DIR "/test/scenarios")) {
      if (e.path().extension() == ".yaml") paths.push_back(e.path().string());
    }
    std::sort(paths.begin(), paths.end());
  }
  ASSERT_FALSE(paths.empty());
  for (const auto& p : paths) runScenario(p);
}
