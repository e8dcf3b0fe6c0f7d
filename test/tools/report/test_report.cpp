// ptz-report on the committed 2 s run: every plot, and a summary whose numbers match what this
// test computes from the log on its own (OpenCV's projectPoints for the centring); broken,
// empty and unrelated logs; a made-up run's track ids and controller states over time; folder
// and channel names that a shell or gnuplot would run; plots.gp re-run in a moved folder;
// a colour per channel; a missing or failing gnuplot.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>

#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "tools/logs/synthetic_run.hpp"
#include "tools/report/report.hpp"

namespace {

const std::string kFixture = PTZ_SOURCE_DIR "/test/fixtures/closed_loop_2s.lcmlog";

std::string tempPath(const std::string& name) {
  return std::string(::testing::TempDir()) + name;
}

std::string readAll(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// The true target's pixel offset from the image centre, by OpenCV from the camera model alone.
double offsetPx(const ptzstereo::camera_model_t& cam, const double p_head[3]) {
  cv::Matx33d R_head_camera(cam.rotation_head_camera);
  const cv::Matx33d R = R_head_camera.t();  // head -> camera
  const cv::Vec3d c(cam.position_head_m[0], cam.position_head_m[1], cam.position_head_m[2]);
  const cv::Vec3d t = -(R * c);
  cv::Vec3d rvec;
  cv::Rodrigues(R, rvec);
  const cv::Matx33d K(cam.fx_px, 0, cam.cx_px, 0, cam.fy_px, cam.cy_px, 0, 0, 1);
  std::vector<double> dist(cam.distortion, cam.distortion + 5);
  std::vector<cv::Point2d> px;
  cv::projectPoints(std::vector<cv::Point3d>{{p_head[0], p_head[1], p_head[2]}}, rvec, t, K, dist,
                    px);
  return std::hypot(px[0].x - (cam.width - 1) / 2.0, px[0].y - (cam.height - 1) / 2.0);
}

// A number of summary.json (OpenCV's JSON reader refuses null).
double jsonNumber(const std::string& json, const std::string& key) {
  const auto at = json.find("\"" + key + "\": ");
  if (at == std::string::npos) return NAN;
  return std::strtod(json.c_str() + at + key.size() + 4, nullptr);
}

int runReport(const std::string& args, std::string* output) {
  // One file per test: ctest runs the tests of this suite side by side.
  const std::string out = tempPath(
      std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + ".output.txt");
  const int status = std::system((PTZ_REPORT_BIN " " + args + " > " + out + " 2>&1").c_str());
  *output = readAll(out);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

TEST(Report, EveryPlotAndASummaryThatMatchesTheLog) {
  const std::string dir = tempPath("fixture.report");
  std::string output;
  ASSERT_EQ(runReport(kFixture + " --out " + dir + " --settle-s 0.5", &output), 0) << output;
  for (const char* png : {"ptz.png", "centring.png", "position.png", "delay.png", "rates.png"}) {
    const cv::Mat image = cv::imread(dir + "/" + png);
    EXPECT_EQ(image.cols, 1000) << png;
    EXPECT_EQ(image.rows, 750) << png;
    EXPECT_NE(readAll(dir + "/report.md").find(std::string("](") + png + ")"), std::string::npos)
        << png << " is not shown in report.md";
  }
  // The numbers, from the log by this test (a pose may be logged before its truth).
  int64_t frames = 0, poses = 0, without_target = 0;
  std::map<int64_t, ptzstereo::sim_truth_t> truth;
  std::vector<ptzstereo::object_pose_t> targeted;
  std::vector<double> errors_m, centring_px;
  lcm::LogFile log(kFixture, "r");
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel == "STEREO_FRAME") ++frames;
    if (ev->channel == "SIM_TRUTH") {
      ptzstereo::sim_truth_t t;
      ASSERT_GE(t.decode(ev->data, 0, ev->datalen), 0);
      truth[t.frame_seq] = t;
    }
    if (ev->channel == "OBJECT_POSE") {
      ptzstereo::object_pose_t p;
      ASSERT_GE(p.decode(ev->data, 0, ev->datalen), 0);
      ++poses;
      if (p.target_index < 0) {
        ++without_target;
        continue;
      }
      targeted.push_back(p);
    }
  }
  // Centring from 0.5 s (--settle-s) after the first lock: the first pose with a target.
  ASSERT_FALSE(targeted.empty());
  int64_t lock_utime = targeted.front().utime;
  for (const auto& p : targeted) lock_utime = std::min(lock_utime, p.utime);
  for (const auto& [seq, t] : truth) {
    if (t.utime - lock_utime < 500000) continue;
    centring_px.push_back(offsetPx(t.left_camera, t.objects[0].position_m));
    centring_px.push_back(offsetPx(t.right_camera, t.objects[0].position_m));
  }
  for (const auto& p : targeted) {
    const auto& o = p.objects[static_cast<size_t>(p.target_index)];
    ASSERT_EQ(truth.count(p.frame_seq), 1u) << "frame " << p.frame_seq;
    const auto& t = truth.at(p.frame_seq).objects[0];
    errors_m.push_back(std::hypot(o.position_m[0] - t.position_m[0],
                                  o.position_m[1] - t.position_m[1],
                                  o.position_m[2] - t.position_m[2]));
  }
  auto rms = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x * x;
    return std::sqrt(s / v.size());
  };
  ASSERT_EQ(truth.begin()->second.objects[0].class_name, "red_ball");
  const std::string summary = readAll(dir + "/summary.json");
  EXPECT_EQ(jsonNumber(summary, "frames_published"), frames);
  EXPECT_EQ(jsonNumber(summary, "frames_processed"), poses);
  EXPECT_EQ(jsonNumber(summary, "poses_without_target"), without_target);
  EXPECT_NEAR(jsonNumber(summary, "position_error_rms_m"), rms(errors_m), 1e-5);
  EXPECT_NEAR(jsonNumber(summary, "centering_rms_px"), rms(centring_px), 1e-3);
  // Every setpoint is in the delay histogram's data.
  const std::string delays = readAll(dir + "/delay.csv");
  EXPECT_EQ(std::count(delays.begin(), delays.end(), '\n') - 1, poses);
}

TEST(Report, ATruncatedLogIsReportedAsFarAsItGoesAndSaysWhere) {
  const std::string bytes = readAll(kFixture);
  const std::string cut = tempPath("truncated.lcmlog");
  const size_t keep = bytes.size() * 6 / 10;
  std::ofstream(cut, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(keep));
  std::string output;
  ASSERT_EQ(runReport(cut + " --out " + tempPath("truncated.report"), &output), 0) << output;
  EXPECT_NE(output.find("partial or unreadable event (cut off) at byte"), std::string::npos)
      << output;
  EXPECT_NE(readAll(tempPath("truncated.report/report.md")).find("The log is broken"),
            std::string::npos);
  EXPECT_FALSE(cv::imread(tempPath("truncated.report/ptz.png")).empty());
}

TEST(Report, GarbageInTheMiddleIsSkippedAndLocated) {
  std::string bytes = readAll(kFixture);
  // From the first event header after the middle (LCM's sync word), so the garbage breaks an
  // event whatever the sizes of the events around the middle.
  const size_t at = bytes.find(std::string("\xED\xA1\xDA\x01", 4), bytes.size() / 2);
  ASSERT_NE(at, std::string::npos);
  ASSERT_LT(at + 5000, bytes.size());
  for (size_t i = at; i < at + 5000; ++i) bytes[i] = static_cast<char>(i * 7919 % 251);
  const std::string path = tempPath("corrupt.lcmlog");
  std::ofstream(path, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ptz::tools::LogReader reader(path);
  const ptz::tools::ReportData d = ptz::tools::collectReport(reader, {});
  ASSERT_FALSE(reader.breaks().empty());
  const auto& b = reader.breaks().front();
  EXPECT_LE(b.offset, static_cast<int64_t>(at));  // the broken event starts at or before it
  EXPECT_GE(b.offset + b.bytes, static_cast<int64_t>(at + 5000));
  EXPECT_GT(d.states.size(), 100u);  // what follows is read
}

TEST(Report, AnEmptyLogOrOneWithoutTheNeededChannelsIsRefused) {
  const std::string empty = tempPath("empty.lcmlog");
  std::ofstream(empty).close();
  std::string output;
  EXPECT_EQ(runReport(empty, &output), 5);
  EXPECT_EQ(output, "ptz-report: log '" + empty + "' is empty (0 bytes)\n");

  const std::string other = tempPath("status_only.lcmlog");
  {
    lcm::LogFile log(other, "w");
    ptzstereo::process_status_t s{};
    s.process = "someone";
    std::vector<uint8_t> buf(static_cast<size_t>(s.getEncodedSize()));
    s.encode(buf.data(), 0, static_cast<int>(buf.size()));
    lcm::LogEvent ev{};
    ev.channel = "PROCESS_STATUS_SOMEONE";
    ev.datalen = static_cast<int32_t>(buf.size());
    ev.data = buf.data();
    log.writeEvent(&ev);
  }
  EXPECT_EQ(runReport(other + " --out " + tempPath("status_only.report"), &output), 7);
  EXPECT_EQ(output, "ptz-report: log '" + other +
                        "' lacks the channels needed: none of STEREO_FRAME, PTZ_STATE, "
                        "PTZ_SETPOINT, SIM_TRUTH; it has PROCESS_STATUS_SOMEONE (1)\n");
  EXPECT_FALSE(std::ifstream(tempPath("status_only.report/report.md")).good());  // no folder
  EXPECT_EQ(runReport("/nonexistent/run.lcmlog", &output), 4);
  EXPECT_EQ(output, "ptz-report: log '/nonexistent/run.lcmlog': No such file or directory\n");
  EXPECT_EQ(runReport(kFixture + " --settle-s -5", &output), 2);
  EXPECT_EQ(output, "ptz-report: flag --settle-s: parameter 'settle_s' must be >= 0, got '-5'\n");
}

TEST(Report, TrackIdsAndControllerStateOverTimeAndTheRunsNumbersOfAKnownRun) {
  namespace syn = ptz::test::synthetic;
  using K = syn::KnownRun;
  const std::string log = tempPath("known.lcmlog"), dir = tempPath("known.report");
  syn::writeKnownRun(log);
  ptz::tools::LogReader reader(log);
  ptz::tools::ReportOptions options;
  options.settle_s = 0;
  const ptz::tools::ReportData d = ptz::tools::collectReport(reader, options);
  ASSERT_EQ(d.target_tracks.size(), 18u);  // frames 2-19
  EXPECT_NEAR(d.target_tracks[0].t_s, 0.2, 1e-9);
  EXPECT_EQ(d.target_tracks[0].target_id, -1);
  EXPECT_EQ(d.target_tracks[5].target_id, 1);   // frame 7
  EXPECT_EQ(d.target_tracks[14].target_id, 2);  // frame 16
  EXPECT_EQ(d.target_tracks[14].tracks, 2);
  // Every track of every message: none in frames 2-4, two in frames 5-19.
  ASSERT_EQ(d.track_points.size(), 15u * 2);
  EXPECT_NEAR(d.track_points[0].t_s, 0.5, 1e-9);
  EXPECT_EQ(d.track_points.back().id, 2);
  EXPECT_EQ(d.track_points.back().state, ptzstereo::object_track_t::STATE_CONFIRMED);
  ASSERT_EQ(d.control.size(), 18u);
  EXPECT_EQ(d.control[0].state, ptzstereo::control_state_t::STATE_SEARCHING);
  EXPECT_EQ(d.control[10].state, ptzstereo::control_state_t::STATE_COASTING);  // frame 12
  // The 3D truth of each position is the object tracked: ball_b once it is the target.
  ASSERT_EQ(d.positions.size(), static_cast<size_t>(K::kOnA + K::kOnB));
  EXPECT_EQ(d.positions.back().truth_m[0], 0.5);
  EXPECT_EQ(d.positions.front().truth_m[0], 0.0);
  EXPECT_EQ(d.summary.target_switches, K::kSwitches);
  EXPECT_NEAR(d.summary.search_time_s, K::kSearchS, 1e-9);
  EXPECT_NEAR(d.summary.coast_time_s, K::kCoastS, 1e-9);
  EXPECT_NEAR(d.summary.time_to_acquire_s, K::kAcquireS, 1e-9);
  EXPECT_NEAR(d.summary.target_lost_s, K::kLostS, 1e-9);
  EXPECT_EQ(d.summary.frames_without_pose, K::kWithoutPose);

  std::string output;
  ASSERT_EQ(runReport(log + " --out " + dir + " --settle-s 0", &output), 0) << output;
  const cv::Mat image = cv::imread(dir + "/tracks.png");
  EXPECT_EQ(image.cols, 1000);
  EXPECT_EQ(image.rows, 750);
  EXPECT_NE(readAll(dir + "/report.md").find("](tracks.png)"), std::string::npos);
  const std::string control = readAll(dir + "/control_state.csv");
  EXPECT_EQ(control.rfind("t_s,state,target_id\n0.2,2,-1\n", 0), 0u) << control;
  const std::string target = readAll(dir + "/target.csv");
  EXPECT_NE(target.find("\n1.6,2,2\n"), std::string::npos) << target;
  const std::string points = readAll(dir + "/tracks.csv");
  EXPECT_EQ(points.rfind("t_s,track_id,state\n0.5,1,1\n", 0), 0u) << points;
  const std::string summary = readAll(dir + "/summary.json");
  EXPECT_EQ(jsonNumber(summary, "target_switches"), K::kSwitches);
  EXPECT_NEAR(jsonNumber(summary, "search_time_s"), K::kSearchS, 1e-9);
}

namespace {

// ptz-report without a shell: argv as given, in folder `cwd`, PATH optionally replaced.
int spawnReport(const std::vector<std::string>& args, const std::string& cwd, std::string* output,
                const std::string& path_env = "") {
  const std::string out = tempPath(
      std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + ".spawn.txt");
  std::vector<std::string> strings = {PTZ_REPORT_BIN};
  strings.insert(strings.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& s : strings) argv.push_back(s.data());
  argv.push_back(nullptr);
  std::vector<std::string> env_strings;
  for (char** e = environ; *e; ++e) {
    if (!path_env.empty() && std::string(*e).rfind("PATH=", 0) == 0) continue;
    env_strings.push_back(*e);
  }
  if (!path_env.empty()) env_strings.push_back("PATH=" + path_env);
  std::vector<char*> envp;
  for (auto& s : env_strings) envp.push_back(s.data());
  envp.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addchdir_np(&actions, cwd.c_str());
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, out.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = 0;
  const int spawned =
      posix_spawn(&pid, PTZ_REPORT_BIN, &actions, nullptr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return -1;
  int status = 0;
  waitpid(pid, &status, 0);
  *output = readAll(out);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// gnuplot on plots.gp inside `dir`, as a user would re-run it there.
int runGnuplotIn(const std::string& dir) {
  std::string program = "gnuplot", script = "plots.gp";
  char* argv[] = {program.data(), script.data(), nullptr};
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addchdir_np(&actions, dir.c_str());
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, "gnuplot", &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return -1;
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// A fresh, empty folder for one test.
std::string freshDir(const std::string& name) {
  const std::string dir = tempPath(name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

std::vector<std::string> filesIn(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// The single-quoted strings of a gnuplot script ('' inside is a quote).
std::vector<std::string> quotedStrings(const std::string& script) {
  std::vector<std::string> out;
  for (size_t i = 0; i < script.size(); ++i) {
    if (script[i] != '\'') continue;
    std::string s;
    for (++i; i < script.size(); ++i) {
      if (script[i] == '\'' && i + 1 < script.size() && script[i + 1] == '\'') {
        s += '\'';
        ++i;
      } else if (script[i] == '\'') {
        break;
      } else {
        s += script[i];
      }
    }
    out.push_back(s);
  }
  return out;
}

// The line of plots.gp that plots `csv` (the first plot command naming it).
std::string plotLineOf(const std::string& script, const std::string& csv) {
  std::istringstream in(script);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("plot ", 0) == 0 && line.find("'" + csv + "'") != std::string::npos) return line;
  }
  return "";
}

std::vector<std::string> coloursOf(const std::string& plot_line) {
  std::vector<std::string> colours;
  for (size_t at = plot_line.find("lc rgb '"); at != std::string::npos;
       at = plot_line.find("lc rgb '", at + 1)) {
    colours.push_back(plot_line.substr(at + 8, 7));
  }
  return colours;
}

}  // namespace

TEST(Report, AFolderNamedWithQuotesSpacesAndShellSyntaxWorksAndRunsNothing) {
  const std::string cwd = freshDir("hostile-cwd");
  const std::string parent = freshDir("it's a $(touch pwned) `touch pwned2` dir");
  const std::string dir = parent + "/report 'x'; touch pwned3";
  std::string output;
  ASSERT_EQ(spawnReport({kFixture, "--out", dir}, cwd, &output), 0) << output;
  EXPECT_EQ(output, "report: " + dir + "/report.md (19 files)\n");
  for (const char* png : {"ptz.png", "centring.png", "position.png", "delay.png", "rates.png"})
    EXPECT_FALSE(cv::imread(dir + "/" + png).empty()) << png;
  // Nothing was run from the name: no file appeared where a shell would have made it.
  EXPECT_TRUE(filesIn(cwd).empty());
  EXPECT_EQ(filesIn(parent), std::vector<std::string>{"report 'x'; touch pwned3"});
  EXPECT_FALSE(std::filesystem::exists(dir + "/pwned3"));
}

TEST(Report, PlotsGpIsRelativeAndReRunsInAMovedCopyToTheSamePngs) {
  const std::string dir = freshDir("moved-src") + "/report";
  std::string output;
  ASSERT_EQ(spawnReport({kFixture, "--out", dir}, tempPath(""), &output), 0) << output;
  const std::string script = readAll(dir + "/plots.gp");
  const auto strings = quotedStrings(script);
  ASSERT_GT(strings.size(), 20u);
  for (const auto& s : strings) {
    EXPECT_NE(s.front(), '/') << "absolute path in plots.gp: " << s;
    EXPECT_EQ(s.find(tempPath("")), std::string::npos) << "the folder's path in plots.gp: " << s;
  }
  // Moved elsewhere, the PNGs removed, gnuplot run inside it: the same pictures again.
  const std::string copy = freshDir("moved-dst") + "/elsewhere";
  std::filesystem::copy(dir, copy);
  const std::vector<std::string> pngs = {"ptz.png", "centring.png", "position.png", "delay.png",
                                         "rates.png"};
  for (const auto& png : pngs) ASSERT_TRUE(std::filesystem::remove(copy + "/" + png)) << png;
  ASSERT_EQ(runGnuplotIn(copy), 0);
  for (const auto& png : pngs) {
    const cv::Mat a = cv::imread(dir + "/" + png), b = cv::imread(copy + "/" + png);
    ASSERT_FALSE(b.empty()) << png << " was not made again";
    ASSERT_EQ(a.size(), b.size()) << png;
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0) << png << " differs";
  }
}

TEST(Report, EveryChannelHasItsOwnColourAndLcmSelfTestIsLeftOut) {
  // The fixture has LCM's self-test messages (lcm-logger records them).
  ASSERT_NE(readAll(kFixture).find("LCM_SELF_TEST"), std::string::npos);
  const std::string dir = freshDir("colours") + "/report";
  std::string output;
  ASSERT_EQ(spawnReport({kFixture, "--out", dir}, tempPath(""), &output), 0) << output;
  for (const char* file : {"rates.csv", "plots.gp", "report.md", "drops.csv", "summary.json"})
    EXPECT_EQ(readAll(dir + "/" + file).find("LCM_SELF_TEST"), std::string::npos) << file;
  const std::string rates = readAll(dir + "/rates.csv");
  const std::string header = rates.substr(0, rates.find('\n'));
  const auto channels = std::count(header.begin(), header.end(), ',');
  ASSERT_GE(channels, 10) << header;
  for (const char* csv : {"rates.csv", "drops.csv"}) {
    const std::string line = plotLineOf(readAll(dir + "/plots.gp"), csv);
    const auto colours = coloursOf(line);
    long series = 0;  // one per mention of the CSV
    for (size_t at = line.find("'" + std::string(csv) + "'"); at != std::string::npos;
         at = line.find("'" + std::string(csv) + "'", at + 1)) {
      ++series;
    }
    EXPECT_EQ(static_cast<long>(colours.size()), series) << line;
    if (std::string(csv) == "rates.csv") {
      EXPECT_EQ(static_cast<long>(colours.size()), channels);
    }
    const std::set<std::string> distinct(colours.begin(), colours.end());
    EXPECT_EQ(distinct.size(), colours.size()) << csv << ": a colour is used twice: " << line;
  }
}

TEST(Report, AChannelNamedLikeGnuplotCommandsIsOnlyATitle) {
  // The fixture plus one message on a channel whose name tries to end the title and run a
  // command in gnuplot; logged at time 0, before the first event (times that go back).
  const std::string log = tempPath("hostile_channel.lcmlog");
  const std::string dir = freshDir("hostile-channel") + "/report";
  const std::string marker = tempPath("hostile-channel/ran");
  {
    lcm::LogFile in(kFixture, "r"), out(log, "w");
    while (const lcm::LogEvent* ev = in.readNextEvent()) {
      lcm::LogEvent copy = *ev;
      out.writeEvent(&copy);
    }
    uint8_t byte = 0;
    lcm::LogEvent ev{};
    ev.channel = "X'\nsystem('touch " + marker + "')\nprint '";
    ev.datalen = 1;
    ev.data = &byte;
    out.writeEvent(&ev);
  }
  std::string output;
  ASSERT_EQ(spawnReport({log, "--out", dir}, tempPath(""), &output), 0) << output;
  EXPECT_FALSE(std::filesystem::exists(marker)) << "gnuplot ran a command from a channel name";
  EXPECT_NE(readAll(dir + "/plots.gp").find("title 'X''?system(''touch "), std::string::npos);
}

TEST(Report, AMissingGnuplotIsReportedAsSuch) {
  const std::string empty_path = freshDir("no-gnuplot-path");
  std::string output;
  EXPECT_EQ(spawnReport({kFixture, "--out", tempPath("no-gnuplot.report")}, tempPath(""), &output,
                        empty_path),
            8);
  EXPECT_EQ(output.rfind("ptz-report: gnuplot is not installed (not found on PATH)", 0), 0u)
      << output;
  EXPECT_FALSE(std::filesystem::exists(tempPath("no-gnuplot.report")));
}

TEST(Report, AFailingGnuplotShowsWhatGnuplotSaid) {
  // A "gnuplot" that fails with a message of its own, first on PATH.
  const std::string bin = freshDir("fake-gnuplot");
  {
    std::ofstream f(bin + "/gnuplot");
    f << "#!/bin/sh\necho \"line 3: unknown terminal type\" >&2\nexit 1\n";
  }
  std::filesystem::permissions(bin + "/gnuplot", std::filesystem::perms::owner_all);
  std::string output;
  EXPECT_EQ(spawnReport({kFixture, "--out", tempPath("bad-gnuplot.report")}, tempPath(""), &output,
                        bin + ":/usr/bin:/bin"),
            8);
  EXPECT_NE(output.find("gnuplot failed (exit code 1) on '"), std::string::npos) << output;
  EXPECT_NE(output.find("plots.gp':\nline 3: unknown terminal type\n"), std::string::npos)
      << output;
}
