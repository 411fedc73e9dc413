// The MJCF config parser (plugin/config.h): strict numbers, presets, overrides, docs.
#include "config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <variant>

#include "core/signals.h"

namespace mjstepper::plugin {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

std::variant<DriveConfig, std::string> ParseMap(const std::map<std::string, std::string>& kv) {
  return ParseConfig([&](const char* key) -> const char* {
    const auto it = kv.find(key);
    return it == kv.end() ? nullptr : it->second.c_str();
  });
}

TEST(Config, StrictNumbers) {
  double v = 0;
  EXPECT_TRUE(ParseFiniteDouble("48", &v));
  EXPECT_EQ(v, 48.0);
  EXPECT_TRUE(ParseFiniteDouble(" 4.8e1 ", &v));
  EXPECT_EQ(v, 48.0);
  EXPECT_TRUE(ParseFiniteDouble("+2", &v));
  for (const char* bad : {"", " ", "48V", "nan", "inf", "-inf", "4,8", "0x", "1e999", "--1"}) {
    EXPECT_FALSE(ParseFiniteDouble(bad, &v)) << bad;
  }
}

// Issue 16: a leading '+' is skipped for from_chars, which then read "+-1" as −1 (a detent phase
// of "+-1" loaded as −1 rad). One sign only: "+-1", "++1" and a lone "+" are no numbers, in a
// single value and in a detent triplet alike.
// Issue 33: a message quotes a bad value as a bounded excerpt with its control characters escaped
// (a 100 MB value gave a 100 MB message; a terminal escape in it cleared the user's screen).
TEST(Config, MessagesQuoteABoundedEscapedExcerpt) {
  const std::string huge(1000000, '7');
  const auto long_parsed = ParseMap({{"bus_voltage", huge + "V"}});
  const auto* long_error = std::get_if<std::string>(&long_parsed);
  ASSERT_NE(long_error, nullptr);
  EXPECT_LT(long_error->size(), 300u);
  EXPECT_THAT(*long_error, HasSubstr("… (1000001 characters)"));
  const auto escape_parsed = ParseMap({{"bus_voltage", "\x1b[2J48"}});
  const auto* escape = std::get_if<std::string>(&escape_parsed);
  ASSERT_NE(escape, nullptr);
  EXPECT_THAT(*escape, HasSubstr("bus_voltage = \"\\x1b[2J48\""));
  EXPECT_EQ(escape->find('\x1b'), std::string::npos);
  // A cut never splits a UTF-8 character: 59 bytes, then a 2-byte "²" across the 60th.
  EXPECT_EQ(Excerpt(std::string(59, 'a') + "²" + std::string(10, 'b')),
            std::string(59, 'a') + "… (71 characters)");
}

TEST(Config, OneSignOnly) {
  double v = 0;
  EXPECT_TRUE(ParseFiniteDouble("-1", &v));
  EXPECT_EQ(v, -1.0);
  for (const char* bad : {"+-1", "++1", "+", " + 1", "+ 1"}) {
    EXPECT_FALSE(ParseFiniteDouble(bad, &v)) << bad;
  }
  const auto parsed = ParseMap({{"detent", "4 0.006 +-1"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(parsed));
  EXPECT_THAT(std::get<std::string>(parsed), AllOf(HasSubstr("detent"), HasSubstr("+-1")));
}

// StealthChop on a catalogue motor: parsed with the TMC2209's defaults; a run current the bus
// cannot drive at standstill (R·√2·I above Vbus·255/256·248/256) is a load error naming it.
TEST(Config, StealthChopReachesItsRunCurrentOrFailsToLoad) {
  const auto parsed = ParseMap({{"motor", "qsh4218_51"},
                                {"drive", "stealthchop"},
                                {"input", "steps"},
                                {"bus_voltage", "24"}});
  ASSERT_TRUE(std::holds_alternative<DriveConfig>(parsed)) << std::get<std::string>(parsed);
  const StealthChop& st = std::get<StealthChop>(std::get<DriveConfig>(parsed).controller);
  EXPECT_EQ(st.pwm_ofs, 36);
  EXPECT_EQ(st.pwm_reg, 8);
  // qsh4218_51: R = 5 Ω; at 12 V the largest phase voltage is 11.58 V, so 1.7 A RMS (12.0 V at
  // rest) cannot be held while 1.6 A RMS (11.3 V) can.
  const auto too_much = ParseMap({{"motor", "qsh4218_51"},
                                  {"drive", "stealthchop"},
                                  {"bus_voltage", "12"},
                                  {"run_current", "1.7"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(too_much));
  EXPECT_THAT(std::get<std::string>(too_much),
              AllOf(HasSubstr("run_current = \"1.7\""), HasSubstr("largest phase voltage")));
  EXPECT_TRUE(std::holds_alternative<DriveConfig>(ParseMap({{"motor", "qsh4218_51"},
                                                            {"drive", "stealthchop"},
                                                            {"bus_voltage", "12"},
                                                            {"run_current", "1.6"}})));
  // An attribute of StealthChop on another drive names the drive that reads it.
  const auto misplaced = ParseMap({{"drive", "chopper"}, {"pwm_grad", "20"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(misplaced));
  EXPECT_THAT(std::get<std::string>(misplaced), HasSubstr("read by stealthchop"));
}

// A catalogue motor's current drive defaults to the peak of its rated RMS current (its datasheet's
// holding torque and temperature rise), not Tsui's 1.9 A, which would overdrive a 1 A motor; a
// given hold_current stands.
TEST(Config, CatalogueMotorsDefaultToTheirRatedCurrent) {
  for (const auto& [motor, rated] : {std::pair{"qsh4218_41", 1.0}, {"17hs19_2004s1", 2.0}}) {
    const auto parsed = ParseMap({{"motor", motor}});
    ASSERT_TRUE(std::holds_alternative<DriveConfig>(parsed)) << motor;
    const auto& drive = std::get<CurrentMicrostep>(std::get<DriveConfig>(parsed).controller);
    EXPECT_DOUBLE_EQ(drive.setpoint.hold_current, std::sqrt(2.0) * rated) << motor;
  }
  const auto given = ParseMap({{"motor", "qsh4218_41"}, {"hold_current", "0.5"}});
  EXPECT_EQ(
      std::get<CurrentMicrostep>(std::get<DriveConfig>(given).controller).setpoint.hold_current,
      0.5);
}

TEST(Config, DefaultsAreTsuiCurrentMicrostepping) {
  const auto parsed = ParseMap({});
  ASSERT_TRUE(std::holds_alternative<DriveConfig>(parsed));
  const DriveConfig& c = std::get<DriveConfig>(parsed);
  ASSERT_TRUE(std::holds_alternative<CurrentMicrostep>(c.controller));
  const CurrentMicrostep& drive = std::get<CurrentMicrostep>(c.controller);
  EXPECT_EQ(c.input, InputMode::kPosition);
  EXPECT_EQ(c.motor.resistance, 0.9);
  EXPECT_EQ(c.motor.detent.size(), 3u);
  EXPECT_EQ(drive.setpoint.hold_current, 1.9);
  EXPECT_EQ(drive.loop.kp, 7.5);
  EXPECT_EQ(drive.loop.ki_per_tick, 0.01);
  EXPECT_EQ(c.isr_period, 50e-6);
  EXPECT_EQ(c.compute_delay, 25e-6);
  EXPECT_EQ(c.bus_voltage, 48.0);
}

TEST(Config, PresetValuesCanBeOverridden) {
  const auto parsed = ParseMap({{"motor", "kim2016"},
                                {"resistance", "2.0"},
                                {"detent", "4 0.01 0; 1 0.002 1.5708"},
                                {"drive", "voltage_microstep"},
                                {"input", "velocity"}});
  ASSERT_TRUE(std::holds_alternative<DriveConfig>(parsed)) << std::get<std::string>(parsed);
  const DriveConfig& c = std::get<DriveConfig>(parsed);
  EXPECT_EQ(c.motor.torque_constant, 0.48);  // from the preset
  EXPECT_EQ(c.motor.resistance, 2.0);        // overridden
  ASSERT_EQ(c.motor.detent.size(), 2u);
  EXPECT_EQ(c.motor.detent[1].order, 1);
  EXPECT_EQ(c.motor.detent[1].phase, 1.5708);
  ASSERT_TRUE(std::holds_alternative<VoltageMicrostep>(c.controller));
  // SPEC §3: Vmax defaults to R·I_rated, here the overridden R = 2.0 Ω times Kim's 2 A.
  EXPECT_EQ(std::get<VoltageMicrostep>(c.controller).voltage_amplitude, 4.0);
  EXPECT_EQ(c.input, InputMode::kVelocity);
  EXPECT_TRUE(std::get<DriveConfig>(ParseMap({{"detent", "none"}})).motor.detent.empty());
}

TEST(Config, ErrorQuotesAttributeValueAndUnit) {
  const auto parsed = ParseMap({{"hold_current", "-1.9"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(parsed));
  EXPECT_EQ(std::get<std::string>(parsed), "hold_current = \"-1.9\": must be > 0 (A)");
}

TEST(Config, VoltageAmplitudeAboveBusFailsForVoltageDrive) {
  const auto parsed = ParseMap({{"drive", "voltage_microstep"}, {"voltage_amplitude", "60"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(parsed));
  EXPECT_EQ(std::get<std::string>(parsed),
            "voltage_amplitude = \"60\": must be <= bus_voltage = 48 for voltage_microstep (V)");
}

// The averaged voltage drive's rotating phasor must stay within SVPWM's linear range (S-14).
TEST(Config, AveragedVoltageBeyondSvpwmsLinearRangeFails) {
  const auto parsed = ParseMap({{"drive", "voltage_microstep"},
                                {"fidelity", "averaged"},
                                {"power_stage", "svpwm"},
                                {"voltage_amplitude", "40"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(parsed));
  EXPECT_THAT(std::get<std::string>(parsed),
              HasSubstr("voltage_amplitude = \"40\": must be <= bus_voltage/√2 = 33.94"));
  EXPECT_TRUE(std::holds_alternative<DriveConfig>(ParseMap({{"drive", "voltage_microstep"},
                                                            {"fidelity", "averaged"},
                                                            {"power_stage", "svpwm"},
                                                            {"voltage_amplitude", "30"}})));
}

// The averaged PI drive carries at most kAveragedLoopHarmonics damping harmonics (two terms each
// in its closed form).
TEST(Config, AveragedPiDriveRefusesMoreDampingHarmonicsThanItCarries) {
  const std::string five = "4 0.006 0; 2 0.014 3.14; 1 0.011 1.57; 3 0.001 0; 5 0.001 0";
  const auto parsed =
      ParseMap({{"damping", "all"}, {"damping_detent", five}, {"fidelity", "averaged"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(parsed));
  EXPECT_THAT(std::get<std::string>(parsed),
              HasSubstr("damping = \"all\": switches on 5 harmonics; fidelity = averaged carries "
                        "at most 4"));
  EXPECT_TRUE(std::holds_alternative<DriveConfig>(
      ParseMap({{"damping", "all"}, {"damping_detent", five}, {"fidelity", "switching"}})));
  EXPECT_TRUE(std::holds_alternative<DriveConfig>(
      ParseMap({{"damping", "4 2 1 3"}, {"damping_detent", five}, {"fidelity", "averaged"}})));
}

// An attribute the chosen drive does not read is an error naming the drives that read it, not a
// silent no-op (a typo of intent, such as servo gains on an open-loop drive).
TEST(Config, AttributeOfAnotherDriveFails) {
  const auto parsed = ParseMap({{"voltage_amplitude", "6"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(parsed));
  EXPECT_EQ(std::get<std::string>(parsed),
            "voltage_amplitude = \"6\": not read by drive current_microstep (read by "
            "voltage_microstep)");
  const auto kim = ParseMap({{"drive", "servo"}, {"k1p", "1000"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(kim));
  EXPECT_THAT(std::get<std::string>(kim), HasSubstr("read by stmms, foc"));
}

TEST(Config, ProfileNeedsPositionInput) {
  const auto parsed = ParseMap({{"profile", "trapezoid"}, {"input", "velocity"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(parsed));
  EXPECT_THAT(std::get<std::string>(parsed),
              HasSubstr("profile = \"trapezoid\": a motion profile moves to a target angle"));
  const auto limits = ParseMap({{"profile_speed", "3"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(limits));
  EXPECT_THAT(std::get<std::string>(limits), HasSubstr("has no effect without profile"));
}

// Finite but absurd numbers the fuzzer (tests/fuzz) found turning the drive's state to NaN within
// its first steps are refused, naming the attribute, the value and the range; and foc, whose J
// defaults to the rotor's inertia and divides by it, needs ff_inertia when rotor_inertia is 0.
TEST(Config, AbsurdMagnitudesAndAZeroInertiaFail) {
  const std::map<std::string, std::string> found[] = {
      {{"resistance", "1e-293"}},
      {{"inductance", "4.9e-320"}},
      {{"torque_constant", "5.6e265"}},
      {{"kp", "1.7e308"}},
      {{"ki", "1.4e308"}},
      {{"drive", "foc"}, {"ff_load_torque", "-1.7e308"}},
      {{"drive", "voltage_microstep"}, {"resistance", "1.4e308"}}};
  for (const auto& config : found) {
    const auto parsed = ParseMap(config);
    ASSERT_TRUE(std::holds_alternative<std::string>(parsed)) << config.rbegin()->first;
    EXPECT_THAT(std::get<std::string>(parsed),
                AllOf(HasSubstr(config.rbegin()->first + " = \"" + config.rbegin()->second),
                      HasSubstr("must be 0 or between 1e-12 and 1e12 in magnitude")));
  }
  const auto foc = ParseMap({{"drive", "foc"}, {"rotor_inertia", "0"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(foc));
  EXPECT_THAT(std::get<std::string>(foc), AllOf(HasSubstr("ff_inertia"), HasSubstr("no default")));
  EXPECT_TRUE(std::holds_alternative<DriveConfig>(
      ParseMap({{"drive", "foc"}, {"rotor_inertia", "0"}, {"ff_inertia", "4.8e-5"}})));
}

TEST(Config, KimControllersAndGainSets) {
  const auto stmms = ParseMap({{"motor", "kim2016"}, {"drive", "stmms"}});
  ASSERT_TRUE(std::holds_alternative<DriveConfig>(stmms)) << std::get<std::string>(stmms);
  const Stmms& s = std::get<Stmms>(std::get<DriveConfig>(stmms).controller);
  EXPECT_EQ(s.mechanical.k1p, 40000);
  EXPECT_EQ(s.mechanical.load_torque, 0.1);  // the preset's τl
  EXPECT_EQ(s.mechanical.inertia, 4.8e-5);   // the preset's J
  const auto case2 = ParseMap(
      {{"motor", "kim2016"}, {"drive", "foc"}, {"foc_case", "case2"}, {"ff_inertia", "5e-5"}});
  ASSERT_TRUE(std::holds_alternative<DriveConfig>(case2)) << std::get<std::string>(case2);
  const HighGainFoc& f = std::get<HighGainFoc>(std::get<DriveConfig>(case2).controller);
  EXPECT_EQ(f.mechanical.k1p, 10000);
  EXPECT_EQ(f.rho, 10000);
  EXPECT_EQ(f.mechanical.inertia, 5e-5);  // its own J, not the plant's
  const auto bad = ParseMap({{"drive", "foc"}, {"foc_case", "case3"}});
  EXPECT_EQ(std::get<std::string>(bad), "foc_case = \"case3\": must be one of: case1, case2");
}

// plugin/README.md carries exactly the tables made from the attribute, signal and controller
// tables: a new attribute, signal or drive, or an edited meaning, fails here until the README is
// regenerated (`build/mjstepper tables --write plugin/README.md`).
TEST(Config, ReadmeTablesAreTheTables) {
  std::ifstream file(MJSTEPPER_SOURCE_DIR "/plugin/README.md");
  ASSERT_TRUE(file) << "plugin/README.md missing";
  std::stringstream text;
  text << file.rdbuf();
  EXPECT_THAT(text.str(), HasSubstr(AttributeTableMarkdown()));
  EXPECT_THAT(text.str(), HasSubstr(SignalTableMarkdown()));
  EXPECT_THAT(text.str(), HasSubstr(DriveListMarkdown()));
  EXPECT_THAT(text.str(), HasSubstr(PresetTableMarkdown()));
  for (const char* name : AttributeNames()) {
    EXPECT_THAT(text.str(), HasSubstr(std::string("| `") + name + "`")) << name;
  }
  // The sensor's size where the text gives it (issue 32: it said 25 values, the table has 30).
  const std::string count = std::to_string(kNumSignals) + " values";
  EXPECT_THAT(text.str(), HasSubstr("signals: " + count));
  EXPECT_THAT(text.str(), HasSubstr(count + " for the stepper on actuator NAME"));
}

// Issue 17, driver presets: `driver` picks the chip's drive and a printer's 24 V, and refuses a
// supply beyond the chip's range or a drive that does not read it.
TEST(Config, DriverChipPicksTheDriveAndBoundsTheSupply) {
  auto config = [](std::map<std::string, std::string> kv) {
    kv["motor"] = "qsh4218_51";
    kv["input"] = "steps";
    return ParseMap(kv);
  };
  const auto tmc = config({{"driver", "tmc2209"}});
  ASSERT_TRUE(std::holds_alternative<DriveConfig>(tmc)) << std::get<std::string>(tmc);
  EXPECT_STREQ(ControllerName(std::get<DriveConfig>(tmc).controller), "spreadcycle");
  EXPECT_EQ(std::get<DriveConfig>(tmc).bus_voltage, 24.0);
  const auto allegro = config({{"driver", "a4988"}});
  ASSERT_TRUE(std::holds_alternative<DriveConfig>(allegro));
  EXPECT_STREQ(ControllerName(std::get<DriveConfig>(allegro).controller), "chopper");
  const auto quiet = config({{"driver", "tmc5160"}, {"bus_voltage", "48"}});
  ASSERT_TRUE(std::holds_alternative<DriveConfig>(quiet)) << std::get<std::string>(quiet);
  const auto over = config({{"driver", "tmc2209"}, {"bus_voltage", "48"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(over));
  EXPECT_THAT(std::get<std::string>(over),
              AllOf(HasSubstr("bus_voltage"), HasSubstr("48"), HasSubstr("at most 29 V")));
  // Found by the config fuzzer: input = steps on a drive without a microstep table was refused by
  // the core's backstop, not named as an attribute.
  const auto no_table = ParseMap({{"input", "steps"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(no_table));
  EXPECT_THAT(std::get<std::string>(no_table),
              AllOf(HasSubstr("input = \"steps\""), HasSubstr("no microstep table")));
  const auto lab = config({{"driver", "tmc2209"}, {"drive", "current_microstep"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(lab));
  EXPECT_THAT(std::get<std::string>(lab),
              AllOf(HasSubstr("driver"), HasSubstr("not read by drive current_microstep")));
}

// Issue 33: a chip makes the microstep settings its MRES register or MS pins give (powers of two
// up to 256 on the TMC chips, 16 on the A4988, 32 on the DRV8825) and runs from the bottom of its
// supply range (TMC2209 4.75 V); anything else is refused, naming the attribute, the value and
// the chip's range.
TEST(Config, DriverChipRefusesMicrostepsAndSuppliesItCannotMake) {
  auto config = [](std::map<std::string, std::string> kv) {
    kv["motor"] = "qsh4218_51";
    kv["input"] = "steps";
    return ParseMap(kv);
  };
  struct Case {
    const char* driver;
    const char* microsteps;
    const char* range;  // "" when accepted
  };
  for (const Case& c :
       {Case{"tmc2209", "3", "tmc2209 makes 1, 2, 4, … 256"},
        Case{"tmc2209", "100", "tmc2209 makes 1, 2, 4, … 256"}, Case{"tmc2209", "256", ""},
        Case{"tmc5160", "1", ""}, Case{"a4988", "16", ""},
        Case{"a4988", "32", "a4988 makes 1, 2, 4, … 16"},
        Case{"a4988", "256", "a4988 makes 1, 2, 4, … 16"}, Case{"drv8825", "32", ""},
        Case{"drv8825", "256", "drv8825 makes 1, 2, 4, … 32"}}) {
    SCOPED_TRACE(std::string(c.driver) + " " + c.microsteps);
    const auto r = config({{"driver", c.driver}, {"microsteps", c.microsteps}});
    if (c.range[0] == '\0') {
      EXPECT_TRUE(std::holds_alternative<DriveConfig>(r)) << std::get<std::string>(r);
    } else {
      ASSERT_TRUE(std::holds_alternative<std::string>(r));
      EXPECT_THAT(std::get<std::string>(r),
                  AllOf(HasSubstr("microsteps"), HasSubstr(c.microsteps), HasSubstr(c.range)));
    }
  }
  const auto low = config({{"driver", "tmc2209"}, {"bus_voltage", "4"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(low));
  EXPECT_THAT(std::get<std::string>(low),
              AllOf(HasSubstr("bus_voltage"), HasSubstr("below tmc2209's supply range"),
                    HasSubstr("at least 4.75 V")));
  const auto low5160 = config({{"driver", "tmc5160"}, {"bus_voltage", "7"}});
  ASSERT_TRUE(std::holds_alternative<std::string>(low5160));
  EXPECT_THAT(std::get<std::string>(low5160), HasSubstr("at least 8 V"));
  EXPECT_TRUE(std::holds_alternative<DriveConfig>(
      config({{"driver", "tmc2209"}, {"bus_voltage", "4.75"}})));
}

}  // namespace
}  // namespace mjstepper::plugin
