// The MJCF config parser (plugin/config.h): strict numbers, presets, overrides, docs.
#include "config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <variant>

namespace mjstepper::plugin {
namespace {

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

TEST(Config, DefaultsAreTsuiCurrentMicrostepping) {
  const auto parsed = ParseMap({});
  ASSERT_TRUE(std::holds_alternative<DriveConfig>(parsed));
  const DriveConfig& c = std::get<DriveConfig>(parsed);
  EXPECT_EQ(c.kind, DriveKind::kCurrentMicrostep);
  EXPECT_EQ(c.input, InputMode::kPosition);
  EXPECT_EQ(c.motor.resistance, 0.9);
  EXPECT_EQ(c.motor.detent.size(), 3u);
  EXPECT_EQ(c.hold_current, 1.9);
  EXPECT_EQ(c.kp, 7.5);
  EXPECT_EQ(c.ki_per_tick, 0.01);
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
  EXPECT_EQ(c.kind, DriveKind::kVoltageMicrostep);
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
  // The current drive does not use it: no error.
  EXPECT_TRUE(std::holds_alternative<DriveConfig>(ParseMap({{"voltage_amplitude", "60"}})));
}

// Every attribute the parser knows has a row in plugin/README.md's table, with a unit column.
TEST(Config, EveryAttributeIsDocumented) {
  std::ifstream file(MJSTEPPER_SOURCE_DIR "/plugin/README.md");
  ASSERT_TRUE(file) << "plugin/README.md missing";
  std::stringstream text;
  text << file.rdbuf();
  for (const char* name : AttributeNames()) {
    EXPECT_THAT(text.str(), HasSubstr(std::string("| `") + name + "`")) << name;
  }
}

}  // namespace
}  // namespace mjstepper::plugin
