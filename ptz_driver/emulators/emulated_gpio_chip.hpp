// A GPIO chip wired to simulated DC-motor axes, for tests and for trying a configuration without
// hardware: each axis's speed follows the bridge's drive (enable high: +-max speed by the
// direction line; low: 0) as a first-order lag, its encoder emits the A/B edges of every count
// the shaft passes, in order and with the time of the crossing, and its limit switches pull
// their lines low at and beyond known positions. Mechanical end stops hold the shaft.
#pragma once

#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <vector>

#include "ptz_driver/io/gpio_lines.hpp"

namespace ptz::driver {

struct EmulatedAxisSpec {
  AxisLines lines;
  double counts_per_rad = 1000;                        // x4 counts
  double max_speed_rad_s = 4;                          // at a duty of 1
  double time_constant_s = 0.05;                       // of the speed
  double start_rad = 0;                                // where the shaft is at power-up
  double min_switch_rad = -1.1, max_switch_rad = 1.1;  // closed at or beyond
  double min_stop_rad = -1.2, max_stop_rad = 1.2;      // mechanical end stops
  bool reversed = false;  // the motor's leads swapped: it turns toward min when driven to max
};

class EmulatedGpioChip : public GpioLines {
 public:
  explicit EmulatedGpioChip(std::vector<EmulatedAxisSpec> axes, double start_s = 0,
                            double substep_s = 10e-6);

  using GpioLines::requestOutput;
  void requestOutput(int line, const std::string& name, bool idle_high) override;
  void requestEvents(int line, Bias bias, const std::string& name) override;
  void set(int line, bool high) override;
  bool get(int line) override;
  void readEvents(std::vector<LineEvent>* events) override;
  int64_t ioErrors() const override;

  // An output wired to nothing of the simulation, only watched (a camera trigger line).
  void addOutput(int line);
  // Moves the simulation on to t_s with the outputs as they are.
  void advanceTo(double t_s);
  // With a clock, every call above first advances to clock() (a head on the wall clock).
  void useClock(std::function<double()> clock);

  double nowS() const;
  double positionRad(size_t axis) const;  // the true shaft position
  double speedRadS(size_t axis) const;
  double maxPositionRad(size_t axis) const;  // the furthest it has been, each way
  double minPositionRad(size_t axis) const;
  bool level(int line) const;
  double highTimeS(int line) const;     // how long an output has been high in all
  int64_t risingEdges(int line) const;  // of an output
  // Both of an output's tallies and the simulation time they are at, taken together (a head
  // on its own thread may step between separate calls).
  struct OutputTally {
    double at_s = 0, high_s = 0;
    int64_t rising = 0;
  };
  OutputTally tally(int line) const;
  // Moves a switch (an obstacle, a badly placed switch).
  void setSwitch(size_t axis, bool max_end, double position_rad);
  // An edge as the kernel would report it now, whatever the line's level (a glitch).
  void injectEvent(int line, bool rising);

 private:
  struct Line {
    bool requested = false, output = false, level = false;
    double high_s = 0;
    int64_t rising = 0;
  };
  struct Axis {
    EmulatedAxisSpec spec;
    double position_rad = 0, speed_rad_s = 0, max_rad = 0, min_rad = 0;
  };
  void tick();
  void advance(double t_s);
  void integrate(Axis& a, double h_s);
  Line& line(int offset, const std::string& name);

  mutable std::mutex mutex_;
  std::vector<Axis> axes_;
  std::map<int, Line> lines_;
  std::deque<LineEvent> events_;
  std::vector<LineEvent> step_events_;
  std::function<double()> clock_;
  double now_s_, substep_s_;
  int64_t io_errors_ = 0;
};

}  // namespace ptz::driver
