// ptz-driver's stop on exit (HeadsStop): every head stopped once, on the normal path and when an
// exception leaves the driver's loop, also when one head's stop fails or throws.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "ptz_driver/heads/common/heads_stop.hpp"

using namespace ptz::driver;

namespace {
// A head that counts its stops; confirms them or not, or throws.
class CountingHead : public PtzHead {
 public:
  enum class Stop { kConfirmed, kUnconfirmed, kThrows };
  explicit CountingHead(Stop how = Stop::kConfirmed) : how_(how) {}
  void start(double) override {}
  void command(const ptz::PtzPose&, double) override {}
  bool stop(double now_s, double timeout_s) override {
    ++stops;
    last_now_s = now_s;
    last_timeout_s = timeout_s;
    if (how_ == Stop::kThrows) throw std::runtime_error("write failed");
    return how_ == Stop::kConfirmed;
  }
  void inquire(double, double) override {}
  void receive(double) override {}
  std::optional<ptz::PtzPose> measured() const override { return std::nullopt; }
  double measuredAtS() const override { return 0; }
  int fd() const override { return -1; }
  HeadStats& stats() override { return stats_; }

  int stops = 0;
  double last_now_s = 0, last_timeout_s = 0;

 private:
  Stop how_;
  HeadStats stats_;
};
}  // namespace

TEST(HeadsStop, StopsEveryHeadOnceOnTheNormalPath) {
  CountingHead left, right;
  std::vector<size_t> unconfirmed;
  {
    HeadsStop stop(
        {&left, &right}, 0.3, [] { return 12.5; }, [&](size_t i) { unconfirmed.push_back(i); });
    EXPECT_EQ(left.stops, 0) << "not before the exit";
    stop.stop();
    EXPECT_EQ(left.stops, 1);
    EXPECT_EQ(right.stops, 1);
    stop.stop();
  }  // and not again when it goes out of scope
  EXPECT_EQ(left.stops, 1);
  EXPECT_EQ(right.stops, 1);
  EXPECT_EQ(left.last_now_s, 12.5);
  EXPECT_EQ(left.last_timeout_s, 0.3);
  EXPECT_TRUE(unconfirmed.empty());
}

TEST(HeadsStop, StopsEveryHeadWhenAnExceptionLeavesTheLoop) {
  CountingHead left, right;
  auto run = [&] {
    HeadsStop stop(
        {&left, &right}, 0.3, [] { return 0.0; }, [](size_t) {});
    throw std::runtime_error("lcm failed");  // before the normal path's stop()
  };
  EXPECT_THROW(run(), std::runtime_error);
  EXPECT_EQ(left.stops, 1);
  EXPECT_EQ(right.stops, 1);
}

TEST(HeadsStop, OneHeadFailingDoesNotKeepTheOtherMoving) {
  CountingHead throws(CountingHead::Stop::kThrows), silent(CountingHead::Stop::kUnconfirmed), fine;
  std::vector<size_t> unconfirmed;
  {
    HeadsStop stop(
        {&throws, &silent, &fine}, 0.3, [] { return 0.0; },
        [&](size_t i) { unconfirmed.push_back(i); });
  }
  EXPECT_EQ(throws.stops + silent.stops + fine.stops, 3);
  EXPECT_EQ(unconfirmed, (std::vector<size_t>{0, 1}));
}
