// Quadrature decoding (x4 state table) against hand-made sequences, and the simulated encoder
// counted through the decoder: known counts for a known rotation of the simulated motor, both
// ways; lost edges counted as illegal transitions.
#include <gtest/gtest.h>

#include <cmath>

#include "ptz_driver/gpio_fake.hpp"
#include "ptz_driver/quadrature.hpp"

using ptz::driver::FakeAxisSpec;
using ptz::driver::FakeGpio;
using ptz::driver::LineEvent;
using ptz::driver::QuadratureDecoder;

TEST(Quadrature, CountsEveryEdgeBothWays) {
  // AB = 00 10 11 01 00 ... counts up (A leads B); the reverse counts down.
  const bool seq[4][2] = {{false, false}, {true, false}, {true, true}, {false, true}};
  QuadratureDecoder d;
  d.reset(false, false);
  for (int i = 1; i <= 400; ++i) d.sample(seq[i % 4][0], seq[i % 4][1], i * 1e-3);
  EXPECT_EQ(d.count(), 400);
  EXPECT_DOUBLE_EQ(d.lastEdgeS(), 0.4);
  for (int i = 399; i >= -3; --i) d.sample(seq[(i + 4) % 4][0], seq[(i + 4) % 4][1], 1.0);
  EXPECT_EQ(d.count(), -3);
  EXPECT_EQ(d.illegal(), 0);
  // The same through edges of one line at a time: A rises, B rises, A falls, B falls = +4.
  QuadratureDecoder e;
  e.reset(false, false);
  for (int turn = 0; turn < 10; ++turn) {
    e.edge(0, true, 0);
    e.edge(1, true, 0);
    e.edge(0, false, 0);
    e.edge(1, false, 0);
  }
  EXPECT_EQ(e.count(), 40);
  e.edge(1, true, 0);  // B first: down
  EXPECT_EQ(e.count(), 39);
  EXPECT_EQ(e.illegal(), 0);
}

TEST(Quadrature, IllegalTransitionsAreCountedNotDecoded) {
  QuadratureDecoder d;
  d.reset(false, false);
  d.sample(true, true, 0);  // 00 -> 11: both lines changed, direction unknown
  EXPECT_EQ(d.illegal(), 1);
  EXPECT_EQ(d.count(), 0);
  d.sample(false, true, 0);  // 11 -> 01: legal again, +1
  EXPECT_EQ(d.count(), 1);
  d.edge(1, true, 0);  // B "rises" while high: the falling edge before it was lost
  EXPECT_EQ(d.illegal(), 2);
  EXPECT_EQ(d.count(), 1);
}

namespace {

// One simulated axis, its lines requested and decoded by hand (no controller).
struct OpenLoop {
  OpenLoop() : chip({spec()}) {
    chip.requestOutput(0, "dir");
    chip.requestOutput(1, "enable");
    for (int line = 2; line <= 5; ++line) chip.requestEvents(line, ptz::driver::Bias::kAsIs, "in");
    decoder.reset(chip.get(2), chip.get(3));
  }
  static FakeAxisSpec spec() {
    FakeAxisSpec s;
    s.lines = {0, -1, 1, 2, 3, 4, 5};
    s.counts_per_rad = 1000;
    s.max_speed_rad_s = 4;
    s.time_constant_s = 0.05;
    s.start_rad = 0;
    s.min_switch_rad = -10;
    s.max_switch_rad = 10;
    s.min_stop_rad = -20;
    s.max_stop_rad = 20;
    return s;
  }
  // Advances in 1 ms steps, decoding the edges as they come, checking their order.
  void run(double until_s) {
    while (t_s < until_s - 1e-12) {
      t_s = std::min(t_s + 1e-3, until_s);
      chip.advanceTo(t_s);
      events.clear();
      chip.readEvents(&events);
      for (const auto& e : events) {
        EXPECT_GE(e.time_s, last_s);
        last_s = e.time_s;
        decoder.edge(e.line == 2 ? 0 : 1, e.rising, e.time_s);
        ++edges;
      }
    }
  }
  FakeGpio chip;
  QuadratureDecoder decoder;
  std::vector<LineEvent> events;
  double t_s = 0, last_s = 0;
  int64_t edges = 0;
};

}  // namespace

TEST(Quadrature, SimulatedEncoderGivesTheCountsOfAKnownRotation) {
  OpenLoop o;
  // Full drive up from rest for 0.25 s: theta = w (T - tau (1 - e^(-T/tau))) = 0.801348 rad.
  o.chip.set(0, true);
  o.chip.set(1, true);
  o.run(0.25);
  const double up_rad = 4 * (0.25 - 0.05 * (1 - std::exp(-5.0)));
  EXPECT_NEAR(o.chip.positionRad(0), up_rad, 1e-9);
  EXPECT_EQ(o.decoder.count(), 801);
  EXPECT_EQ(o.edges, 801);
  // Full drive down for 0.5 s from w0 = 4 (1 - e^-5): theta = -0.800018 rad, count -801.
  o.chip.set(0, false);
  o.run(0.75);
  const double w0 = 4 * (1 - std::exp(-5.0));
  const double down_rad = up_rad - 4 * 0.5 + (w0 + 4) * 0.05 * (1 - std::exp(-10.0));
  EXPECT_NEAR(o.chip.positionRad(0), down_rad, 1e-9);
  EXPECT_EQ(o.decoder.count(), -801);
  EXPECT_EQ(o.decoder.count(), static_cast<int64_t>(std::floor(down_rad * 1000)));
  // Every count passed gives one edge, none lost: on reversing, the shaft first runs on up to
  // its peak (speed 0 at t* = tau ln((w0 + 4) / 4)), then down.
  const double t_peak_s = 0.05 * std::log((w0 + 4) / 4);
  const double peak_rad =
      up_rad - 4 * t_peak_s + (w0 + 4) * 0.05 * (1 - std::exp(-t_peak_s / 0.05));
  EXPECT_NEAR(o.chip.maxPositionRad(0), peak_rad, 1e-6);
  const int64_t peak_count = static_cast<int64_t>(std::floor(peak_rad * 1000));  // 862
  EXPECT_EQ(o.edges, peak_count + (peak_count + 801));
  EXPECT_EQ(o.decoder.illegal(), 0);
}

TEST(Quadrature, ALostEdgeIsAnIllegalTransition) {
  OpenLoop o;
  o.chip.set(0, true);
  o.chip.set(1, true);
  o.run(0.1);
  // A repeated edge at A's present level: what a lost opposite edge looks like.
  o.chip.injectEvent(2, o.chip.level(2));
  o.run(0.2);
  EXPECT_EQ(o.decoder.illegal(), 1);
  EXPECT_EQ(o.decoder.count(), static_cast<int64_t>(std::floor(o.chip.positionRad(0) * 1000)));
}
