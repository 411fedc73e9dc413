// Open-loop harmonic damping, T(13): the setpoint and what it cancels.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/drive.h"
#include "core/motor.h"
#include "core/presets.h"

namespace mjstepper {
namespace {

DriveConfig Damped(std::vector<DetentHarmonic> damping) {
  DriveConfig c;
  c.motor = FindPreset("tsui2009")->motor;
  c.controller = IdealCurrent{.setpoint = {.hold_current = 1.9, .damping = {std::move(damping)}}};
  return c;
}

// With every harmonic compensated with the true values and the rotor on its command (δ = 0),
// iq* = (1/Km)·Σ Kdh·sin(h·x + φh) makes τm = Km·iq* = −τdet: the net torque is zero at every
// angle (S-12 with δ = 0; round-off only).
TEST(Damping, AllHarmonicsCancelTheDetentOnTheCommand) {
  const Drive drive(Damped(FindPreset("tsui2009")->motor.detent));
  for (int k = 0; k < 200; ++k) {
    const double theta = k * 1e-4;  // rad, over 0.8 electrical cycles
    const DriveState s = drive.Rest(0.0, theta, theta);
    EXPECT_NEAR(drive.Torque(s, theta), 0.0, 1e-15) << "theta " << theta;
  }
}

// One harmonic switched on cancels only itself: what is left is the other two.
TEST(Damping, OneHarmonicLeavesTheOthers) {
  const MotorParams motor = FindPreset("tsui2009")->motor;
  const Drive drive(Damped({motor.detent[1]}));  // h = 2 only
  const double theta = 0.0037;
  const DriveState s = drive.Rest(0.0, theta, theta);
  const double x = 50 * theta;
  const double left = -0.006 * std::sin(4 * x) - 0.011 * std::sin(x + std::numbers::pi / 2);
  EXPECT_NEAR(drive.Torque(s, theta), left, 1e-15);
}

// The damping uses its own estimates: a 10 % wrong amplitude leaves 10 % of that harmonic.
TEST(Damping, UsesItsOwnEstimates) {
  const MotorParams motor = FindPreset("tsui2009")->motor;
  DetentHarmonic estimate = motor.detent[1];
  estimate.amplitude *= 1.1;
  const Drive drive(Damped({estimate}));
  const double theta = 0.0011;
  const DriveState s = drive.Rest(0.0, theta, theta);
  const double x = 50 * theta;
  const double left = -0.006 * std::sin(4 * x) - 0.011 * std::sin(x + std::numbers::pi / 2) +
                      0.1 * 0.014 * std::sin(2 * x + std::numbers::pi);
  EXPECT_NEAR(drive.Torque(s, theta), left, 1e-15);
}

}  // namespace
}  // namespace mjstepper
