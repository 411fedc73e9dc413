// The sub-stepped rotor (issue 30, item 2; SPEC §11; core/substep.h): the rotor and its drive
// integrated in sub-steps within MuJoCo's step, its end angle handed to MuJoCo as its position.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "test_model.h"

namespace mjstepper::testing {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

// models/tsui_rigid.xml (the Tsui rotor on its dry friction and damping, velocity input) at
// timestep h with the given coupling.
std::string TsuiRigid(double h, const std::string& coupling) {
  std::string xml = ShippedModel("tsui_rigid.xml");
  const std::string option = R"(timestep="5e-5")";
  xml.replace(xml.find(option), option.size(), fmt::format(R"(timestep="{}")", h));
  const std::string input = R"(<config key="input" value="velocity"/>)";
  xml.insert(xml.find(input), Config("coupling", coupling));
  return xml;
}

// The standard deviation of the rotor's mean speed over each millisecond from 0.1 s to 0.3 s at
// 20 rad/s (rad/s): the velocity ripple as a 1 kHz log sees it.
double RippleAt(double h, const std::string& coupling) {
  std::string error;
  const ModelPtr m = LoadModel(TsuiRigid(h, coupling), &error);
  EXPECT_TRUE(m) << error;
  if (!m) return NAN;
  const DataPtr d(mj_makeData(m.get()));
  d->ctrl[0] = 20;  // rad/s
  const int per_ms = static_cast<int>(std::lround(1e-3 / h));
  std::vector<double> angles;  // rad, at each millisecond
  for (int k = 1; k <= 300 * per_ms; ++k) {
    mj_step(m.get(), d.get());
    if (k % per_ms == 0) angles.push_back(d->qpos[0]);
  }
  std::vector<double> speeds;  // rad/s
  for (size_t i = 100; i < angles.size(); ++i) speeds.push_back((angles[i] - angles[i - 1]) / 1e-3);
  double mean = 0, square = 0;
  for (double v : speeds) mean += v / speeds.size();
  for (double v : speeds) square += (v - mean) * (v - mean) / speeds.size();
  return std::sqrt(square);
}

// At ωn·h = 0.89 (1 ms; the rotor with its detent's worst case rings at 149 Hz) the sub-stepped
// rotor's velocity ripple is the 10 µs reference's within 2 % (measured +0.15 %: the sub-steps
// resolve the full-step forcing at 4·Nr·20 rad/s with ω·δ <= 0.3, 14 sub-steps; with the ring
// alone bounding them at 0.3, 4 sub-steps, it was +1.0 %). The consistent coupling at 1 ms is
// 25 % high: the band tells them apart.
TEST(Substepped, TheTsuiRippleAtOneMillisecondIsTheFineReferences) {
  const double reference = RippleAt(1e-5, "consistent");
  ASSERT_GT(reference, 0.5);  // rad/s: there is a ripple to match (0.709)
  EXPECT_NEAR(RippleAt(1e-3, "substepped") / reference, 1.0, 0.02);
  EXPECT_GT(RippleAt(1e-3, "consistent") / reference, 1.1);
}

// Two damped joints in series, each driven by a Tsui stepper through a gear (the rotors coupled
// through M, each joint damped by its dof damping and its actuator's): MuJoCo's step lands every
// rotor on its sub-stepped angle, to round-off (R-2 takes the damping MuJoCo's Euler step applies
// implicitly into account: without it the landing misses by about h·D/J, 3 % of the step's motion
// here), so MuJoCo's speed after each step is the chord the plugin kept.
TEST(Substepped, MuJoCoLandsOnTheSubsteppedAngles) {
  const std::string model = R"(<mujoco>
  <option timestep="1e-3" integrator="implicitfast" gravity="0 0 -9.81"/>
  <extension><plugin plugin="mjstepper.stepper">
    <instance name="drive"><config key="motor" value="tsui2009"/>
      <config key="input" value="velocity"/><config key="coupling" value="substepped"/></instance>
  </plugin></extension>
  <worldbody>
    <body name="upper"><joint name="shoulder" type="hinge" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.01" mass="0.3" contype="0"
            conaffinity="0"/>
      <body name="lower" pos="0.2 0 0"><joint name="elbow" type="hinge" axis="0 1 0"
                                              damping="0.02"/>
        <geom type="capsule" fromto="0 0 0 0.15 0 0" size="0.01" mass="0.2" contype="0"
              conaffinity="0"/></body></body>
  </worldbody>
  <actuator>
    <plugin name="a1" joint="shoulder" gear="20" instance="drive" armature="0.36e-4"
            damping="0.001"/>
    <plugin name="a2" joint="elbow" gear="10" instance="drive" armature="0.36e-4"
            damping="0.001"/>
  </actuator></mujoco>)";
  std::string error;
  const ModelPtr m = LoadModel(model, &error);
  ASSERT_TRUE(m) << error;
  const DataPtr d(mj_makeData(m.get()));
  // The instance's state: two drive slots, the constraint forces (1 + nv), then per slot the
  // kSubstepExtras (7) values and a tentative drive state (plugin/stepper.h, SubstepSlot).
  const int na = 2, nv = m->nv;
  const int drive = (m->plugin_statenum[0] - 1 - nv - 7 * na) / (2 * na);
  const mjtNum* state = d->plugin_state + m->plugin_stateadr[0];
  auto chord = [&](int slot) { return state[na * drive + 1 + nv + slot * (7 + drive) + 2]; };
  const double gears[2] = {20, 10};
  double worst = 0, largest = 0;  // rad/s
  for (int k = 0; k < 400; ++k) {
    d->ctrl[0] = 20;
    d->ctrl[1] = -10;  // rad/s at the rotors
    mj_step(m.get(), d.get());
    if (k < 2) continue;
    for (int i = 0; i < na; ++i) {
      const double speed = gears[i] * d->qvel[i];  // rad/s, MuJoCo's rotor speed
      worst = std::max(worst, std::abs(speed - chord(i)));
      largest = std::max(largest, std::abs(speed));
    }
  }
  ASSERT_GT(largest, 5.0);  // they move
  EXPECT_LT(worst, 1e-10 * largest);
}

// The sub-stepped rotor at 1 ms passes the timestep rule (its spring is integrated within the
// step, not by MuJoCo: the rule judges the model's other modes, here none); the consistent
// coupling at 1 ms does not.
TEST(Substepped, TheTimestepRuleLeavesTheRotorsSpringOut) {
  std::vector<std::string> warnings;
  static std::vector<std::string>* captured = nullptr;
  captured = &warnings;
  mju_user_warning = [](const char* message) { captured->push_back(message); };
  std::vector<size_t> count;
  for (const char* coupling : {"substepped", "consistent"}) {
    const ModelPtr m = LoadModel(TsuiRigid(1e-3, coupling));
    EXPECT_TRUE(m);
    count.push_back(warnings.size());
  }
  mju_user_warning = nullptr;
  EXPECT_EQ(count[0], 0u);
  ASSERT_GT(count[1], 0u);
  EXPECT_THAT(warnings.back(), HasSubstr("too coarse"));
}

// STEP/DIR in a sub-step: the drive spreads the step's pulses to the command's end (the MuJoCo
// step's), so a 100 µs sub-step of a 1 ms step moves θcmd by a tenth of the step's count, and the
// last sub-step ends on the count exactly. (Spread over each sub-step instead, θcmd ran a whole
// step ahead: StealthChop's lag at 1 ms read 0.39 full steps against the reference's 0.51.)
TEST(Substepped, StepDirPulsesSpreadOverTheMuJoCoStep) {
  const std::map<std::string, std::string> kv = {{"motor", "17hs19_2004s1"},
                                                 {"driver", "tmc2209"},
                                                 {"drive", "spreadcycle"},
                                                 {"input", "steps"}};
  const Drive drive = DriveFromConfig(kv);
  DriveState state = drive.Rest(0.0, 0.0, 0.0);
  const double count = 20;  // microsteps by the step's end
  for (int k = 0; k < 10; ++k) {
    ASSERT_EQ(drive.Advance(&state, k * 1e-4, (k + 1) * 1e-4, 0.0, count, 1e-3),
              AdvanceStatus::kOk);
    if (k == 0) {
      EXPECT_NEAR(state.theta_cmd, 0.1 * count * drive.StepAngle(), 1e-12);
    }
  }
  EXPECT_EQ(state.theta_cmd, count * drive.StepAngle());
}

// A model spring acting on a sub-stepped rotor still binds the timestep: R-1 holds the other
// forces over the step, and on models/tsui_coupling.xml (a 50 N·m/rad coupling spring between
// rotor and load) the sub-stepped run goes unstable from 562 µs (docs/coupling.md). With the
// stepper's spring left out, the coupling's mode (230 Hz, the rotor free) moves the rotor: the
// rule counts it as a stepper's mode, which `run` refuses, and names the rotor; it no longer says
// that no stepper takes part.
TEST(Substepped, AModeThatMovesASubsteppedRotorIsAStepperMode) {
  std::string xml = ShippedModel("tsui_coupling.xml");
  const std::string option = R"(timestep="5e-5")";
  xml.replace(xml.find(option), option.size(), R"(timestep="5.6e-4")");
  const std::string input = R"(<config key="input" value="velocity"/>)";
  xml.insert(xml.find(input), Config("coupling", "substepped"));
  std::vector<std::string> warnings;
  static std::vector<std::string>* captured = nullptr;
  captured = &warnings;
  mju_user_warning = [](const char* message) { captured->push_back(message); };
  std::string error;
  const ModelPtr m = LoadModel(xml, &error);
  mju_user_warning = nullptr;
  ASSERT_TRUE(m) << error;
  ASSERT_FALSE(warnings.empty());
  EXPECT_THAT(warnings.front(),
              AllOf(HasSubstr("joint 'coupling'"), HasSubstr("sub-stepped rotor 'shaft' moves"),
                    ::testing::Not(HasSubstr("not refused"))));
}

// What the sub-stepped rotor cannot take is refused at load, naming the attribute and the fix:
// RK4 (four stages, four states), an actuator dyntype (the command is the step's start ctrl) and a
// model whose steppers are coupled two ways.
TEST(Substepped, RefusesRk4DyntypeAndMixedCouplings) {
  std::string error;
  std::string xml = TsuiRigid(1e-3, "substepped");
  const std::string option = R"(integrator="implicitfast")";
  xml.replace(xml.find(option), option.size(), R"(integrator="RK4")");
  EXPECT_FALSE(LoadModel(xml, &error));
  EXPECT_THAT(error, AllOf(HasSubstr("coupling = \"substepped\""), HasSubstr("RK4"),
                           HasSubstr("integrator=\"Euler\"")));
  xml = TsuiRigid(1e-3, "substepped");
  const std::string damping = R"(damping="0.001">)";
  xml.replace(xml.find(damping), damping.size(),
              R"(damping="0.001" dyntype="filter" dynprm="0.01">)");
  EXPECT_FALSE(LoadModel(xml, &error));
  EXPECT_THAT(error, AllOf(HasSubstr("coupling = \"substepped\""), HasSubstr("dyntype")));
  const std::string mixed =
      RotorModel(TsuiActuator("m1", "j1", Config("coupling", "substepped")) +
                     TsuiActuator("m2", "j2", Config("coupling", "consistent")),
                 "", "", 2, 1e-4);
  EXPECT_FALSE(LoadModel(mixed, &error));
  EXPECT_THAT(error, AllOf(HasSubstr("coupling = \"substepped\" here but \"consistent\""),
                           HasSubstr("actuator 'm2'")));
}

// RK4 set after loading (which refuses it): the sub-stepped steppers fall back to the motor's
// torque at the step's start and their own advance, said once; the run goes on, finite.
TEST(Substepped, Rk4SetAfterLoadingFallsBackAndSaysSo) {
  std::string error;
  const ModelPtr m = LoadModel(TsuiRigid(1e-4, "substepped"), &error);
  ASSERT_TRUE(m) << error;
  const DataPtr d(mj_makeData(m.get()));
  m->opt.integrator = mjINT_RK4;  // (a new mjData would be refused: its init checks the model)
  std::vector<std::string> warnings;
  static std::vector<std::string>* captured = nullptr;
  captured = &warnings;
  mju_user_warning = [](const char* message) { captured->push_back(message); };
  d->ctrl[0] = 10;  // rad/s
  for (int k = 0; k < 2000; ++k) mj_step(m.get(), d.get());
  mju_user_warning = nullptr;
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_THAT(warnings[0], AllOf(HasSubstr("RK4"), HasSubstr("explicit coupling")));
  EXPECT_NEAR(d->qvel[0], 10, 2);  // rad/s: it turns with its command
}

}  // namespace
}  // namespace mjstepper::testing
