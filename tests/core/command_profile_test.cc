#include "core/command_profile.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "core/units.h"

namespace mjstepper {
namespace {

using ::testing::HasSubstr;

TEST(CommandProfile, RampSpeedAndAngleAgree) {
  const CommandProfile p = CommandProfile::Parse("ramp(0rpm, 200rpm, 0.8s)");
  const double w = RpmToRadPerSec(200);
  EXPECT_NEAR(p.Speed(0.4), w / 2, 1e-12);
  EXPECT_NEAR(p.Speed(1.0), w, 1e-12);
  EXPECT_NEAR(p.Angle(0.8), 0.5 * w * 0.8, 1e-12);
  EXPECT_NEAR(p.Angle(1.0), 0.5 * w * 0.8 + w * 0.2, 1e-12);
  // Velocity input: the mean speed over the step, so the drive's integral meets Angle exactly.
  EXPECT_NEAR(p.ControlForStep(0.3, 1e-3, InputMode::kVelocity, 0.0) * 1e-3,
              p.Angle(0.301) - p.Angle(0.3), 1e-15);
}

TEST(CommandProfile, TrapezoidComesToRestAtItsDistance) {
  const CommandProfile p = CommandProfile::Parse("trapezoid(60rpm, 0.2s, 0.5s, 0.3s)");
  const double w = kTwoPi;  // 60 r/min
  EXPECT_NEAR(p.Speed(0.5), w, 1e-12);
  EXPECT_NEAR(p.Speed(2.0), 0.0, 1e-12);
  EXPECT_NEAR(p.Angle(2.0), w * (0.1 + 0.5 + 0.15), 1e-12);
}

TEST(CommandProfile, AngleProfilesAreAbsolute) {
  const CommandProfile hold = CommandProfile::Parse("constant(90deg)");
  EXPECT_TRUE(hold.absolute_angle());
  EXPECT_NEAR(hold.ControlForStep(0.1, 1e-3, InputMode::kPosition, 5.0), kTwoPi / 4, 1e-12);
  const CommandProfile ramp = CommandProfile::Parse("ramp(0rad, 1rad, 2s)");
  EXPECT_NEAR(ramp.Angle(1.0), 0.5, 1e-12);
  EXPECT_NEAR(ramp.Speed(1.0), 0.5, 1e-12);
}

TEST(CommandProfile, BadTextNamesTheProblem) {
  for (const char* text : {"ramp(0rpm, 200rpm)", "constant(100)", "wobble(1rpm)",
                           "ramp(0rpm, 1rad, 1s)", "constant(1rpm) junk"}) {
    try {
      CommandProfile::Parse(text);
      FAIL() << text << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr(text)) << e.what();
    }
  }
}

}  // namespace
}  // namespace mjstepper
