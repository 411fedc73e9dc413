// Issue 31, item 6: Klipper's MCU step commands (parsedump.py's text) as step lists, by the rules
// of Klipper's src/stepper.c (core/klipper_steps.h).
#include "core/klipper_steps.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>
#include <string>

namespace mjstepper {
namespace {

using ::testing::HasSubstr;

std::map<int, KlipperStepper> Parse(const std::string& text) {
  std::istringstream in(text);
  return ParseKlipperDump(in, "dump.txt");
}

std::string ErrorOf(const std::string& text) {
  try {
    Parse(text);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// queue_step(I, n, a) steps at T + k·I + a·k(k−1)/2, k = 1 … n, from the previous command's last
// step T (0 after config_stepper); the direction latched by set_next_step_dir applies to every
// step after it (dir = 1: +1); reset_step_clock sets T; other commands and oids are skipped.
TEST(KlipperSteps, QueueStepsAreTheMcusArithmetic) {
  const auto steppers = Parse(
      "allocate_oids count=4\n"
      "config_stepper oid=2 step_pin=gpiochip0/gpio20 dir_pin=gpiochip0/gpio21 invert_step=0 "
      "step_pulse_ticks=100\n"
      "config_digital_out oid=3 pin=gpiochip0/gpio22 value=1 default_value=1 max_duration=0\n"
      "set_next_step_dir oid=2 dir=1\n"
      "queue_step oid=2 interval=100 count=3 add=10\n"  // 100, 210, 330
      "queue_step oid=2 interval=50 count=1 add=0\n"    // 380
      "queue_digital_out oid=3 clock=500 on_ticks=0\n"
      "set_next_step_dir oid=2 dir=0\n"
      "queue_step oid=2 interval=20 count=2 add=-5\n"  // 400, 415, backward
      "reset_step_clock oid=2 clock=1000\n"
      "queue_step oid=2 interval=5 count=1 add=0\n");  // 1005, backward
  ASSERT_EQ(steppers.size(), 1u);
  const KlipperStepper& s = steppers.at(2);
  EXPECT_EQ(s.clocks, (std::vector<std::int64_t>{100, 210, 330, 380, 400, 415, 1005}));
  EXPECT_EQ(s.directions, (std::vector<double>{1, 1, 1, 1, -1, -1, -1}));
}

// The MCU's clock is 32 bits: a reset_step_clock after 2^32 ticks (86 s at 50 MHz) is the time
// with those low bits nearest the last step or after it, and queue_step intervals add past 2^32.
TEST(KlipperSteps, ClocksUnwrapPastThirtyTwoBits) {
  const auto steppers = Parse(
      "config_stepper oid=0 step_pin=a dir_pin=b invert_step=0 step_pulse_ticks=0\n"
      "queue_step oid=0 interval=4294967295 count=1 add=0\n"  // 2^32 − 1
      "queue_step oid=0 interval=11 count=1 add=0\n"          // 2^32 + 10
      "reset_step_clock oid=0 clock=100\n"                    // 2^32 + 100
      "queue_step oid=0 interval=1 count=1 add=0\n");
  const std::int64_t wrap = std::int64_t{1} << 32;
  EXPECT_EQ(steppers.at(0).clocks, (std::vector<std::int64_t>{wrap - 1, wrap + 10, wrap + 101}));
}

// A malformed dump is refused with its file, line and what is wrong.
TEST(KlipperSteps, MalformedCommandsAreRefusedByLine) {
  const std::string config = "config_stepper oid=2 step_pin=a dir_pin=b\n";
  EXPECT_THAT(ErrorOf("queue_step oid=2 interval=1 count=1 add=0\n"),
              HasSubstr("dump.txt:1: oid 2 is no stepper"));
  EXPECT_THAT(ErrorOf(config + "queue_step oid=2 interval=1 count=0 add=0\n"),
              HasSubstr("dump.txt:2: count must be an integer in [1, 65535]"));
  EXPECT_THAT(ErrorOf(config + "queue_step oid=2 interval=4294967296 count=1 add=0\n"),
              HasSubstr("interval must be an integer in [0, 4294967295]"));
  EXPECT_THAT(ErrorOf(config + "queue_step oid=2 interval=1 count=1 add=40000\n"),
              HasSubstr("add must be an integer in [-32768, 32767]"));
  EXPECT_THAT(ErrorOf(config + "queue_step oid=2 interval=1 count=1\n"), HasSubstr("no add="));
  EXPECT_THAT(ErrorOf(config + "queue_step oid=2 interval=10 count=3 add=-8\n"),
              HasSubstr("falls below 0"));
  EXPECT_THAT(ErrorOf(config + "set_next_step_dir oid=2 dir=2\n"),
              HasSubstr("dir must be an integer in [0, 1]"));
  EXPECT_THAT(ErrorOf(config + std::string(5000, 'x') + "\n"), HasSubstr("longer than 4096"));
  EXPECT_THAT(ErrorOf(config + "queue_step oid=2 interval=\x1b[2J count=1 add=0\n"),
              HasSubstr("interval=?[2J"));  // control characters are not echoed
}

TEST(KlipperSteps, TheMapNamesItsFieldsAndRefusesTheRest) {
  std::istringstream good(
      "# a comment\n"
      "dump out.txt\n"
      "clock_freq 50000000  # Hz\n"
      "offset 0.5\n"
      "stepper stepper_a 2\n"
      "stepper stepper_b 5 reversed\n");
  const KlipperMap map = ParseKlipperMap(good, "m.map");
  EXPECT_EQ(map.dump, "out.txt");
  EXPECT_EQ(map.clock_freq, 5e7);
  EXPECT_EQ(map.offset, 0.5);
  ASSERT_EQ(map.steppers.size(), 2u);
  EXPECT_EQ(map.steppers[1].actuator, "stepper_b");
  EXPECT_EQ(map.steppers[1].oid, 5);
  EXPECT_TRUE(map.steppers[1].reversed);
  auto error = [](const std::string& text) {
    std::istringstream in(text);
    try {
      ParseKlipperMap(in, "m.map");
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_THAT(error("dump a\nclock_freq 0\nstepper s 1\n"), HasSubstr("m.map:2: clock_freq (Hz)"));
  EXPECT_THAT(error("dump a\nclock_freq 1e6\nstepper s 1.5\n"),
              HasSubstr("m.map:3: oid must be an integer"));
  EXPECT_THAT(error("dump a\nclock_freq 1e6\nstepper s 1 backwards\n"), HasSubstr("reversed"));
  EXPECT_THAT(error("dump a\nclock_freq 1e6\nstepper s 1\nstepper s 2\n"),
              HasSubstr("mapped twice"));
  EXPECT_THAT(error("dump a\nclock_freq 1e6\n"), HasSubstr("needs `dump PATH`"));
  EXPECT_THAT(error("dmp a\n"), HasSubstr("m.map:1: expected `dump PATH`"));
}

}  // namespace
}  // namespace mjstepper
