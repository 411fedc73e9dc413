// The one timestep rule (issue 19): every failing mode named, a suggestion that passes, and no
// refusal for a mode no stepper takes part in.
#include "core/timestep_rule.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <random>

#include "core/drive.h"
#include "core/units.h"

namespace mjstepper {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

// The suggestion, printed as every message prints it and read back, passes every mode, also when
// the largest step is itself a round number (ω = 4000 rad/s: 0.2/ω = 5e-5 s, where ω·h = 0.2 > 0.2
// was once refused); one ulp above the largest step fails.
TEST(TimestepRule, PrintedSuggestionPassesAndTheBoundaryIsExact) {
  std::mt19937 random(19);
  std::uniform_real_distribution<double> decades(0, 8);
  std::vector<std::vector<RuleMode>> cases = {{{.omega = 4000, .name = "a", .stepper = true}},
                                              {{.omega = 1000, .name = "a", .stepper = true},
                                               {.omega = 2000, .name = "b", .stepper = false}}};
  for (int i = 0; i < 2000; ++i) {
    cases.push_back({{.omega = std::pow(10.0, decades(random)), .name = "a", .stepper = true},
                     {.omega = std::pow(10.0, decades(random)), .name = "b", .stepper = true}});
  }
  for (const auto& modes : cases) {
    const TimestepVerdict coarse = JudgeTimestep(modes, 1e9, kMaxOmegaTimesStep);
    ASSERT_EQ(coarse.failed.size(), modes.size());
    const std::string printed = fmt::format("{:.3g}", coarse.suggestion);
    const double read = std::strtod(printed.c_str(), nullptr);
    EXPECT_EQ(read, coarse.suggestion) << printed;
    EXPECT_LE(coarse.suggestion, coarse.largest_timestep);
    EXPECT_GT(coarse.suggestion, coarse.largest_timestep * (1 - 1e-2));  // 3 figures: < 1 % below
    EXPECT_TRUE(JudgeTimestep(modes, read, kMaxOmegaTimesStep).failed.empty()) << printed;
    EXPECT_TRUE(JudgeTimestep(modes, coarse.largest_timestep, kMaxOmegaTimesStep).failed.empty());
    const double above = std::nextafter(coarse.largest_timestep, 1.0);
    EXPECT_EQ(JudgeTimestep(modes, above, kMaxOmegaTimesStep).failed.size(), 1u);
  }
  EXPECT_EQ(JudgeTimestep(cases[0], 1, kMaxOmegaTimesStep).suggestion, 5e-5);
  EXPECT_EQ(RoundDown3(4.999999e-5), 4.99e-5);
  EXPECT_EQ(RoundDown3(1.0), 1.0);
  EXPECT_EQ(RoundDown3(999.9), 999.0);
}

// Every failing mode is named in one message, stepper modes first, with its frequency, ω·h and its
// own largest step, and the one suggestion; a passing mode is not named.
TEST(TimestepRule, NamesEveryFailingCheck) {
  const std::vector<RuleMode> modes = {
      {.omega = kTwoPi * 72.2, .name = "mode 1 (stepper 'shaft' 76 %)", .stepper = true},
      {.omega = kTwoPi * 260.0, .name = "mode 2 (joint 'coupling' 76 %)", .stepper = true},
      {.omega = kTwoPi * 5000.0, .name = "mode 3 (joint 'tip' 100 %)", .stepper = false},
      {.omega = kTwoPi * 1.0, .name = "mode 0 (slow)", .stepper = true}};
  const TimestepVerdict v = JudgeTimestep(modes, 1e-3, 0.2);
  ASSERT_EQ(v.failed.size(), 3u);
  EXPECT_TRUE(v.refuse());
  EXPECT_EQ(v.failed[0].name, "mode 2 (joint 'coupling' 76 %)");
  EXPECT_EQ(v.failed[1].name, "mode 1 (stepper 'shaft' 76 %)");
  EXPECT_EQ(v.failed[2].name, "mode 3 (joint 'tip' 100 %)");
  EXPECT_FALSE(v.failed[2].stepper);
  const std::string message = v.Message("m.xml");
  EXPECT_THAT(message,
              AllOf(HasSubstr("m.xml: timestep 0.001 s is too coarse for 3 mode(s)"),
                    HasSubstr("\n  mode 2 (joint 'coupling' 76 %): 260.0 Hz, ω·h = 1.63 > 0.2, "
                              "its largest timestep 0.000122 s"),
                    HasSubstr("\n  mode 1 (stepper 'shaft' 76 %): 72.2 Hz, ω·h = 0.454 > 0.2"),
                    HasSubstr("\n  non-stepper mode 3 (joint 'tip' 100 %): 5000.0 Hz"),
                    HasSubstr("use timestep <= 6.36e-06 s (passes every mode)"),
                    Not(HasSubstr("slow")), Not(HasSubstr("not refused"))));
  EXPECT_EQ(v.suggestion, 6.36e-6);
}

// A mode no stepper takes part in is named as a non-stepper mode and never refuses.
TEST(TimestepRule, NonStepperModesWarnButNeverRefuse) {
  const TimestepVerdict v = JudgeTimestep(
      {{.omega = kTwoPi * 5000.0, .name = "mode 1 (joint 'tip' 100 %)", .stepper = false}}, 2e-3,
      0.2);
  ASSERT_EQ(v.failed.size(), 1u);
  EXPECT_FALSE(v.refuse());
  EXPECT_THAT(v.Message("finger.xml"),
              AllOf(HasSubstr("non-stepper mode 1 (joint 'tip' 100 %)"), HasSubstr("not refused")));
  EXPECT_TRUE(JudgeTimestep({}, 1.0, 0.2).failed.empty());
  EXPECT_TRUE(std::isinf(JudgeTimestep({}, 1.0, 0.2).largest_timestep));
}

// A failing ω·h is never printed as the limit itself.
TEST(TimestepRule, FailingProductIsNotPrintedAsTheLimit) {
  EXPECT_EQ(FormatOmegaH(0.2000001, 0.2), "0.2000001");
  EXPECT_EQ(FormatOmegaH(0.2003, 0.2), "0.2003");
  EXPECT_EQ(FormatOmegaH(1.66, 0.2), "1.66");
}

// The limit is a parameter (issue 20 will make it depend on the coupling).
TEST(TimestepRule, LimitIsAParameter) {
  const std::vector<RuleMode> modes = {{.omega = 1000, .name = "m", .stepper = true}};
  EXPECT_TRUE(JudgeTimestep(modes, 1e-4, 0.2).failed.empty());
  EXPECT_EQ(JudgeTimestep(modes, 1e-4, 0.05).failed.size(), 1u);
  EXPECT_EQ(JudgeTimestep(modes, 1, 0.05).suggestion, 5e-5);
}

// Issue 30, items 4 and 6: with STEP/DIR input the verdict recommends the step a move's ringing
// needs, kRingingOmegaTimesStep/ω on the fastest stepper mode, and never refuses on it. The
// CoreXY's 205.6 Hz rotor mode gives 5.03e-5 s: 1e-4 s passes the modes (ω·h 0.129 <= 0.2) but is
// noted, 4e-4 s fails them and the refusal recommends the ringing's step beside the modes' 1.54e-4
// s.
TEST(TimestepRule, TheRingingStepIsRecommendedNeverRefused) {
  const double omega = kTwoPi * 205.6;  // rad/s
  const std::vector<RuleMode> modes = {{.omega = omega, .name = "mode 4", .stepper = true}};
  TimestepVerdict v = JudgeTimestep(modes, 1e-4, 0.2);
  EXPECT_EQ(v.RingingNote("corexy.xml"), "");  // not judged: no STEP/DIR input
  JudgeRinging(&v, omega);
  EXPECT_EQ(v.ringing_timestep, 5.03e-5);
  EXPECT_TRUE(v.failed.empty());
  EXPECT_FALSE(v.refuse());
  EXPECT_TRUE(v.ringing_exceeded());
  EXPECT_THAT(v.RingingNote("corexy.xml"),
              AllOf(HasSubstr("corexy.xml: after a move with STEP/DIR input, timestep 0.0001 s "
                              "(ω·h = 0.129 on the fastest stepper mode, 205.6 Hz)"),
                    HasSubstr("timestep <= 5.03e-05 s (ω·h <= 0.065)")));
  EXPECT_EQ(v.Message("corexy.xml"), "");  // the modes pass: the note is RingingNote's alone
  // At the recommended step itself, nothing to note.
  TimestepVerdict at = JudgeTimestep(modes, 5.03e-5, 0.2);
  JudgeRinging(&at, omega);
  EXPECT_FALSE(at.ringing_exceeded());
  EXPECT_EQ(at.RingingNote("corexy.xml"), "");
  // A step the modes refuse: the message recommends both.
  TimestepVerdict coarse = JudgeTimestep(modes, 4e-4, 0.2);
  JudgeRinging(&coarse, omega);
  EXPECT_TRUE(coarse.refuse());
  EXPECT_THAT(coarse.Message("corexy.xml"),
              AllOf(HasSubstr("use timestep <= 0.000154 s (passes every mode)"),
                    HasSubstr("after a move with STEP/DIR input, timestep <= 5.03e-05 s keeps its "
                              "ringing within 5 %")));
  EXPECT_THAT(coarse.Summary("mjstepper"),
              HasSubstr("use timestep <= 0.000154 s, <= 5.03e-05 s for a move's ringing"));
}

}  // namespace
}  // namespace mjstepper
