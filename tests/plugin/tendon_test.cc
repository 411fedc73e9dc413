// A stepper on a tendon transmission (issue 19 item 6): θ = gear·L, the force gear·τ through the
// tendon's moment, the rotor inertia as the actuator's armature reflected onto the tendon.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "core/signals.h"
#include "core/units.h"
#include "test_model.h"

namespace mjstepper::testing {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

// The Tsui preset's numbers (tsui2009): Km = 0.3 N·m/A, Nr = 50, at 1.9 A: holding stiffness
// T' = Nr·Km·I = 28.5 N·m/rad and pull-out torque Km·I = 0.57 N·m (SPEC §1, T(1)).
constexpr double kTsuiHolding = 50 * 0.3 * 1.9;  // N·m/rad
constexpr double kTsuiPullOut = 0.3 * 1.9;       // N·m

// A 0.5 kg carriage on slide "x", driven by actuator "m1" (a Tsui stepper with `configs`) whose
// target and gear are `transmission`, and a probe "s" on it. Tendons: "fixed1" (L = x), "fixed2"
// (L = 2x) and the spatial "cable" from the frame's anchor to the carriage's clamp, both on the
// slide's axis (L = x + 0.05 m, ∂L/∂x = 1).
std::string CarriageModel(const std::string& transmission, const std::string& configs,
                          const std::string& joint_attrs = "",
                          const std::string& armature = "armature=\"0.36e-4\"") {
  return fmt::format(R"(<mujoco>
  <option timestep="5e-5" integrator="implicitfast"/>
  <extension><plugin plugin="mjstepper.stepper"/></extension>
  <worldbody>
    <site name="anchor" pos="-0.05 0 0"/>
    <body name="carriage">
      <joint name="x" type="slide" axis="1 0 0" {}/>
      <inertial pos="0 0 0" mass="0.5" diaginertia="1e-4 1e-4 1e-4"/>
      <site name="clamp"/>
    </body>
  </worldbody>
  <tendon>
    <fixed name="fixed1"><joint joint="x" coef="1"/></fixed>
    <fixed name="fixed2"><joint joint="x" coef="2"/></fixed>
    <spatial name="cable"><site site="anchor"/><site site="clamp"/></spatial>
  </tendon>
  <actuator>
    <plugin name="m1" {} plugin="mjstepper.stepper" {} damping="0.001">{}</plugin>
  </actuator>
  <sensor><plugin name="s" plugin="mjstepper.stepper" objtype="actuator" objname="m1"/></sensor>
</mujoco>)",
                     joint_attrs, transmission, armature, configs);
}

struct Transmission {
  const char* name;
  std::string attributes;
  double moment;  // ∂θ/∂x = gear·∂L/∂x, rad/m
};

// The same carriage through a joint transmission and three tendons of the same moment
// (157.08 rad/m, a 40 mm-per-turn capstan): the same ramp moves them alike. The fixed tendons are
// the joint's own arithmetic (L = 1·x or 2·x, then gear·L; doubling is exact), so they match to the
// bit; the spatial tendon's length is a norm and its θ at the step's end first-order (exact here:
// its moment is constant), so it matches to 1e-12 m, round-off (measured 2e-16 m; a full step is
// 1.8°/157.08 rad/m = 0.2 mm).
TEST(TendonTransmission, MotionEqualsTheJointEquivalent) {
  const std::string configs = Config("input", "velocity") + Config("detent", "none");
  const std::vector<Transmission> variants = {
      {"joint", R"(joint="x" gear="157.08")", 157.08},
      {"fixed tendon", R"(tendon="fixed1" gear="157.08")", 157.08},
      {"fixed tendon, coef 2", R"(tendon="fixed2" gear="78.54")", 157.08},
      {"spatial tendon", R"(tendon="cable" gear="157.08")", 157.08}};
  std::vector<std::vector<double>> paths;
  std::vector<double> lost;
  for (const Transmission& t : variants) {
    std::string error;
    const ModelPtr m = LoadModel(CarriageModel(t.attributes, configs), &error);
    ASSERT_TRUE(m) << t.name << ": " << error;
    const DataPtr d(mj_makeData(m.get()));
    std::vector<double> path;
    for (int k = 0; k < 6000; ++k) {  // 0.3 s: to 200 r/min in 0.1 s, through the resonance
      d->ctrl[0] = RpmToRadPerSec(200) * std::min(1.0, d->time / 0.1);
      mj_step(m.get(), d.get());
      path.push_back(d->qpos[0]);
    }
    mj_forward(m.get(), d.get());
    lost.push_back(d->sensordata[kLostSteps]);
    paths.push_back(path);
  }
  // 200 r/min for 0.25 s on average: 0.83 turn of the capstan = 33 mm of travel.
  EXPECT_NEAR(paths[0].back(), RpmToRadPerSec(200) * 0.25 / 157.08, 2e-3);
  for (size_t v = 1; v < variants.size(); ++v) {
    for (size_t k = 0; k < paths[0].size(); ++k) {
      if (v < 3) {
        ASSERT_EQ(paths[v][k], paths[0][k]) << variants[v].name << " step " << k;
      } else {
        ASSERT_NEAR(paths[v][k], paths[0][k], 1e-12) << variants[v].name << " step " << k;
      }
    }
    EXPECT_EQ(lost[v], lost[0]) << variants[v].name;
  }
}

// A held rotor (position input on its start angle, detent off, 1.9 A), and the carriage's fixed
// tendon L = 2x (gear 50) and spatial cable L = x + 0.05 (gear 100): both moment 100 rad/m.
std::string HeldConfigs() {
  return Config("input", "position") + Config("detent", "none") + Config("hold_current", "1.9");
}
const Transmission kCarriageTransmissions[] = {{"fixed", R"(tendon="fixed2" gear="50")", 100.0},
                                               {"spatial", R"(tendon="cable" gear="100")", 100.0}};

// Holding stiffness along the tendon: a held rotor resists a carriage force F with the closed
// form K = T'·(gear·∂L/∂x)², so x = F/K. Fixed tendon L = 2x, gear 50 and spatial L = x + 0.05,
// gear 100: both K = 28.5·100² = 2.85e5 N/m. Tolerance 2e-4 (measured 1.3e-4): the torque is
// Km·I·sin δ, not T'·θ, at δ = Nr·θ = 0.018 rad electrical sin δ/δ − 1 = −5e-5 (it grows as F²:
// 4.6e-4 more at F = 3 N), and 8e-5 that does not vary with F, the drive's own (the joint
// transmission moves the same to the bit, test above); the slide's damping (ζ ≈ 0.3) has settled
// the carriage to 3e-6 of x in 0.2 s. Without the factor (gear·∂L/∂x)² x would be off 1e4-fold.
TEST(TendonTransmission, HoldingStiffnessAlongTheTendonIsTPrimeTimesMomentSquared) {
  const std::string configs = HeldConfigs();
  for (const Transmission& t : kCarriageTransmissions) {
    std::string error;
    const ModelPtr m = LoadModel(CarriageModel(t.attributes, configs, R"(damping="300")"), &error);
    ASSERT_TRUE(m) << t.name << ": " << error;
    const DataPtr d(mj_makeData(m.get()));
    mj_forward(m.get(), d.get());
    const double theta0 = d->actuator_length[0];  // rad: hold the rotor where it starts
    const double force = 1.0;                     // N, along +x
    for (int k = 0; k < 4000; ++k) {
      d->ctrl[0] = theta0;
      d->qfrc_applied[0] = force;
      mj_step(m.get(), d.get());
    }
    const double stiffness = kTsuiHolding * t.moment * t.moment;  // N/m
    EXPECT_NEAR(d->qpos[0], force / stiffness, 2e-4 * force / stiffness) << t.name;
    EXPECT_NEAR(d->qvel[0], 0.0, 1e-8) << t.name;  // settled
  }
}

// Pull-out along the tendon and the slip counter: the held rotor first slips when the carriage
// force passes Km·I·moment (0.57 N·m × 100 rad/m = 57 N), and the lost steps counted are the
// cycles the rotor fell behind, round(θ·Nr/2π) with θ = gear·L. ± 2 %, as the joint's test
// (plugin_test.cc): the ramp during the run from δ = π/2 to the counting threshold, and the
// current loop's error at that speed.
TEST(TendonTransmission, PullOutAndLostStepsAlongTheTendon) {
  const std::string configs = HeldConfigs();
  for (const Transmission& t : kCarriageTransmissions) {
    std::string error;
    const ModelPtr m = LoadModel(CarriageModel(t.attributes, configs), &error);
    ASSERT_TRUE(m) << t.name << ": " << error;
    const DataPtr d(mj_makeData(m.get()));
    mj_forward(m.get(), d.get());
    const double theta0 = d->actuator_length[0];
    const double rate = 25;  // N/s
    double slip_force = -1;
    while (d->time < 2.6) {
      d->ctrl[0] = theta0;
      // Along +x, away from the cable's anchor (towards it the spatial cable would fold over it
      // once slipping): the carriage pulls the rotor ahead of its command.
      d->qfrc_applied[0] = rate * d->time;
      mj_step(m.get(), d.get());
      mj_forward(m.get(), d.get());
      if (slip_force < 0 && d->sensordata[kLostSteps] != 0) slip_force = rate * d->time;
    }
    const double pull_out = kTsuiPullOut * t.moment;  // N
    ASSERT_GT(slip_force, 0) << t.name << ": never slipped";
    EXPECT_NEAR(slip_force, pull_out, 0.02 * pull_out) << t.name;
    // Cycles behind the command (negative: ahead).
    const double cycles_behind = std::round((theta0 - d->actuator_length[0]) * 50 / kTwoPi);
    EXPECT_LT(cycles_behind, -3) << t.name;
    EXPECT_NEAR(d->sensordata[kLostSteps] / 4, cycles_behind, 1.0) << t.name;
  }
}

// The rotor's inertia on a tendon is the actuator's armature, which MuJoCo reflects onto the
// tendon: M_xx = m + J·(gear·∂L/∂x)². Without it the load fails naming the armature to add, as on
// a joint.
TEST(TendonTransmission, RotorInertiaIsTheArmatureReflectedOntoTheTendon) {
  const std::string configs = Config("input", "velocity");
  std::string error;
  const ModelPtr m = LoadModel(CarriageModel(R"(tendon="fixed2" gear="50")", configs), &error);
  ASSERT_TRUE(m) << error;
  const DataPtr d(mj_makeData(m.get()));
  mj_forward(m.get(), d.get());
  EXPECT_NEAR(d->M[0], 0.5 + 0.36e-4 * 100 * 100, 1e-12);  // kg
  EXPECT_FALSE(LoadModel(CarriageModel(R"(tendon="cable" gear="50")", configs, "", ""), &error));
  EXPECT_THAT(error, AllOf(HasSubstr("actuator 'm1'"), HasSubstr("add armature=\"3.6e-05\"")));
}

// Site, slider-crank and body transmissions are refused, naming the actuator and the trntype.
// (MuJoCo itself refuses an actuator's damping and armature on them: the models have none, and
// rotor_inertia="0". MJCF's <plugin>
// actuator takes no body="...": the body transmission is set through mjSpec.)
TEST(TendonTransmission, OtherTransmissionsAreRefusedByName) {
  auto without_damping = [](std::string xml) {
    xml.erase(xml.find(R"(damping="0.001")"), 15);
    return xml;
  };
  const std::string configs = Config("input", "velocity") + Config("rotor_inertia", "0");
  auto expect_refused = [](const std::string& error, const char* trntype) {
    EXPECT_THAT(error, AllOf(HasSubstr("actuator 'm1'"), HasSubstr(trntype),
                             HasSubstr("tendon transmission")));
  };
  for (const auto& [attributes, trntype] :
       {std::pair{R"(site="clamp")", "trntype = site"},
        std::pair{R"(cranksite="clamp" slidersite="anchor" cranklength="0.1")",
                  "trntype = slidercrank"}}) {
    std::string error;
    EXPECT_FALSE(LoadModel(without_damping(CarriageModel(attributes, configs, "", "")), &error))
        << attributes;
    expect_refused(error, trntype);
  }
  const std::string xml = without_damping(CarriageModel(R"(site="clamp")", configs, "", ""));
  char error[1024] = "";
  mjSpec* spec = mj_parseXMLString(xml.c_str(), nullptr, error, sizeof(error));
  ASSERT_NE(spec, nullptr) << error;
  mjsActuator* actuator = mjs_asActuator(mjs_findElement(spec, mjOBJ_ACTUATOR, "m1"));
  ASSERT_NE(actuator, nullptr);
  actuator->trntype = mjTRN_BODY;
  mjs_setString(actuator->target, "carriage");
  mjModel* m = mj_compile(spec, nullptr);
  EXPECT_EQ(m, nullptr);
  if (m != nullptr) mj_deleteModel(m);
  expect_refused(mjs_getError(spec), "trntype = body");
  mj_deleteSpec(spec);
}

// MuJoCo adds a tendon's armature within each kinematic tree only: a tendon x1 + x2 over two
// separate carriages gets J·gear² on each diagonal and no cross term (a rigid rotor would pull
// both as one), while over a carriage riding on the other the cross term is there. Loading warns,
// naming the actuator and the tendon, in the first case only.
TEST(TendonTransmission, ATendonAcrossKinematicTreesWarnsOfItsArmature) {
  static std::vector<std::string>* captured = nullptr;
  std::vector<std::string> warnings;
  captured = &warnings;
  void (*previous)(const char*) = mju_user_warning;
  mju_user_warning = +[](const char* message) { captured->emplace_back(message); };
  std::vector<double> cross;  // M[0][1], kg
  std::vector<size_t> count;  // warnings after each load
  for (bool nested : {false, true}) {
    const std::string b =
        R"(<body name="b" pos="0 1 0"><joint name="x2" type="slide" axis="1 0 0"/>)"
        R"(<inertial pos="0 0 0" mass="1.5" diaginertia="1e-4 1e-4 1e-4"/></body>)";
    const std::string a = R"(<body name="a"><joint name="x1" type="slide" axis="1 0 0"/>)"
                          R"(<inertial pos="0 0 0" mass="0.5" diaginertia="1e-4 1e-4 1e-4"/>)";
    const std::string xml = fmt::format(
        R"(<mujoco><option timestep="5e-5"/>
  <extension><plugin plugin="mjstepper.stepper"/></extension>
  <worldbody>{}</worldbody>
  <tendon><fixed name="sum"><joint joint="x1" coef="1"/><joint joint="x2" coef="1"/></fixed></tendon>
  <actuator><plugin name="m1" tendon="sum" gear="100" plugin="mjstepper.stepper" armature="0.36e-4">{}</plugin></actuator>
</mujoco>)",
        nested ? a + b + "</body>" : a + "</body>" + b, Config("input", "velocity"));
    std::string error;
    const ModelPtr m = LoadModel(xml, &error);
    ASSERT_TRUE(m) << error;
    const DataPtr d(mj_makeData(m.get()));
    mj_forward(m.get(), d.get());
    mjtNum dense[4];
    mj_fullM(m.get(), d.get(), dense);
    cross.push_back(dense[1]);
    count.push_back(warnings.size());
  }
  mju_user_warning = previous;
  EXPECT_EQ(cross[0], 0.0);                                 // separate trees: no cross term
  EXPECT_NEAR(cross[1], 1.5 + 0.36e-4 * 100 * 100, 1e-12);  // nested: m_b + J·gear²
  ASSERT_GT(count[0], 0u);
  EXPECT_EQ(count[1], count[0]);  // none for the nested carriages
  EXPECT_THAT(warnings[0], AllOf(HasSubstr("actuator 'm1'"), HasSubstr("tendon 'sum' spans 2 "
                                                                       "kinematic trees")));
}

}  // namespace
}  // namespace mjstepper::testing
