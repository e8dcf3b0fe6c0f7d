// The fixture of the serial VISCA tests: a daisy chain of two emulated cameras (EVI-D70 model,
// the shared plant model) on the master end of a pty, two heads on its slave path sharing one
// line. Time is the test's (seconds from 0), so the plant model gives the known answers.
#pragma once

#include <gtest/gtest.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/plant.hpp"
#include "ptz_driver/emulators/visca_chain_emulator.hpp"
#include "ptz_driver/heads/visca/visca_serial_head.hpp"
#include "support/hardware/pty_pair.hpp"

namespace ptz::test {

inline const std::string kD70 = PTZ_SOURCE_DIR "/config/visca/sony_evi_d70.yaml";

class ViscaSerial : public ::testing::Test {
 protected:
  driver::ViscaModel model = driver::ViscaModel::load(kD70);
  PtyPair pty;
  DeviceLink link{pty.path()};  // the path the heads open, as a user's /dev/serial/by-id/...
  PtyPair* wire = &pty;         // where the chain is plugged in now
  driver::ViscaChainEmulator chain{model, ptz::defaultPlantParams(), 2};
  std::shared_ptr<driver::ViscaSerialLine> line =
      std::make_shared<driver::ViscaSerialLine>(link.path(), 9600, "serial_baud");
  driver::ViscaSerialHead left{model, line, 1};
  driver::ViscaSerialHead right{model, line, 2};

  // The chain takes `packets` packets from the heads and answers them at now_s.
  std::vector<driver::Bytes> serve(size_t packets, double now_s) {
    const auto in = ptz::test::readViscaPackets(*wire, packets);
    EXPECT_EQ(in.size(), packets);
    for (const driver::Bytes& p : in) wire->write(chain.feed(p.data(), p.size(), now_s));
    return in;
  }
  // The heads read at now_s until done() (at most 2 s).
  bool read(double now_s, const std::function<bool()>& done) {
    return driver::waitUntil(
        line->fd(), 2.0,
        [&] {
          left.receive(now_s);
          right.receive(now_s);
        },
        done);
  }
  int64_t replies() { return left.stats().replies + right.stats().replies; }
  void startChain() {
    left.start(0);
    right.start(0);
    serve(2, 0);
    ASSERT_TRUE(read(0, [&] { return replies() == 2; }));
  }
  // One round of position inquiries of head h, answered at now_s (pan-tilt, then zoom).
  void measure(driver::ViscaSerialHead& h, double now_s) {
    const int64_t before = h.stats().replies;
    h.inquire(now_s, 0.1);
    serve(1, now_s);
    ASSERT_TRUE(read(now_s, [&] { return h.stats().replies == before + 1; }));
    serve(1, now_s);  // the zoom inquiry went after the pan-tilt answer
    ASSERT_TRUE(read(now_s, [&] { return h.stats().replies == before + 2; }));
  }
};
}  // namespace ptz::test
