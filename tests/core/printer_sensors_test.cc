// The resonance test's excitation (resonance_excitation.h) and the virtual ADXL345
// (sensors/adxl345.h), against what they are defined to be.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/resonance_excitation.h"
#include "core/sensors/adxl345.h"

namespace mjstepper {
namespace {

TEST(ResonanceExcitation, SquareWaveAccelerationAtTheRisingFrequencyWithoutDrift) {
  // Klipper's defaults: 5 → 133.33 Hz at 1 Hz/s, 75 mm/s² per Hz. The acceleration, from the
  // velocity's change over one 50 µs step, is ±accel_per_hz·f_n except in a step holding a
  // reversal; the position is never below the start nor beyond accel_per_hz/(16·f_n) (round-off
  // aside), and it is back at the start at the end of every cycle: no drift over the 128 s.
  const ResonanceTestOptions o;
  EXPECT_NEAR(o.Duration(), 128.33, 1e-9);
  ResonanceExcitation e(o);
  const double h = 50e-6;
  long checked = 0, reversals = 0, cycles = 0;
  double lowest = 0, beyond = -1;
  double previous_v = e.Velocity(), previous_f = e.frequency();
  const long n = std::lround(o.Duration() / h);
  for (long k = 0; k < n; ++k) {
    const double x = e.Advance(h);
    const double f = e.frequency();
    if (f != previous_f) ++cycles;
    previous_f = f;
    lowest = std::min(lowest, x);
    beyond = std::max(beyond, x - o.accel_per_hz / (16 * f));
    const double v = e.Velocity();
    const double a = (v - previous_v) / h;
    previous_v = v;
    if (std::abs(std::abs(a) - o.accel_per_hz * f) < 1e-6 * o.accel_per_hz * f) {
      ++checked;
    } else {
      ++reversals;  // a step holding a reversal, or a cycle's start
    }
  }
  // About ∫f dt = 5·128.33 + 128.33²/2 = 8876 cycles, three reversals or starts each.
  EXPECT_NEAR(cycles, o.min_freq * o.Duration() + 0.5 * o.Duration() * o.Duration(), 70);
  EXPECT_LE(reversals, 3 * (cycles + 1));
  EXPECT_EQ(checked + reversals, n);
  EXPECT_GT(lowest, -1e-12);  // m
  EXPECT_LT(beyond, 1e-12);   // m beyond accel_per_hz/(16·f_n)
  EXPECT_GT(beyond, -1e-6);   // and it gets there
}

TEST(ResonanceExcitation, OptionsOutsideTheirRangesAreNamed) {
  ResonanceTestOptions o;
  o.max_freq = 2;  // below min_freq
  EXPECT_THROW(Validate(o), std::invalid_argument);
  o = {};
  o.hz_per_sec = NAN;
  try {
    Validate(o);
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("hz_per_sec"), std::string::npos);
  }
}

TEST(Adxl345, SamplesAtItsRateWithItsNoiseResolutionAndRange) {
  // 10 s of a constant (0.5, −1.0, 9.80665) m/s² fed in 50 µs pieces: 32 000 samples 1/3200 s
  // apart; each a multiple of 3.9 mg; the mean the input to a tenth of an LSB; the noise RMS
  // density·√(rate/2) (11.6 mg on x and y, 17.2 mg on z) within 3 % (its estimate over 32 000
  // samples scatters by 0.4 %, and rounding to 3.9 mg adds LSB²/12).
  Adxl345 adxl({});
  std::vector<AccelSample> out;
  const std::array<double, 3> a = {0.5, -1.0, kStandardGravity};
  for (long k = 0; k < 200000; ++k) adxl.Add(k * 50e-6, (k + 1) * 50e-6, a, &out);
  ASSERT_EQ(out.size(), 32000u);
  EXPECT_NEAR(out[1].time - out[0].time, 1 / 3200.0, 1e-12);
  const double lsb = 0.0039 * kStandardGravity;
  for (int i = 0; i < 3; ++i) {
    double mean = 0, square = 0;
    for (const AccelSample& s : out) {
      EXPECT_NEAR(s.accel[i] / lsb, std::round(s.accel[i] / lsb), 1e-9);
      mean += s.accel[i] / out.size();
    }
    for (const AccelSample& s : out) square += std::pow(s.accel[i] - mean, 2) / out.size();
    const double expected =
        std::sqrt(std::pow(adxl.options().noise_density[i], 2) * 1600 + lsb * lsb / 12);
    EXPECT_NEAR(mean, a[i], 0.1 * lsb) << i;
    EXPECT_NEAR(std::sqrt(square), expected, 0.03 * expected) << i;
  }
  // Beyond ±16 g the part saturates.
  Adxl345 hit({});
  std::vector<AccelSample> clipped;
  hit.Add(0, 0.01, {300.0, -300.0, 0.0}, &clipped);
  ASSERT_FALSE(clipped.empty());
  EXPECT_DOUBLE_EQ(clipped[0].accel[0], 16 * kStandardGravity);
  EXPECT_DOUBLE_EQ(clipped[0].accel[1], -16 * kStandardGravity);
}

}  // namespace
}  // namespace mjstepper
