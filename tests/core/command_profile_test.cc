#include "core/command_profile.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/units.h"

namespace mjstepper {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

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
  // A line is quoted by its start only, with no control character echoed to a terminal, and a
  // line past kMaxStepLine is refused.
  const std::string escape = error("\x1b[2J" + std::string(100, 'x') + "\n");
  EXPECT_THAT(escape, HasSubstr("\"?[2Jxxx"));
  EXPECT_THAT(escape, Not(HasSubstr("\x1b")));
  EXPECT_LT(escape.size(), 120u);
  EXPECT_THAT(error(std::string(100000, '1') + "\n"), HasSubstr("a line longer than 256"));
}

// The reader takes regular files only, of a bounded size: a device, a directory or a pipe is
// refused by name before any of it is read (issue 33: `steps(/dev/zero)` read 1.06 GB).
TEST(StepTimes, ReadTakesRegularFilesOnly) {
  auto error = [](const std::string& path) -> std::string {
    try {
      StepTimes::Read(path);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_THAT(error("/dev/zero"), HasSubstr("/dev/zero: not a regular file"));
  EXPECT_THAT(error(::testing::TempDir()), HasSubstr("not a regular file"));
  EXPECT_THAT(error("/nonexistent/steps.txt"), HasSubstr("cannot be read"));
  const std::string path = ::testing::TempDir() + "/read_steps.txt";
  std::ofstream(path) << "0.001\n0.002 -1\n";
  EXPECT_EQ(StepTimes::Read(path).Count(1.0), 0);
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

// Issue 30: a step list's pulses as a driver receives them, each at its own time (the drive's
// step_times): the list itself, and for a shaped list the steps of the shaped count, at the very
// instants it changes. Read back, their count equals the shaped count everywhere on a fine grid,
// and just before and after each of its own steps.
TEST(CommandProfile, PulseTimesAreTheShapedCountsOwnSteps) {
  const std::string path = ::testing::TempDir() + "/pulses.txt";
  {
    std::ofstream out(path);
    for (int k = 1; k <= 200; ++k) out << 0.001 + k * 0.37e-3 << (k > 150 ? " -1" : "") << "\n";
  }
  const double step = kTwoPi / (4 * 50 * 16);  // rad per microstep
  for (const std::string& text : {"steps(" + path + ")", "shaped(steps(" + path + "), zv 40Hz)",
                                  "shaped(steps(" + path + "), ei 55Hz 0.1)"}) {
    const CommandProfile p = CommandProfile::Parse(text);
    const std::optional<StepTimes> pulses = p.PulseTimes();
    ASSERT_TRUE(pulses) << text;
    // The shaped count at t is ControlForStep's at the end of a step ending at t (from count 0).
    auto shaped = [&](double t) {
      return p.ControlForStep(t - 1e-4, 1e-4, InputMode::kSteps, 0.0, step);
    };
    for (double t = 0; t < 0.2; t += 7.3e-6) {
      ASSERT_EQ(pulses->Count(t), shaped(t)) << text << " at " << t;
    }
    // A picosecond either side of each of its steps (at the instant itself the shaped count's
    // t − T_i may round below the list's time by an ulp).
    for (std::size_t k = 0; k < pulses->size(); ++k) {
      const double t = pulses->TimeAt(k);
      EXPECT_EQ(pulses->Count(t + 1e-12), shaped(t + 1e-12)) << text << " after its step " << k;
      EXPECT_EQ(pulses->Count(t - 1e-12), shaped(t - 1e-12)) << text << " before its step " << k;
    }
    EXPECT_EQ(pulses->Count(1.0), 100) << text;  // 150 forward, 50 back
  }
  EXPECT_FALSE(CommandProfile::Parse("constant(10rpm)").PulseTimes());
}

// Linear units on a linear axis (issue 19 item 7): θ = gear·x with the transmission's gear in rad
// per metre. A profile in mm, mm/s, mm/s² gives the very commands of the same profile written by
// hand in rad, rad/s, rad/s² (each value gear·(v·1e-3), printed to 17 digits): bit-identical, for
// every form and through a shaper.
TEST(CommandProfile, LinearUnitsEqualTheRotorUnitsByHand) {
  const double gear = kTwoPi / 0.008;  // rad/m: a lead screw of 8 mm per turn
  auto rad = [gear](double value, double metres) {
    return fmt::format("{:.17g}", gear * (value * metres));
  };
  const std::vector<std::pair<std::string, std::string>> pairs = {
      {"constant(25mm/s)", "constant(" + rad(25, 1e-3) + "rad/s)"},
      {"constant(0.012m/s)", "constant(" + rad(0.012, 1) + "rad/s)"},
      {"constant(12.5mm)", "constant(" + rad(12.5, 1e-3) + "rad)"},
      {"ramp(0mm, 40mm, 0.5s)", "ramp(" + rad(0, 1e-3) + "rad, " + rad(40, 1e-3) + "rad, 0.5s)"},
      {"ramp(0m/s, 0.05m/s, 0.2s)", "ramp(0rad/s, " + rad(0.05, 1) + "rad/s, 0.2s)"},
      {"ramp(0mm/s, 50mm/s, 250mm/s²)",
       "ramp(0rad/s, " + rad(50, 1e-3) + "rad/s, " + rad(250, 1e-3) + "rad/s²)"},
      {"trapezoid(80mm/s, 0.1s, 0.3s, 0.1s)",
       "trapezoid(" + rad(80, 1e-3) + "rad/s, 0.1s, 0.3s, 0.1s)"},
      {"trapezoid(80mm/s, 2m/s^2, 0.3s, 1000mm/s²)", "trapezoid(" + rad(80, 1e-3) + "rad/s, " +
                                                         rad(2, 1) + "rad/s^2, 0.3s, " +
                                                         rad(1000, 1e-3) + "rad/s²)"},
      {"shaped(trapezoid(80mm/s, 0.1s, 0.3s, 0.1s), mzv 40Hz)",
       "shaped(trapezoid(" + rad(80, 1e-3) + "rad/s, 0.1s, 0.3s, 0.1s), mzv 40Hz)"},
      {"shaped(constant(5mm), ei 30Hz 0.15)",
       "shaped(constant(" + rad(5, 1e-3) + "rad), ei 30Hz 0.15)"}};
  for (const auto& [linear, by_hand] : pairs) {
    const CommandProfile a = CommandProfile::Parse(linear, gear);
    const CommandProfile b = CommandProfile::Parse(by_hand);
    EXPECT_EQ(a.absolute_angle(), b.absolute_angle()) << linear;
    for (double t = -0.01; t < 0.8; t += 0.0137) {
      for (InputMode input : {InputMode::kVelocity, InputMode::kPosition, InputMode::kSteps}) {
        ASSERT_EQ(a.ControlForStep(t, 1e-3, input, 0.3, 1e-3),
                  b.ControlForStep(t, 1e-3, input, 0.3, 1e-3))
            << linear << " at " << t;
      }
      ASSERT_EQ(a.Speed(t), b.Speed(t)) << linear << " at " << t;
      ASSERT_EQ(a.Angle(t), b.Angle(t)) << linear << " at " << t;
    }
  }
  // The numbers themselves: 25 mm/s is 25e-3·gear rad/s; the accelerations are rates: 50 mm/s at
  // 250 mm/s² is a 0.2 s ramp; a negative gear turns the motion, not the ramp's time.
  EXPECT_EQ(CommandProfile::Parse("constant(25mm/s)", gear).Speed(0), gear * 25e-3);
  EXPECT_NEAR(CommandProfile::Parse("ramp(0mm/s, 50mm/s, 250mm/s²)", gear).Speed(0.1), gear * 25e-3,
              1e-9);
  EXPECT_NEAR(CommandProfile::Parse("ramp(0mm/s, 50mm/s, 250mm/s²)", -gear).Speed(0.1),
              -gear * 25e-3, 1e-9);
  EXPECT_NEAR(CommandProfile::Parse("trapezoid(60rpm, 10rad/s², 0s, 10rad/s²)").Angle(5),
              kTwoPi * kTwoPi / 10, 1e-9);  // ω²/a: two ramps of ω/a = 0.628 s
}

// Without a linear axis (a hinge: no rad per metre) a linear unit is refused naming the unit; an
// angular unit stays valid on a linear axis (it is the rotor's angle); an acceleration is a rate.
TEST(CommandProfile, LinearUnitsNeedALinearAxis) {
  auto error = [](const std::string& text, std::optional<double> rad_per_metre) {
    try {
      CommandProfile::Parse(text, rad_per_metre);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  for (const char* unit : {"mm", "m", "mm/s", "m/s"}) {
    const std::string text = fmt::format("constant(10{})", unit);
    EXPECT_THAT(error(text, std::nullopt),
                AllOf(HasSubstr(text), HasSubstr(fmt::format("is in {}, a linear unit", unit)),
                      HasSubstr("slide joint or a tendon")))
        << unit;
  }
  EXPECT_THAT(error("ramp(0mm/s, 5mm/s, 10mm/s²)", std::nullopt), HasSubstr("mm/s²"));
  EXPECT_EQ(error("constant(100rpm)", 157.08), "");
  EXPECT_EQ(error("constant(1rad)", 157.08), "");
  EXPECT_THAT(error("ramp(0mm/s, 5mm/s, -10mm/s²)", 157.08), HasSubstr("must be > 0"));
  EXPECT_THAT(error("constant(10mm/s²)", 157.08), HasSubstr("expected constant(speed)"));
  EXPECT_THAT(error("constant(1e6m/s)", 157.08), HasSubstr("beyond"));  // 1.6e8 rad/s
}

// targets(…): each angle from its time on, absolute; the drive's motion profile moves between them.
TEST(CommandProfile, TargetsHoldEachAngleFromItsTime) {
  const CommandProfile p = CommandProfile::Parse("targets(0.5rad, 90deg@0.2s, -1rad@1s)");
  EXPECT_TRUE(p.absolute_angle());
  EXPECT_DOUBLE_EQ(p.Angle(0.0), 0.5);
  EXPECT_DOUBLE_EQ(p.Angle(0.1999), 0.5);
  EXPECT_DOUBLE_EQ(p.Angle(0.2), kTwoPi / 4);
  EXPECT_DOUBLE_EQ(p.Angle(5.0), -1.0);
  EXPECT_DOUBLE_EQ(p.Speed(0.5), 0.0);
  // Position input: the angle at mid-step, whatever the start angle (absolute).
  EXPECT_DOUBLE_EQ(p.ControlForStep(0.15, 0.1, InputMode::kPosition, 7.0), kTwoPi / 4);
  auto error = [](const char* text) {
    try {
      CommandProfile::Parse(text);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(error("targets(0rad, 1rad@1s, 2rad@0.5s)"),
              HasSubstr("\"2rad@0.5s\": times must rise"));
  EXPECT_THAT(error("targets(0rad, 1rad)"), HasSubstr("\"1rad\" has no @TIME"));
  EXPECT_THAT(error("targets(0rad, 1rpm@1s)"), HasSubstr("\"1rpm@1s\" is not an angle"));
  EXPECT_THAT(error("targets(0rad, 1rad@-1s)"), HasSubstr("must be >= 0 s"));
}

// Issue 33: the text's length is bounded before any work, and every message quotes a bounded
// excerpt (a 100 001-target profile gave a 2.7 MB message).
TEST(CommandProfile, TextAndMessagesAreBounded) {
  auto error = [](const std::string& text) {
    try {
      CommandProfile::Parse(text);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string huge = "constant(" + std::string(kMaxProfileText, '1') + "rpm)";
  const std::string long_error = error(huge);
  EXPECT_THAT(long_error, HasSubstr("longer than 4000000 characters"));
  EXPECT_LT(long_error.size(), 300u);
  std::string targets = "targets(0rad";
  for (size_t k = 1; k <= kMaxTargets; ++k) targets += fmt::format(", {}rad@{}s", k, k);
  targets += ")";
  const std::string many = error(targets);
  EXPECT_THAT(many, HasSubstr("100000"));
  EXPECT_LT(many.size(), 400u);
  EXPECT_THAT(error(std::string("constant(\x1b[2J1rpm)")), Not(HasSubstr("\x1b")));
}
}  // namespace
}  // namespace mjstepper
