// GPIO lines as the DC-motor heads use them: outputs (direction, PWM enable), inputs with edge
// events and timestamps (encoder A/B, limit switches). Two providers: libgpiod 1.6 on a real
// chip (openGpiodChip) and a simulated head for tests (emulated_gpio_chip.hpp).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace ptz::driver {

struct LineEvent {
  int line = -1;
  bool rising = false;  // the level after the edge
  double time_s = 0;    // when the edge happened, on gpioClockS()
};

// The clock of line events and of the heads' control threads: CLOCK_MONOTONIC in seconds (the
// wall clock may jump, and a PWM period must not stretch with it).
double gpioClockS();
// Sleeps until t_s on that clock (to the deadline, not for a while: periods do not drift).
void gpioSleepUntilS(double t_s);

// The lines of one DC-motor axis: the bridge's, the encoder's and the limit switches' (-1: none).
struct AxisLines {
  int dir = -1, dir2 = -1, enable = -1;  // dir2: -1 for a DIR/PWM (PH/EN) bridge
  int encoder_a = -1, encoder_b = -1;
  int limit_min = -1, limit_max = -1;  // closed = low (switch to ground, pull-up)
};

enum class Bias { kAsIs, kPullUp, kDisabled };

class GpioLines {
 public:
  virtual ~GpioLines() = default;

  // `name` is the parameter that chose the line, so that errors name it. Throws ConfigError
  // naming the chip, the line and `name` when the line cannot be had.
  // Driven to its idle level at once, and set to it again before the lines are released (what a
  // released line does then is the kernel driver's: some return it to an input, so pull a
  // trigger input to its idle level outside).
  virtual void requestOutput(int line, const std::string& name, bool idle_high) = 0;
  void requestOutput(int line, const std::string& name) { requestOutput(line, name, false); }
  virtual void requestEvents(int line, Bias bias, const std::string& name) = 0;

  virtual void set(int line, bool high) = 0;
  virtual bool get(int line) = 0;
  // Appends the edges seen on event lines since the last call, oldest first, also across calls
  // (a real chip holds back the last 0.2 ms for that: gpio_event_merger.hpp).
  virtual void readEvents(std::vector<LineEvent>* events) = 0;
  // Failed reads and writes so far (the control loop keeps running; the head reports them).
  virtual int64_t ioErrors() const { return 0; }
};

// Opens a chip by name ("gpiochip0"), number ("0"), path ("/dev/gpiochip0") or label; throws
// ConfigError naming the chip and `param` (the parameter that chose it) when there is no such
// GPIO chip. `consumer` labels the lines the kernel hands out (gpioinfo shows it).
std::unique_ptr<GpioLines> openGpiodChip(const std::string& chip, const std::string& consumer,
                                         const std::string& param = "gpio_chip");

}  // namespace ptz::driver
