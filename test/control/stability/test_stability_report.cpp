// What ptz-stability prints and writes (stability_report.hpp) for loops with known figures.
#include <gtest/gtest.h>

#include <string>

#include "control/stability/stability_report.hpp"

namespace pc = ptz::control;

namespace {

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

}  // namespace

TEST(StabilityReport, ThePapersLoopContinuousOnly) {
  const pc::StabilityFigures f = pc::analyseStability({1.7, 0.24, 0.0}, 0.0, {}, 0.0);
  const std::string text = pc::stabilityText(f);
  EXPECT_EQ(text.substr(0, text.find('\n') + 1),
            "open loop G(s) = 1.7 / (1 + 0.24 s) * exp(-s * 0)\n");
  EXPECT_TRUE(contains(text, "gain crossover      omega_g = 5.728 rad/s\n"));
  EXPECT_TRUE(contains(text, "largest delay       tau_max = 0.384 s (continuous)\n"));
  EXPECT_TRUE(contains(text, "at tau = 0 s the continuous loop is stable\n"));
  EXPECT_FALSE(contains(text, "sampled at"));  // no frame rate
  EXPECT_FALSE(contains(text, "smith mode"));
  const std::string json = pc::stabilityJson(f);
  EXPECT_TRUE(contains(json, "\"has_crossover\": true,"));
  EXPECT_TRUE(contains(json, "\"sampled_tau_max_s\": null,"));
  EXPECT_TRUE(contains(json, "\"sampled_stable\": null,"));
  EXPECT_FALSE(contains(json, "\"smith\""));
  EXPECT_EQ(json.back(), '\n');
}

TEST(StabilityReport, AGainOfAtMostOneHasNoCrossoverAndSampledFiguresAtAFrameRate) {
  const pc::StabilityFigures f = pc::analyseStability({0.9, 0.24, 0.5}, 30.0, {}, 0.0);
  const std::string text = pc::stabilityText(f);
  EXPECT_TRUE(contains(text,
                       "|K| <= 1: |G(j w)| < 1 at every frequency, no gain crossover: "
                       "the continuous loop is stable for every delay\n"));
  EXPECT_TRUE(contains(text, "sampled at 30 Hz"));
  EXPECT_TRUE(contains(pc::stabilityJson(f), "\"tau_max_s\": null,"));  // infinite
}

TEST(StabilityReport, TheSmithSensitivityHasItsFifteenCasesAndTheNominalOneIsExact) {
  const pc::StabilityFigures f = pc::analyseStability({1.7, 0.24, 1.0}, 30.0, {}, 1.0);
  ASSERT_EQ(f.smith.size(), 15u);  // K and T x 0.7, 1, 1.3; then tau x 0.8 .. 2
  const pc::SmithCase& nominal = f.smith[4];
  EXPECT_EQ(nominal.k_scale, 1.0);
  EXPECT_EQ(nominal.t_scale, 1.0);
  EXPECT_EQ(nominal.tau_scale, 1.0);
  EXPECT_LT(nominal.f.overshoot, 0.01);
  EXPECT_LT(nominal.f.final_error, 1e-4);
  EXPECT_EQ(f.smith.back().tau_scale, 2.0);
  EXPECT_TRUE(contains(pc::stabilityText(f), "smith mode (Smith predictor"));
  EXPECT_TRUE(contains(pc::stabilityJson(f), "\"smith\": [\n    {\"plant_gain_scale\": 0.7,"));
}
