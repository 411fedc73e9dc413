#include "core/command_profile.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

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

// Issue 17: a STEP/DIR stream as a motion controller emits it, one step time per line.
TEST(StepTimes, CountAndRateFollowTheList) {
  std::istringstream text(
      "# three steps forward, one back\n0.001\n0.002 +1\n\n0.004 1\n0.005 -1\n");
  const StepTimes s = StepTimes::Parse(text, "moves.txt");
  EXPECT_EQ(s.size(), 4u);
  EXPECT_EQ(s.Count(0.0), 0);
  EXPECT_EQ(s.Count(0.001), 1);  // a step at t counts from t on
  EXPECT_EQ(s.Count(0.0039), 2);
  EXPECT_EQ(s.Count(0.0045), 3);
  EXPECT_EQ(s.Count(1.0), 2);
  EXPECT_NEAR(s.Rate(0.003), 1 / 0.002, 1e-9);  // from the step at 2 ms to the one at 4 ms
  EXPECT_NEAR(s.Rate(0.0045), -1 / 0.001, 1e-9);
  EXPECT_EQ(s.Rate(0.0), 0);
  // Two steps at one time (a motion controller's doubled pulse): both count in the rate.
  std::istringstream doubled("0.001\n0.002\n0.002\n");
  EXPECT_NEAR(StepTimes::Parse(doubled, "d.txt").Rate(0.0015), 2 / 0.001, 1e-9);
}

TEST(StepTimes, BadListsNameTheFileAndLine) {
  auto error = [](const std::string& body) -> std::string {
    std::istringstream text(body);
    try {
      StepTimes::Parse(text, "moves.txt");
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_THAT(error("0.1\n0.05\n"),
              HasSubstr("moves.txt:2: \"0.05\": step times must not decrease"));
  EXPECT_THAT(error("0.1 2\n"), HasSubstr("moves.txt:1"));
  EXPECT_THAT(error("nan\n"), HasSubstr("[0, 1e6]"));
  EXPECT_THAT(error("-1\n"), HasSubstr("[0, 1e6]"));
  EXPECT_THAT(error("0.1 1 x\n"), HasSubstr("at most a direction"));
  EXPECT_THAT(error("# nothing\n"), HasSubstr("no step times"));
  EXPECT_THAT(error("0.1\n"), ::testing::IsEmpty());
}

TEST(CommandProfile, StepListDrivesTheCountFromTheStartAngle) {
  const std::string path = ::testing::TempDir() + "/steps.txt";
  {
    std::ofstream out(path);
    for (int k = 1; k <= 100; ++k) out << k * 1e-3 << "\n";  // 1000 microsteps/s for 0.1 s
  }
  const CommandProfile p = CommandProfile::Parse("steps(" + path + ")");
  EXPECT_TRUE(p.step_list());
  const double step = kTwoPi / (4 * 50 * 16);  // rad per microstep
  // The start angle's count, 7, plus the list's count at the step's end.
  EXPECT_EQ(p.ControlForStep(0.0495, 1e-3, InputMode::kSteps, 7 * step, step), 7 + 50);
  EXPECT_NEAR(p.Speed(0.05, step), 1000 * step, 1e-9);
  EXPECT_THAT(
      [] {
        try {
          CommandProfile::Parse("steps(/nonexistent/moves.txt)");
        } catch (const std::invalid_argument& e) {
          return std::string(e.what());
        }
        return std::string();
      }(),
      HasSubstr("cannot be read"));
}

}  // namespace
}  // namespace mjstepper
