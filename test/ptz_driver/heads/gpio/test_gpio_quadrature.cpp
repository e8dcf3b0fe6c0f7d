// Quadrature decoding (x4 state table) against hand-made sequences, and the simulated encoder
// counted through the decoder: known counts for a known rotation of the simulated motor, both
// ways; lost edges counted as illegal transitions; the edges of lines read one after the other
// merged in time order.
#include <gtest/gtest.h>

#include <cmath>

#include "ptz_driver/emulators/emulated_gpio_chip.hpp"
#include "ptz_driver/heads/gpio/quadrature.hpp"
#include "ptz_driver/io/gpio_event_merger.hpp"

using ptz::driver::EmulatedAxisSpec;
using ptz::driver::EmulatedGpioChip;
using ptz::driver::GpioEventMerger;
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
  static EmulatedAxisSpec spec() {
    EmulatedAxisSpec s;
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
  EmulatedGpioChip chip;
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

namespace {

constexpr int kA = 2, kB = 3;

void decode(QuadratureDecoder* d, const std::vector<LineEvent>& events) {
  for (const auto& e : events) d->edge(e.line == kA ? 0 : 1, e.rising, e.time_s);
}

}  // namespace

TEST(GpioEventMerger, AnEdgeQueuedAfterItsLineWasReadIsNotOvertakenByALaterOne) {
  // Up one turn (+4): A rises at 1 ms, B at 2 ms, A falls at 3 ms, B at 4 ms. The first batch
  // takes its cutoff at 2.5 ms and reads line A at 2.6 ms (A's fall is still to come), then
  // line B at 4.5 ms (both of B's edges are there).
  GpioEventMerger m;
  std::vector<LineEvent> batch1, batch2;
  m.add({kA, true, 1e-3});
  m.add({kB, true, 2e-3});
  m.add({kB, false, 4e-3});
  m.take(2.5e-3, &batch1);
  ASSERT_EQ(batch1.size(), 2u);
  EXPECT_EQ(batch1[0].line, kA);
  EXPECT_EQ(batch1[1].line, kB);
  EXPECT_EQ(m.pending(), 1u);  // B's fall, after the cutoff
  // The next batch (cutoff 5 ms) reads A's fall: it comes out before B's fall, held back.
  m.add({kA, false, 3e-3});
  m.take(5e-3, &batch2);
  ASSERT_EQ(batch2.size(), 2u);
  EXPECT_EQ(batch2[0].line, kA);
  EXPECT_DOUBLE_EQ(batch2[0].time_s, 3e-3);
  EXPECT_EQ(batch2[1].line, kB);
  EXPECT_DOUBLE_EQ(batch2[1].time_s, 4e-3);
  EXPECT_EQ(m.pending(), 0u);
  QuadratureDecoder d;
  d.reset(false, false);
  decode(&d, batch1);
  decode(&d, batch2);
  EXPECT_EQ(d.count(), 4);  // each batch merely sorted: B falls before A, +1 +1 -1 -1 = 0
  EXPECT_EQ(d.illegal(), 0);
}

TEST(GpioEventMerger, DeliversUpToTheCutoffInTimeOrderKeepingEachLinesOrder) {
  GpioEventMerger m;
  std::vector<LineEvent> out;
  m.take(1.0, &out);  // nothing pending: nothing
  EXPECT_TRUE(out.empty());
  // Two lines read one after the other, each in order; two of A's edges at the same time.
  for (const LineEvent& e : {LineEvent{kA, true, 0.1}, LineEvent{kA, false, 0.3},
                             LineEvent{kA, true, 0.3}, LineEvent{kA, false, 0.7}}) {
    m.add(e);
  }
  for (const LineEvent& e : {LineEvent{kB, true, 0.2}, LineEvent{kB, false, 0.5}}) m.add(e);
  m.take(0.5, &out);  // at the cutoff is delivered
  const double times[] = {0.1, 0.2, 0.3, 0.3, 0.5};
  const int lines[] = {kA, kB, kA, kA, kB};
  ASSERT_EQ(out.size(), 5u);
  for (size_t i = 0; i < out.size(); ++i) {
    EXPECT_DOUBLE_EQ(out[i].time_s, times[i]) << i;
    EXPECT_EQ(out[i].line, lines[i]) << i;
  }
  EXPECT_FALSE(out[2].rising);  // A's fall, then its rise: as read
  EXPECT_TRUE(out[3].rising);
  out.clear();
  m.take(0.6, &out);  // A's 0.7 still waits
  EXPECT_TRUE(out.empty());
  m.take(0.7, &out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_DOUBLE_EQ(out[0].time_s, 0.7);
}
