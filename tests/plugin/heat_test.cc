// Heat in the plugin (SPEC §8): the attributes and their defaults, the temperatures as signals,
// where a reset leaves them, and the one warning per actuator when a winding passes its
// insulation class.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <map>
#include <string>
#include <variant>
#include <vector>

#include "config.h"
#include "test_model.h"

namespace mjstepper::testing {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

const int kWindingTemperature = SignalIndex("winding_temperature");
const int kHousingTemperature = SignalIndex("housing_temperature");
const int kResistance = SignalIndex("resistance");

std::variant<DriveConfig, std::string> Parse(const std::map<std::string, std::string>& kv) {
  return plugin::ParseConfig([&](const char* key) -> const char* {
    const auto it = kv.find(key);
    return it == kv.end() ? nullptr : it->second.c_str();
  });
}

std::string ErrorOf(const std::map<std::string, std::string>& kv) {
  const auto parsed = Parse(kv);
  return std::holds_alternative<std::string>(parsed) ? std::get<std::string>(parsed) : "";
}

TEST(HeatConfig, OnWhereTheMotorHasANetworkOffForThePaperMotors) {
  // `heat` = auto (the default): on for a catalogue preset, which carries its network, with the
  // documented defaults; off for the paper presets (tsui2009, kim2016, bodson1993: no thermal
  // data, and their R is the paper's, not an R20), so the paper reproductions run as before.
  const auto catalogue = Parse({{"motor", "qsh4218_41"}, {"drive", "chopper"}});
  ASSERT_TRUE(std::holds_alternative<DriveConfig>(catalogue)) << std::get<std::string>(catalogue);
  const std::optional<HeatParams>& heat = std::get<DriveConfig>(catalogue).heat;
  ASSERT_TRUE(heat.has_value());
  EXPECT_EQ(heat->network.resistance_winding, 0.619);
  EXPECT_EQ(heat->ambient_temperature, 25.0);
  EXPECT_EQ(heat->initial_temperature, 25.0);  // the ambient's
  EXPECT_EQ(heat->insulation_limit, 130.0);    // class B
  EXPECT_EQ(heat->resistance_coefficient, 0.00393);
  EXPECT_EQ(heat->torque_constant_coefficient, -0.0011);
  for (const char* paper : {"tsui2009", "kim2016", "bodson1993"}) {
    const auto parsed = Parse({{"motor", paper}});
    ASSERT_TRUE(std::holds_alternative<DriveConfig>(parsed)) << paper;
    EXPECT_FALSE(std::get<DriveConfig>(parsed).heat.has_value()) << paper;
  }
  // Off on request, and off for ideal_current (no windings) under auto.
  EXPECT_FALSE(std::get<DriveConfig>(Parse({{"motor", "qsh4218_41"}, {"heat", "off"}})).heat);
  EXPECT_FALSE(
      std::get<DriveConfig>(Parse({{"motor", "qsh4218_41"}, {"drive", "ideal_current"}})).heat);
  // A paper motor with all four constants given: on (auto), with the attributes' values.
  const auto given = Parse({{"motor", "tsui2009"},
                            {"thermal_resistance_winding", "0.5"},
                            {"thermal_resistance_housing", "3"},
                            {"heat_capacity_winding", "40"},
                            {"heat_capacity_housing", "600"},
                            {"ambient_temperature", "-10"},
                            {"initial_temperature", "60"},
                            {"insulation_class", "F"},
                            {"resistance_temperature_coefficient", "0.004"},
                            {"torque_constant_temperature_coefficient", "-0.002"}});
  ASSERT_TRUE(std::holds_alternative<DriveConfig>(given)) << std::get<std::string>(given);
  const HeatParams& h = *std::get<DriveConfig>(given).heat;
  EXPECT_EQ(h.network.capacity_housing, 600.0);
  EXPECT_EQ(h.ambient_temperature, -10.0);
  EXPECT_EQ(h.initial_temperature, 60.0);
  EXPECT_EQ(h.insulation_limit, 155.0);
  EXPECT_EQ(h.resistance_coefficient, 0.004);
  EXPECT_EQ(h.torque_constant_coefficient, -0.002);
}

TEST(HeatConfig, ErrorsNameTheAttributeAndTheValue) {
  EXPECT_THAT(ErrorOf({{"heat", "on"}}),
              AllOf(HasSubstr("heat = \"on\""), HasSubstr("motor tsui2009 has no thermal network"),
                    HasSubstr("thermal_resistance_winding"), HasSubstr("heat_capacity_housing")));
  EXPECT_THAT(ErrorOf({{"heat", "on"}, {"motor", "qsh4218_41"}, {"drive", "ideal_current"}}),
              AllOf(HasSubstr("heat = \"on\""), HasSubstr("no windings")));
  EXPECT_THAT(ErrorOf({{"ambient_temperature", "30"}}),
              AllOf(HasSubstr("ambient_temperature = \"30\""), HasSubstr("no effect"),
                    HasSubstr("motor tsui2009 has no thermal network")));
  EXPECT_THAT(ErrorOf({{"motor", "qsh4218_41"}, {"heat", "off"}, {"insulation_class", "F"}}),
              AllOf(HasSubstr("insulation_class = \"F\""), HasSubstr("heat = off")));
  EXPECT_THAT(ErrorOf({{"motor", "qsh4218_41"}, {"initial_temperature", "500"}}),
              AllOf(HasSubstr("initial_temperature = \"500\""), HasSubstr("[-50, 400]")));
  EXPECT_THAT(ErrorOf({{"motor", "qsh4218_41"}, {"ambient_temperature", "nan"}}),
              HasSubstr("ambient_temperature = \"nan\""));
  EXPECT_THAT(ErrorOf({{"motor", "qsh4218_41"}, {"heat_capacity_winding", "0"}}),
              AllOf(HasSubstr("heat_capacity_winding = \"0\""), HasSubstr("[0.1, 100000]")));
  // Issue 33: 1e6 K/W on 1e-6 J/K put the winding at 1.4e7 °C after 1 s.
  EXPECT_THAT(ErrorOf({{"motor", "qsh4218_41"}, {"thermal_resistance_winding", "1e6"}}),
              AllOf(HasSubstr("thermal_resistance_winding = \"1e6\""), HasSubstr("[0.01, 100]")));
  EXPECT_THAT(ErrorOf({{"motor", "qsh4218_41"}, {"heat_capacity_housing", "1e-6"}}),
              AllOf(HasSubstr("heat_capacity_housing = \"1e-6\""), HasSubstr("[0.1, 100000]")));
  EXPECT_THAT(ErrorOf({{"motor", "qsh4218_41"}, {"insulation_class", "C"}}),
              AllOf(HasSubstr("insulation_class = \"C\""), HasSubstr("A, E, B, F, H")));
  EXPECT_THAT(
      ErrorOf({{"motor", "qsh4218_41"}, {"torque_constant_temperature_coefficient", "0.01"}}),
      AllOf(HasSubstr("torque_constant_temperature_coefficient = \"0.01\""),
            HasSubstr("[-0.002, 0.002]")));
  EXPECT_THAT(ErrorOf({{"heat", "warm"}}),
              AllOf(HasSubstr("heat = \"warm\""), HasSubstr("auto, on, off")));
}

// A qsh4218_41 on the chopper held at its full-step position (STEP/DIR count 8 of 16), heat on,
// with `extra` configs; its armature is the rotor's 5.4e-6 kg·m².
std::string HeldQsh(const std::string& name, const std::string& joint, const std::string& extra) {
  return fmt::format(R"(<plugin name="{}" joint="{}" plugin="mjstepper.stepper" armature="5.4e-6" )"
                     R"(damping="1e-4">{}</plugin>)",
                     name, joint,
                     Config("motor", "qsh4218_41") + Config("drive", "chopper") +
                         Config("input", "steps") + Config("bus_voltage", "24") + extra);
}

std::string Probe(const std::string& actuator) {
  return fmt::format(
      R"(<plugin name="p_{0}" plugin="mjstepper.stepper" objtype="actuator" objname="{0}"/>)",
      actuator);
}

TEST(HeatPlugin, TemperaturesAreSignalsAndResetRestartsThem) {
  // C_w = 0.1 J/K (the least the attribute takes): the winding warms by kelvins within tens of
  // milliseconds. Tsui's motor beside it has
  // no heat: its signals say 20 °C and R = 0.9 Ω throughout.
  const std::string actuators =
      HeldQsh("q", "j1",
              Config("heat_capacity_winding", "0.1") + Config("initial_temperature", "40")) +
      TsuiActuator("t", "j2", Config("input", "velocity"));
  const ModelPtr m = LoadModel(RotorModel(actuators, "", Probe("q") + Probe("t"), 2));
  ASSERT_TRUE(m);
  const DataPtr d(mj_makeData(m.get()));
  const int q = m->sensor_adr[0], t = m->sensor_adr[1];
  d->ctrl[0] = 8;  // microsteps: both phases at the rated 1 A
  mj_forward(m.get(), d.get());
  EXPECT_EQ(d->sensordata[q + kWindingTemperature], 40.0);
  EXPECT_EQ(d->sensordata[q + kHousingTemperature], 40.0);
  EXPECT_DOUBLE_EQ(d->sensordata[q + kResistance], 4.5 * (1 + 0.00393 * 20));
  for (int k = 0; k < 8000; ++k) mj_step(m.get(), d.get());  // 0.4 s
  mj_forward(m.get(), d.get());
  const double warm = d->sensordata[q + kWindingTemperature];
  std::printf("winding %.3f °C, housing %.6f °C, R %.5f Ω after 0.4 s\n", warm,
              d->sensordata[q + kHousingTemperature], d->sensordata[q + kResistance]);
  // The small winding settles within a few C_w·R_wh = 62 ms (0.4 s: 6.5 of them) at P·R_wh above
  // the housing (P = R·(ia² + ib²) ≈ 2 A²·R, less the chopper's ripple deficit: 5 %), and the
  // housing (C_h = 204 J/K) has barely moved: P·t/C_h = 0.02 K.
  const double housing = d->sensordata[q + kHousingTemperature];
  const double power = 2.0 * d->sensordata[q + kResistance];  // W
  EXPECT_NEAR(warm - housing, power * 0.619, 0.05 * power * 0.619);
  EXPECT_GT(housing, 40.0);
  EXPECT_LT(housing, 40.05);
  EXPECT_DOUBLE_EQ(d->sensordata[q + kResistance], 4.5 * (1 + 0.00393 * (warm - 20)));
  EXPECT_EQ(d->sensordata[t + kWindingTemperature], 20.0);
  EXPECT_EQ(d->sensordata[t + kResistance], 0.9);
  // mj_copyData carries the heat (plugin_state); mj_resetData restarts it at initial_temperature.
  const DataPtr copy(mj_copyData(nullptr, m.get(), d.get()));
  mj_forward(m.get(), copy.get());
  EXPECT_EQ(copy->sensordata[q + kWindingTemperature], warm);
  mj_resetData(m.get(), d.get());
  d->ctrl[0] = 8;
  mj_forward(m.get(), d.get());
  EXPECT_EQ(d->sensordata[q + kWindingTemperature], 40.0);
}

// The warnings mju_warning sends while it lives that come from the plugin.
class PluginWarnings {
 public:
  PluginWarnings() : previous_(mju_user_warning) {
    Messages().clear();
    mju_user_warning = +[](const char* message) {
      if (std::string(message).starts_with("mjstepper: ")) Messages().emplace_back(message);
    };
  }
  ~PluginWarnings() { mju_user_warning = previous_; }
  const std::vector<std::string>& messages() const { return Messages(); }

 private:
  static std::vector<std::string>& Messages() {
    static std::vector<std::string> messages;
    return messages;
  }
  void (*previous_)(const char*);
};

TEST(HeatPlugin, WarnsOncePerActuatorWhenTheWindingPassesItsClass) {
  // Two actuators of one shared instance, starting at 129.5 °C with C_w = 0.1 J/K: each winding
  // passes class B's 130 °C within a few milliseconds. One warning per actuator, naming it, the
  // temperature and the class, however long they stay above; a third actuator of class H (180
  // °C) on its own instance, at the same temperatures, says nothing.
  PluginWarnings warnings;
  const std::string hot = Config("motor", "qsh4218_41") + Config("drive", "chopper") +
                          Config("input", "steps") + Config("bus_voltage", "24") +
                          Config("heat_capacity_winding", "0.1") +
                          Config("initial_temperature", "129.5");
  const std::string extension = R"(<instance name="shared">)" + hot + "</instance>";
  auto shared = [](const char* name, const char* joint) {
    return fmt::format(R"(<plugin name="{}" joint="{}" instance="shared" armature="5.4e-6"/>)",
                       name, joint);
  };
  const std::string actuators =
      shared("left", "j1") + shared("right", "j2") +
      HeldQsh("classh", "j3",
              Config("heat_capacity_winding", "0.1") + Config("initial_temperature", "129.5") +
                  Config("insulation_class", "H"));
  const ModelPtr m = LoadModel(RotorModel(actuators, extension, "", 3));
  ASSERT_TRUE(m);
  const DataPtr d(mj_makeData(m.get()));
  for (int u = 0; u < m->nu; ++u) d->ctrl[u] = 8;
  for (int k = 0; k < 200; ++k) mj_step(m.get(), d.get());  // 10 ms
  ASSERT_EQ(warnings.messages().size(), 2u);
  std::printf("%s\n", warnings.messages()[0].c_str());
  for (const auto& [i, name] : {std::pair{0, "left"}, std::pair{1, "right"}}) {
    EXPECT_THAT(warnings.messages()[i], AllOf(HasSubstr(fmt::format("actuator '{}'", name)),
                                              HasSubstr("winding temperature 130."),
                                              HasSubstr("passed its insulation class B (130 °C)")));
  }
  for (int k = 0; k < 400; ++k) mj_step(m.get(), d.get());  // 20 ms more, hotter still
  EXPECT_EQ(warnings.messages().size(), 2u);
}

// Issue 33: beyond 400 °C R(T) and Km(T) are held at their 400 °C values; it was silent (the
// `resistance` signal read 11.22 Ω for ever). A winding started at 399.9 °C with C_w = 0.1 J/K
// passes it within milliseconds: one warning with the temperature and the held R, beside the
// insulation class's.
TEST(HeatPlugin, WarnsOnceWhenTheWindingLeavesTheLawsRange) {
  PluginWarnings warnings;
  const ModelPtr m = LoadModel(RotorModel(
      HeldQsh("hot", "j1",
              Config("heat_capacity_winding", "0.1") + Config("initial_temperature", "399.9") +
                  Config("insulation_class", "H")),
      "", "", 1));
  ASSERT_TRUE(m);
  const DataPtr d(mj_makeData(m.get()));
  d->ctrl[0] = 8;
  for (int k = 0; k < 400; ++k) mj_step(m.get(), d.get());  // 20 ms
  std::vector<std::string> law;
  for (const std::string& w : warnings.messages()) {
    if (w.find("R(T) and Km(T)") != std::string::npos) law.push_back(w);
  }
  ASSERT_EQ(law.size(), 1u);
  EXPECT_THAT(law[0], AllOf(HasSubstr("actuator 'hot'"), HasSubstr("winding temperature 400."),
                            HasSubstr("held at their 400 °C values (R = "),
                            HasSubstr("its class: 180 °C")));
}

}  // namespace
}  // namespace mjstepper::testing
