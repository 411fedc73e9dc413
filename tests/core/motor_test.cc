// The motor equations of SPEC §1 against their closed forms: H1, H2, H5.
#include "core/motor.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "core/analysis.h"
#include "core/presets.h"
#include "core/units.h"

namespace mjstepper {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

MotorParams Tsui() { return FindPreset("tsui2009")->motor; }

// H1: two phases at the rated 3 A give T_H = √2·Km·Ir = 1.2728 N·m (datasheet 1.27 N·m). The
// maximum of τm over the rotor angle is found on a 1e-5 rad (electrical) grid: the grid error is
// (Δx)²/8 relative, 1e-11, so the bound here is H1's own ±0.5 % of the paper's 1.273.
TEST(Motor, H1_HoldingTorque) {
  const MotorParams p = Tsui();
  const PhaseVector two_phases(3.0, 3.0);  // ia = ib = 3 A
  double peak = 0;
  for (double x = 0; x < kTwoPi; x += 1e-5) {
    peak = std::max(peak, std::abs(ElectromagneticTorque(p, x / p.rotor_teeth, two_phases)));
  }
  EXPECT_NEAR(peak, std::sqrt(2.0) * 0.3 * 3.0, 1e-9);
  EXPECT_NEAR(peak, 1.273, 0.005 * 1.273);
}

// H2: a current vector of 1.9 A held at x = 0 resists a displacement with T' = Nr·Km·I =
// 28.5 N·m/rad (detent off). Central difference with Δθ = 1e-6 rad: truncation (Nr·Δθ)²/6 ≈ 4e-10
// relative, round-off ≈ 1e-16·τ/Δθ ≈ 1e-10; the bound 1e-8 relative is far inside H2's ±1 %.
TEST(Motor, H2_StaticStiffness) {
  const MotorParams p = Tsui();
  const PhaseVector hold(1.9, 0.0);
  const double dtheta = 1e-6;
  const double stiffness =
      -(ElectromagneticTorque(p, dtheta, hold) - ElectromagneticTorque(p, -dtheta, hold)) /
      (2 * dtheta);
  EXPECT_NEAR(stiffness, 28.5, 28.5 * 1e-8);
}

// H5: back-EMF at 1920 r/min has amplitude Km·ω = 60.3 V at Nr·n/60 = 1600 Hz. Sampled over 10
// electrical periods at 1 MHz, fitted as a tone; the fit is exact for a pure sinusoid (1e-9).
TEST(Motor, H5_BackEmfAmplitudeAndFrequency) {
  const MotorParams p = Tsui();
  const double omega = RpmToRadPerSec(1920);
  std::vector<double> t, ea, eb;
  for (int k = 0; k < 6250; ++k) {
    t.push_back(k * 1e-6);
    const PhaseVector e = BackEmf(p, omega * t.back(), omega);
    ea.push_back(e.real());
    eb.push_back(e.imag());
  }
  const double f = CrossingFrequency(t, ea);
  EXPECT_NEAR(f, 1600.0, 1600.0 * 1e-3);  // crossing interpolation error at 625 samples/period
  const Tone a = FitTone(t, ea, 1600.0);
  const Tone b = FitTone(t, eb, 1600.0);
  EXPECT_NEAR(a.amplitude, 60.3, 0.01 * 60.3);
  std::printf("H5: %.3f V at %.2f Hz\n", a.amplitude, f);
  EXPECT_NEAR(a.amplitude, 0.3 * omega, 1e-9 * a.amplitude);
  EXPECT_NEAR(b.amplitude, a.amplitude, 1e-9 * a.amplitude);
  // ea = −Km·ω·sin x = Km·ω·cos(x + π/2);  eb = Km·ω·cos x.
  EXPECT_NEAR(a.phase, std::numbers::pi / 2, 1e-6);
  EXPECT_NEAR(b.phase, 0.0, 1e-6);
}

// S-5 with Tsui's harmonics: the sum of −Kdh·sin(h·x + φh) term by term, at an arbitrary angle.
TEST(Motor, DetentTorqueIsTheSumOfItsHarmonics) {
  const MotorParams p = Tsui();
  const double theta = 0.0123;  // rad
  const double x = 50 * theta;
  const double expected = -0.006 * std::sin(4 * x) - 0.014 * std::sin(2 * x + std::numbers::pi) -
                          0.011 * std::sin(x + std::numbers::pi / 2);
  EXPECT_NEAR(DetentTorque(p, theta), expected, 1e-15);
}

// S-9/S-10: Park and its inverse are each other's inverse; S-11: with ψ = x, τm = Km·iq.
TEST(Motor, ParkRoundTripAndTorqueIsKmTimesIq) {
  const MotorParams p = Tsui();
  const PhaseVector i(1.3, -0.4);
  const double theta = 0.37;
  const double x = ElectricalAngle(p, theta);
  EXPECT_NEAR(std::abs(FromDq(ToDq(i, x), x) - i), 0.0, 1e-15);
  EXPECT_NEAR(ElectromagneticTorque(p, theta, i), p.torque_constant * ToDq(i, x).imag(), 1e-15);
}

TEST(Motor, ValidateNamesFieldAndValue) {
  MotorParams p = Tsui();
  p.inductance = 0;
  try {
    Validate(p);
    FAIL() << "zero inductance accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("inductance"), HasSubstr("= 0")));
  }
  p = Tsui();
  p.resistance = std::nan("");
  EXPECT_THROW(Validate(p), std::invalid_argument);
}

}  // namespace
}  // namespace mjstepper
