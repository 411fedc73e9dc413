#include "core/analysis.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

namespace mjstepper {
namespace {

// A known decaying tone: the estimators recover its frequency, amplitude, phase and damping.
TEST(Analysis, RecoversFrequencyPhaseAndDamping) {
  const double f = 141.6, zeta = 0.0156, wn = 2 * std::numbers::pi * f;
  const double wd = wn * std::sqrt(1 - zeta * zeta);
  std::vector<double> t, x, tone;
  for (int k = 0; k < 20000; ++k) {
    t.push_back(k * 1e-5);
    x.push_back(std::exp(-zeta * wn * t.back()) * std::cos(wd * t.back()));
    tone.push_back(0.3 + 2.0 * std::cos(wn * t.back() + 0.4));
  }
  // Crossing interpolation on 700 samples per period: 1e-4 relative.
  EXPECT_NEAR(CrossingFrequency(t, x), wd / (2 * std::numbers::pi), 1e-4 * f);
  // Peaks on a 10 µs grid: each peak's sampling error is ≤ (wd·5e-6)²/2 ≈ 1e-5 relative.
  EXPECT_NEAR(DampingRatioFromPeaks(x), zeta, 1e-3 * zeta * 10);
  const Tone fit = FitTone(t, tone, f);
  EXPECT_NEAR(fit.amplitude, 2.0, 1e-9);
  EXPECT_NEAR(fit.phase, 0.4, 1e-9);
  EXPECT_NEAR(fit.offset, 0.3, 1e-9);
}

// A 141.6 Hz tone under a weaker 60 Hz one and a slow drift: the peak is found to the grid's
// parabolic refinement (0.1 Hz on a 0.5 Hz grid over 0.5 s of data).
TEST(Analysis, DominantFrequencyFindsTheStrongestTone) {
  std::vector<double> x;
  for (int k = 0; k < 10000; ++k) {
    const double t = k * 5e-5;
    x.push_back(std::sin(2 * std::numbers::pi * 141.6 * t) +
                0.4 * std::sin(2 * std::numbers::pi * 60 * t) + 3 * t);
  }
  EXPECT_NEAR(DominantFrequency(x, 20000, 20, 400, 0.5), 141.6, 0.1);
}

TEST(Analysis, RmsAndPeakToPeak) {
  const std::vector<double> x = {1, -1, 1, -1, 3};
  EXPECT_DOUBLE_EQ(Rms(x), std::sqrt(13.0 / 5));
  EXPECT_DOUBLE_EQ(PeakToPeak(x), 4.0);
}

}  // namespace
}  // namespace mjstepper
