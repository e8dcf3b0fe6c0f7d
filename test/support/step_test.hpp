// A step test as a user runs one: what is heard on PTZ_STATE and PTZ_SETPOINT logged as
// lcm-logger would, each STEREO_FRAME answered with a pan setpoint (0 for the first 15 frames,
// then step_rad), and ptz-identify's fit of the log read back.
#pragma once

#include <lcm/lcm-cpp.hpp>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include "common/transport/transport.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz::test {

struct StepTest {
  lcm::LCM* lcm;
  lcm::LogFile* log;
  double step_rad = 0.3;
  int64_t events = 0;

  void subscribe() {
    lcm->subscribe("PTZ_STATE", &StepTest::record, this);
    lcm->subscribe("PTZ_SETPOINT", &StepTest::record, this);
    lcm->subscribe("STEREO_FRAME", &StepTest::onFrame, this);
  }
  void record(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    lcm::LogEvent ev{};
    ev.eventnum = events++;
    ev.timestamp = rbuf->recv_utime;
    ev.channel = channel;
    ev.datalen = static_cast<int32_t>(rbuf->data_size);
    ev.data = rbuf->data;
    log->writeEvent(&ev);
  }
  void onFrame(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::stereo_frame_t* m) {
    ptzstereo::ptz_setpoint_t sp{};
    sp.utime = m->utime;
    sp.frame_seq = m->seq;
    sp.publish_utime = ptz::wallUtime();
    const double pan = m->seq < 15 ? 0.0 : step_rad;
    sp.left = {pan, 0.0, 1.0};
    sp.right = {pan, 0.0, 1.0};
    lcm->publish("PTZ_SETPOINT", &sp);
  }
};

struct Identified {
  bool ok = false;
  double K = 0, T_s = 0, tau_s = 0;
  std::string text;  // what ptz-identify printed
};

// ptz-identify's fit of the log's left pan (its first axis with a step).
inline Identified identify(const std::string& identify_bin, const std::string& log_path) {
  Identified r;
  const std::string out = log_path + ".identify.txt";
  if (std::system((identify_bin + " --log " + log_path + " > " + out).c_str()) != 0) return r;
  std::ifstream in(out);
  r.text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  const auto at = r.text.find("K = ");
  r.ok = at != std::string::npos && std::sscanf(r.text.c_str() + at, "K = %lf T = %lf s tau = %lf",
                                                &r.K, &r.T_s, &r.tau_s) == 3;
  return r;
}

}  // namespace ptz::test
