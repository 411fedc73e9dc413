// Encoder (S-16) and velocity estimator (S-17), and H15.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "core/analysis.h"
#include "core/sensors/encoder.h"
#include "core/sensors/velocity_estimator.h"
#include "core/units.h"

namespace mjstepper {
namespace {

TEST(Sensors, EncoderQuantisesDown) {
  const double q = kTwoPi / 4000;
  EXPECT_EQ(EncoderAngle(2.5 * q, 4000), 2 * q);
  EXPECT_EQ(EncoderAngle(-0.5 * q, 4000), -q);
  EXPECT_EQ(EncoderAngle(0.123, 0), 0.123);  // ideal
}

// H15: at 20 kHz one count of a 4000-count encoder is a velocity quantum of 300 r/min: a single
// count between two ticks moves the raw backward difference by 2π/4000/50 µs = 31.4 rad/s.
TEST(Sensors, H15_VelocityQuantumIs300Rpm) {
  const VelocityEstimator estimator{.period = 50e-6, .cutoff = 32.0};
  const double q = kTwoPi / 4000;
  double previous = EncoderAngle(0.0, 4000), estimate = 0;
  estimator.Update(EncoderAngle(q * 1.0000001, 4000), &previous, &estimate);
  const double raw = estimate / estimator.Gain();  // one step from zero: w = a·raw
  EXPECT_NEAR(RadPerSecToRpm(raw), 300.0, 1e-6);
}

// H15: the estimate's corner is 32 Hz. The angle is a sinusoid (ideal encoder); after the
// transient the estimate's amplitude over the true speed's is 1/√2 at 32 Hz (the backward
// difference's own lag and gain at 32 Hz are 1 − 4e-5: the bound is 1 %), and near 1 at 1 Hz.
TEST(Sensors, H15_VelocityCornerIs32Hz) {
  const VelocityEstimator estimator{.period = 50e-6, .cutoff = 32.0};
  auto gain_at = [&](double f) {
    const double w = kTwoPi * f, amplitude = 1e-3;  // rad
    double previous = 0, estimate = amplitude * w;
    std::vector<double> t, est;
    const int n = static_cast<int>(std::lround(2.0 / 50e-6));
    for (int k = 1; k <= n; ++k) {
      const double tk = k * 50e-6;
      estimator.Update(amplitude * std::sin(w * tk), &previous, &estimate);
      if (tk > 1.0) {
        t.push_back(tk);
        est.push_back(estimate);
      }
    }
    return FitTone(t, est, f).amplitude / (amplitude * w);
  };
  EXPECT_NEAR(gain_at(32.0), 1 / std::sqrt(2.0), 0.01 / std::sqrt(2.0));
  EXPECT_NEAR(gain_at(1.0), 1.0, 1e-3);
}

}  // namespace
}  // namespace mjstepper
