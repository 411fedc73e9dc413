// Issue 30, item 2's requirement: a run restored with mj_setState replays bit for bit under the
// consistent coupling on a model with a constraint. The coupling reads the previous step's
// constraint forces (plugin/stepper.cc, ConsistentForces), which no mjSTATE holds when read from
// d->qfrc_constraint (|Δq| 8e-15 rad here after 2 000 steps, 2.7e-13 on the issue's model); they
// are now kept in the plugin state, which mjSTATE_INTEGRATION holds. The sub-stepped rotor keeps
// its speed and its tentative drive state there too (plugin/stepper.h, SubstepSlot): replayed at 1
// ms.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "test_model.h"

namespace mjstepper::testing {
namespace {

// A rotor driving, through a 2:1 joint equality (the constraint carries torque every step), a
// pendulum that gravity loads, at 120 r/min; its stepper `actuator` (a <plugin> on joint shaft).
std::string Model(const std::string& actuator, double timestep) {
  return fmt::format(R"(<mujoco><option timestep="{}" integrator="implicitfast"/>
  <extension><plugin plugin="mjstepper.stepper"/></extension>
  <worldbody>
    <body name="rotor"><joint name="shaft" type="hinge" axis="0 0 1"/>
      <geom type="cylinder" size="0.01 0.01" mass="0.001" contype="0" conaffinity="0"/></body>
    <body name="pendulum" pos="0.2 0 0"><joint name="swing" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.05 0 0" size="0.005" mass="0.05" contype="0"
            conaffinity="0"/></body>
  </worldbody>
  <equality><joint joint1="swing" joint2="shaft" polycoef="0 0.5 0 0 0"/></equality>
  <actuator>{}</actuator></mujoco>)",
                     timestep, actuator);
}

// The Tsui PI drive (at its interrupts), the averaged SpreadCycle (whose phases' modes are state
// too), the switching SpreadCycle at 50 µs (each phase's last cycle, whose ripple the handed torque
// leaves out), the Tsui drive with the sub-stepped rotor at 1 ms (its speed is state), averaged
// voltage microstepping, the averaged SpreadCycle sub-stepped at 1 ms (its velocity crossings), and
// the averaged PI drive and servo sub-stepped at 1 ms (the servo's held iq* and the one before it),
// and Kim's laws averaged (the STMMS sub-stepped at 1 ms, the FOC at 50 µs).
struct Case {
  const char* name;
  const char* actuator;
  double timestep;  // s
};
class Replay : public ::testing::TestWithParam<Case> {};

INSTANTIATE_TEST_SUITE_P(
    Drives, Replay,
    ::testing::Values(
        Case{"TsuiPi",
             R"(<plugin name="shaft" joint="shaft" plugin="mjstepper.stepper" armature="0.36e-4">)"
             R"(<config key="motor" value="tsui2009"/><config key="input" value="velocity"/>)"
             R"(</plugin>)",
             5e-5},
        Case{"AveragedSpreadCycle",
             R"(<plugin name="shaft" joint="shaft" plugin="mjstepper.stepper" armature="8.2e-6">)"
             R"(<config key="motor" value="17hs19_2004s1"/><config key="driver" value="tmc2209"/>)"
             R"(<config key="fidelity" value="averaged"/><config key="input" value="velocity"/>)"
             R"(</plugin>)",
             5e-5},
        Case{"SwitchingSpreadCycleTakingOutItsRipple",  // (its last cycle is state: switching.h)
             R"(<plugin name="shaft" joint="shaft" plugin="mjstepper.stepper" armature="8.2e-6">)"
             R"(<config key="motor" value="17hs19_2004s1"/><config key="driver" value="tmc2209"/>)"
             R"(<config key="input" value="velocity"/></plugin>)",
             5e-5},
        Case{"SubsteppedTsuiAt1ms",
             R"(<plugin name="shaft" joint="shaft" plugin="mjstepper.stepper" armature="0.36e-4">)"
             R"(<config key="motor" value="tsui2009"/><config key="input" value="velocity"/>)"
             R"(<config key="coupling" value="substepped"/></plugin>)",
             1e-3},
        Case{
            "AveragedVoltageMicrostep",
            R"(<plugin name="shaft" joint="shaft" plugin="mjstepper.stepper" armature="0.36e-4">)"
            R"(<config key="motor" value="tsui2009"/><config key="drive" value="voltage_microstep"/>)"
            R"(<config key="fidelity" value="averaged"/><config key="input" value="velocity"/>)"
            R"(</plugin>)",
            5e-5},
        Case{"SubsteppedAveragedSpreadCycleAt1ms",
             R"(<plugin name="shaft" joint="shaft" plugin="mjstepper.stepper" armature="8.2e-6">)"
             R"(<config key="motor" value="17hs19_2004s1"/><config key="driver" value="tmc2209"/>)"
             R"(<config key="fidelity" value="averaged"/><config key="input" value="velocity"/>)"
             R"(<config key="coupling" value="substepped"/></plugin>)",
             1e-3},
        Case{"SubsteppedAveragedPiDriveAt1ms",
             R"(<plugin name="shaft" joint="shaft" plugin="mjstepper.stepper" armature="0.36e-4">)"
             R"(<config key="motor" value="tsui2009"/><config key="damping" value="all"/>)"
             R"(<config key="fidelity" value="averaged"/><config key="input" value="velocity"/>)"
             R"(<config key="coupling" value="substepped"/></plugin>)",
             1e-3},
        Case{"SubsteppedAveragedServoAt1ms",
             R"(<plugin name="shaft" joint="shaft" plugin="mjstepper.stepper" armature="0.36e-4">)"
             R"(<config key="motor" value="tsui2009"/><config key="drive" value="servo"/>)"
             R"(<config key="damping" value="all"/><config key="fidelity" value="averaged"/>)"
             R"(<config key="input" value="velocity"/><config key="coupling" value="substepped"/>)"
             R"(</plugin>)",
             1e-3},
        Case{"SubsteppedAveragedStmmsAt1ms",  // (its e0 is state: averaged_feed_forward.h)
             R"(<plugin name="shaft" joint="shaft" plugin="mjstepper.stepper" armature="4.8e-5">)"
             R"(<config key="motor" value="kim2016"/><config key="drive" value="stmms"/>)"
             R"(<config key="encoder_counts" value="0"/><config key="fidelity" value="averaged"/>)"
             R"(<config key="input" value="velocity"/><config key="coupling" value="substepped"/>)"
             R"(</plugin>)",
             1e-3},
        Case{"AveragedHighGainFoc",
             R"(<plugin name="shaft" joint="shaft" plugin="mjstepper.stepper" armature="4.8e-5">)"
             R"(<config key="motor" value="kim2016"/><config key="drive" value="foc"/>)"
             R"(<config key="encoder_counts" value="0"/><config key="fidelity" value="averaged"/>)"
             R"(<config key="input" value="velocity"/></plugin>)",
             5e-5}),
    [](const ::testing::TestParamInfo<Case>& info) { return std::string(info.param.name); });

TEST_P(Replay, SetStateReplaysBitForBitWithAConstraint) {
  std::string error;
  const ModelPtr m = LoadModel(Model(GetParam().actuator, GetParam().timestep), &error);
  ASSERT_TRUE(m) << error;
  const mjtState spec = mjSTATE_INTEGRATION;
  const DataPtr d(mj_makeData(m.get()));
  // 0.05 s, then 0.1 s replayed.
  const int steps = static_cast<int>(std::lround(0.05 / GetParam().timestep));
  for (int k = 0; k < steps; ++k) {
    d->ctrl[0] = 12.57;  // rad/s
    mj_step(m.get(), d.get());
  }
  ASSERT_GT(mju_norm(d->qfrc_constraint, m->nv), 0);  // the constraint carries force
  std::vector<mjtNum> state(mj_stateSize(m.get(), spec));
  mj_getState(m.get(), d.get(), state.data(), spec);
  // The original run goes on; a fresh mjData (its qfrc_constraint zero) takes the saved state.
  const DataPtr replay(mj_makeData(m.get()));
  mj_setState(m.get(), replay.get(), state.data(), spec);
  for (int k = 0; k < 2 * steps; ++k) {
    for (mjData* x : {d.get(), replay.get()}) {
      x->ctrl[0] = 12.57;
      mj_step(m.get(), x);
    }
  }
  EXPECT_EQ(std::memcmp(d->qpos, replay->qpos, sizeof(mjtNum) * m->nq), 0)
      << "qpos differs by " << d->qpos[0] - replay->qpos[0];
  EXPECT_EQ(std::memcmp(d->qvel, replay->qvel, sizeof(mjtNum) * m->nv), 0);
  EXPECT_EQ(std::memcmp(d->plugin_state, replay->plugin_state, sizeof(mjtNum) * m->npluginstate),
            0);
}

}  // namespace
}  // namespace mjstepper::testing
