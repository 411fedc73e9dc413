// mjstepper.stepper on real MuJoCo: the plugin checklist (STYLE.md §5, after MuJoCo's pid_test).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <future>
#include <limits>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/drive.h"
#include "core/signals.h"
#include "core/units.h"
#include "stepper.h"
#include "test_model.h"

namespace mjstepper::testing {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

std::string VelocityTsui(const std::string& name = "m1", const std::string& joint = "j1") {
  return TsuiActuator(name, joint, Config("input", "velocity"));
}

// One velocity Tsui rotor "m1" with a signal probe "s" on it.
std::string ProbedVelocityRotor() {
  return RotorModel(
      VelocityTsui(), "",
      R"(<plugin name="s" plugin="mjstepper.stepper" objtype="actuator" objname="m1"/>)");
}

// A speed ramp that crosses the 42.5 r/min resonance, so that states are far from trivial.
double RampSpeed(double t) { return RpmToRadPerSec(100) * std::min(1.0, t / 0.05); }

void Step(const mjModel* m, mjData* d, int n) {
  for (int k = 0; k < n; ++k) {
    for (int u = 0; u < m->nu; ++u) d->ctrl[u] = RampSpeed(d->time) * (1 + 0.1 * u);
    mj_step(m, d);
  }
}

void ExpectSameState(const mjModel* m, const mjData* a, const mjData* b) {
  EXPECT_EQ(a->time, b->time);
  for (int i = 0; i < m->nq; ++i) EXPECT_EQ(a->qpos[i], b->qpos[i]) << "qpos " << i;
  for (int i = 0; i < m->nv; ++i) EXPECT_EQ(a->qvel[i], b->qvel[i]) << "qvel " << i;
  for (int i = 0; i < m->npluginstate; ++i) {
    EXPECT_EQ(a->plugin_state[i], b->plugin_state[i]) << "plugin_state " << i;
  }
}

TEST(StepperPlugin, LoadsFromMjcf) {
  std::string error;
  const ModelPtr m = LoadModel(RotorModel(VelocityTsui()), &error);
  ASSERT_TRUE(m) << error;
  EXPECT_EQ(m->nu, 1);
  EXPECT_EQ(m->nplugin, 1);
  // The drive's core (40 doubles), current_microstep's two PI integrators, and the constraint
  // forces of the last step (a flag and one dof; plugin/stepper.h, ConstraintForces).
  EXPECT_EQ(m->plugin_statenum[0], 42 + 1 + m->nv);
  EXPECT_DOUBLE_EQ(m->actuator_armature[0], 0.36e-4);
}

// The rotor follows a velocity command: after the ramp to 100 r/min and 0.15 s of cruise its mean
// speed over the last 0.1 s is the command (a synchronous motor: no slip, ±0.5 % for the residual
// oscillation at the window's ends) and no step is lost.
TEST(StepperPlugin, RotorFollowsVelocityCommand) {
  const ModelPtr m = LoadModel(ProbedVelocityRotor());
  ASSERT_TRUE(m);
  const DataPtr d(mj_makeData(m.get()));
  Step(m.get(), d.get(), 4000);  // 0.2 s
  const double q0 = d->qpos[0];
  Step(m.get(), d.get(), 2000);  // 0.1 s
  const double mean_speed = (d->qpos[0] - q0) / 0.1;
  EXPECT_NEAR(mean_speed, RpmToRadPerSec(100), 0.005 * RpmToRadPerSec(100));
  EXPECT_EQ(d->sensordata[kLostSteps], 0.0);
}

// Under each of MuJoCo's integrators the drive advances once per step and the rotor follows the
// command (mean speed over 0.1 s after a 0.2 s ramp-and-settle within 0.5 %, as above).
TEST(StepperPlugin, WorksUnderEveryIntegrator) {
  for (const char* integrator : {"Euler", "implicitfast", "implicit", "RK4"}) {
    std::string xml = RotorModel(VelocityTsui());
    xml.replace(xml.find("implicitfast"), 12, integrator);
    const ModelPtr m = LoadModel(xml);
    ASSERT_TRUE(m) << integrator;
    const DataPtr d(mj_makeData(m.get()));
    Step(m.get(), d.get(), 4000);
    const double q0 = d->qpos[0];
    Step(m.get(), d.get(), 2000);
    EXPECT_NEAR((d->qpos[0] - q0) / 0.1, RpmToRadPerSec(100), 0.005 * RpmToRadPerSec(100))
        << integrator;
    // One interrupt per 50 µs whatever the integrator: 6000 steps, 6000 ticks (the index of the
    // next one, its anchor's plus those after it, counts them).
    DriveCoreState core;
    std::memcpy(static_cast<void*>(&core), d->plugin_state, sizeof(core));
    EXPECT_EQ(Drive::NextTickIndex(core), 6000) << integrator;
  }
}

TEST(StepperPlugin, CopyDataContinuesIdentically) {
  const ModelPtr m = LoadModel(RotorModel(VelocityTsui()));
  ASSERT_TRUE(m);
  const DataPtr a(mj_makeData(m.get()));
  Step(m.get(), a.get(), 777);
  const DataPtr b(mj_copyData(nullptr, m.get(), a.get()));
  Step(m.get(), a.get(), 1000);
  Step(m.get(), b.get(), 1000);
  ExpectSameState(m.get(), a.get(), b.get());
}

TEST(StepperPlugin, ResetRestoresInitialState) {
  const ModelPtr m = LoadModel(RotorModel(VelocityTsui()));
  ASSERT_TRUE(m);
  const DataPtr fresh(mj_makeData(m.get()));
  const DataPtr used(mj_makeData(m.get()));
  Step(m.get(), used.get(), 1500);
  mj_resetData(m.get(), used.get());
  for (int i = 0; i < m->npluginstate; ++i) EXPECT_EQ(used->plugin_state[i], 0.0);
  Step(m.get(), fresh.get(), 1000);
  Step(m.get(), used.get(), 1000);
  ExpectSameState(m.get(), fresh.get(), used.get());
}

// A keyframe restores qpos; the drive then starts at rest on the rotor wherever it is (SPEC §6):
// with a zero speed command the rotor stays put (to the 1e-12 rad of round-off).
TEST(StepperPlugin, KeyframeStartsDriveAtRestOnTheRotor) {
  std::string xml = RotorModel(VelocityTsui());
  xml.replace(xml.find("</mujoco>"), 9,
              R"(<keyframe><key name="k" qpos="0.7"/></keyframe></mujoco>)");
  const ModelPtr m = LoadModel(xml);
  ASSERT_TRUE(m);
  const DataPtr d(mj_makeData(m.get()));
  mj_resetDataKeyframe(m.get(), d.get(), 0);
  // Detent pulls the rotor to its nearest detent-plus-magnet equilibrium: a small move only.
  for (int k = 0; k < 2000; ++k) mj_step(m.get(), d.get());
  EXPECT_NEAR(d->qpos[0], 0.7, 2e-3);
}

TEST(StepperPlugin, ComputeIsIdempotent) {
  const ModelPtr m = LoadModel(RotorModel(VelocityTsui()));
  ASSERT_TRUE(m);
  const DataPtr d(mj_makeData(m.get()));
  Step(m.get(), d.get(), 300);
  const std::vector<double> state(d->plugin_state, d->plugin_state + m->npluginstate);
  mj_forward(m.get(), d.get());
  const double force = d->actuator_force[0];
  mj_forward(m.get(), d.get());
  EXPECT_EQ(d->actuator_force[0], force);
  for (int i = 0; i < m->npluginstate; ++i) EXPECT_EQ(d->plugin_state[i], state[i]);
}

TEST(StepperPlugin, FiniteDifferencingLeavesDriveStateAlone) {
  const ModelPtr m = LoadModel(RotorModel(VelocityTsui()));
  ASSERT_TRUE(m);
  const DataPtr d(mj_makeData(m.get()));
  const DataPtr twin(mj_makeData(m.get()));
  Step(m.get(), d.get(), 500);
  Step(m.get(), twin.get(), 500);
  const int nx = 2 * m->nv + m->na;
  std::vector<mjtNum> A(nx * nx), B(nx * m->nu);
  mjd_transitionFD(m.get(), d.get(), 1e-6, 1, A.data(), B.data(), nullptr, nullptr);
  ExpectSameState(m.get(), d.get(), twin.get());
  // The Jacobian sees the motor: ∂qvel'/∂qpos ≈ −h·T'/J, T' = 28.5 N·m/rad (currents held).
  EXPECT_LT(A[nx * 1 + 0], 0.0);
  Step(m.get(), d.get(), 200);
  Step(m.get(), twin.get(), 200);
  ExpectSameState(m.get(), d.get(), twin.get());
}

// A named instance shared by two actuators, and two implicit instances with the same config,
// give bit-identical motion: each actuator keeps its own drive state.
TEST(StepperPlugin, SharedInstanceAndSeparateInstancesGiveSameMotion) {
  const std::string shared_actuators =
      R"(<plugin name="m1" joint="j1" instance="drive" armature="0.36e-4" damping="0.001"/>)"
      R"(<plugin name="m2" joint="j2" instance="drive" armature="0.36e-4" damping="0.001"/>)";
  const std::string shared_instance =
      R"(<instance name="drive">)" + Config("input", "velocity") + "</instance>";
  const ModelPtr shared = LoadModel(RotorModel(shared_actuators, shared_instance, "", 2));
  const ModelPtr separate =
      LoadModel(RotorModel(VelocityTsui("m1", "j1") + VelocityTsui("m2", "j2"), "", "", 2));
  ASSERT_TRUE(shared);
  ASSERT_TRUE(separate);
  EXPECT_EQ(shared->nplugin, 1);
  EXPECT_EQ(separate->nplugin, 2);
  const DataPtr a(mj_makeData(shared.get())), b(mj_makeData(separate.get()));
  Step(shared.get(), a.get(), 2000);
  Step(separate.get(), b.get(), 2000);
  for (int j = 0; j < 2; ++j) {
    EXPECT_EQ(a->qpos[j], b->qpos[j]) << "joint " << j;
    EXPECT_EQ(a->qvel[j], b->qvel[j]) << "joint " << j;
  }
  EXPECT_NE(a->qpos[0], a->qpos[1]);  // different commands: the drives did not share state
}

// One mjData per thread, 4 threads, each bit-identical to the same run done serially.
TEST(StepperPlugin, OneDataPerThreadMatchesSerial) {
  const ModelPtr m = LoadModel(RotorModel(VelocityTsui()));
  ASSERT_TRUE(m);
  constexpr int kThreads = 4;
  auto run = [&](int i, std::vector<double>* out) {
    DataPtr d(mj_makeData(m.get()));
    for (int k = 0; k < 3000; ++k) {
      d->ctrl[0] = RampSpeed(d->time) * (1 + 0.2 * i);
      mj_step(m.get(), d.get());
    }
    out->assign(d->plugin_state, d->plugin_state + m->npluginstate);
    out->push_back(d->qpos[0]);
    out->push_back(d->qvel[0]);
  };
  std::vector<std::vector<double>> serial(kThreads), parallel(kThreads);
  for (int i = 0; i < kThreads; ++i) run(i, &serial[i]);
  std::vector<std::thread> threads;
  for (int i = 0; i < kThreads; ++i) threads.emplace_back(run, i, &parallel[i]);
  for (std::thread& t : threads) t.join();
  for (int i = 0; i < kThreads; ++i) EXPECT_EQ(parallel[i], serial[i]) << "thread " << i;
  EXPECT_NE(serial[0], serial[1]);
}

// The signal sensor reports the drive's state: at rest on θ = 0 with the Tsui drive, ia = 1.9 A,
// ib = 0, id = 1.9 A; torque_total is the motor's τm + τdet, which MuJoCo applies as it is with
// coupling="explicit" (the consistent coupling hands it C-2 instead: Coupling tests).
TEST(StepperPlugin, SignalSensorReportsDriveState) {
  const ModelPtr m = LoadModel(ProbedVelocityRotor());
  ASSERT_TRUE(m);
  EXPECT_EQ(m->sensor_dim[0], kNumSignals);
  const DataPtr d(mj_makeData(m.get()));
  mj_forward(m.get(), d.get());
  const double* s = d->sensordata;
  EXPECT_DOUBLE_EQ(s[kCurrentA], 1.9);
  EXPECT_DOUBLE_EQ(s[kCurrentB], 0.0);
  EXPECT_DOUBLE_EQ(s[kCurrentD], 1.9);
  EXPECT_DOUBLE_EQ(s[kVoltageA], 1.9 * 0.9);
  Step(m.get(), d.get(), 500);
  mj_forward(m.get(), d.get());
  EXPECT_NE(s[kTorqueTotal], d->actuator_force[0]);  // C-2
  EXPECT_NEAR(s[kTorqueTotal], s[kTorqueEm] + s[kTorqueDetent], 1e-15);
  std::string xml = ProbedVelocityRotor();
  xml.replace(xml.find("</plugin>", xml.find("<actuator>")), 0, Config("coupling", "explicit"));
  const ModelPtr explicit_model = LoadModel(xml);
  ASSERT_TRUE(explicit_model);
  const DataPtr e(mj_makeData(explicit_model.get()));
  Step(explicit_model.get(), e.get(), 500);
  mj_forward(explicit_model.get(), e.get());
  EXPECT_EQ(e->sensordata[kTorqueTotal], e->actuator_force[0]);
  EXPECT_NEAR(s[kLoadAngle], 50 * (s[kThetaCmd] - d->actuator_length[0]), 1e-12);
}

// With gear g the rotor angle is g·q (actuator_length): a velocity command ω turns the joint at
// ω/g. The actuator's armature and damping are the rotor's, J and B: MuJoCo reflects them to the
// joint as g²·J and g²·B.
TEST(StepperPlugin, GearScalesRotorToJoint) {
  const std::string actuator =
      R"(<plugin name="m1" joint="j1" plugin="mjstepper.stepper" gear="4" armature="0.36e-4" )"
      R"(damping="0.001">)" +
      Config("input", "velocity") + "</plugin>";
  const ModelPtr m = LoadModel(RotorModel(actuator));
  ASSERT_TRUE(m);
  {
    const DataPtr d(mj_makeData(m.get()));
    d->qvel[0] = 1;
    mj_forward(m.get(), d.get());
    EXPECT_NEAR(d->M[0], 16 * 0.36e-4 + 1e-9, 1e-12);  // g²·J plus the body's own 1e-9
    EXPECT_NEAR(d->qfrc_passive[0], -16 * 0.001, 1e-12);
  }
  const DataPtr d(mj_makeData(m.get()));
  Step(m.get(), d.get(), 4000);
  const double q0 = d->qpos[0];
  Step(m.get(), d.get(), 2000);
  EXPECT_NEAR((d->qpos[0] - q0) / 0.1, RpmToRadPerSec(100) / 4, 0.005 * RpmToRadPerSec(100) / 4);
}

// Static friction S-6 as the joint's frictionloss (MuJoCo's dry friction, solved as a constraint):
// with the motor torque off (identification mode with no compensation) and detent off, a load
// torque of 0.02 N·m < Fs = 0.029 N·m leaves the rotor stuck, and 0.04 N·m > Fs turns it, towards
// (0.04 − 0.029)/B = 11 rad/s. MuJoCo's friction is a soft constraint: with the stiffest
// settings (solreffriction = 2·timestep, solimpfriction 0.99-0.999, as models/tsui_rigid.xml) it
// creeps at about 3e-4 rad/s under 0.02 N·m, so "stuck" is < 5e-4 rad in 0.5 s (1/60 full step).
TEST(StepperPlugin, StaticFrictionSticksBelowFsAndSlipsAbove) {
  const std::string actuator =
      TsuiActuator("m1", "j1",
                   Config("drive", "identification") + Config("detent", "none") +
                       Config("friction_compensation", "0"));
  const ModelPtr m = LoadModel(RotorModel(
      actuator, "", "", 1, 5e-5,
      R"(frictionloss="0.029" solreffriction="1e-4 1" solimpfriction="0.99 0.999 0.001")"));
  ASSERT_TRUE(m);
  for (double load : {0.02, 0.04}) {
    const DataPtr d(mj_makeData(m.get()));
    for (int k = 0; k < 10000; ++k) {
      d->qfrc_applied[0] = load;
      mj_step(m.get(), d.get());
    }
    if (load < 0.029) {
      EXPECT_LT(std::abs(d->qpos[0]), 5e-4) << "load " << load;
    } else {
      // The drive's PI loop holds the currents near zero against the back-EMF, so the rotor
      // runs near the 11 rad/s of the friction-viscous balance; 1 rad/s says it slips freely.
      EXPECT_GT(d->qvel[0], 1.0) << "load " << load;
      EXPECT_GT(d->qpos[0], 0.5) << "load " << load;
    }
  }
}

// Pull-out at rest and the slip counter: a rotor held by current microstepping at I = 1.9 A,
// without detent or friction (its holding torque is then Km·I·sin δ alone), under an external
// torque rising at 0.25 N·m/s, first slips when the torque passes Km·I = 0.57 N·m, and then counts
// one slip per electrical cycle it falls behind. ± 2 %: the ramp adds 0.25 N·m/s × the time the
// rotor needs to run from the unstable equilibrium δ = π/2 to the counting threshold 5π/4 (a few
// ms at fn = 141 Hz: < 0.5 %), and the PI loop's current error at that speed (< 1 %).
TEST(StepperPlugin, HoldingRotorSlipsAtPullOutAndCountsEachCycle) {
  const std::string actuator = TsuiActuator(
      "m1", "j1",
      Config("input", "position") + Config("detent", "none") + Config("hold_current", "1.9"));
  const std::string sensor =
      R"(<plugin name="s" plugin="mjstepper.stepper" objtype="actuator" objname="m1"/>)";
  const ModelPtr m = LoadModel(RotorModel(actuator, "", sensor));
  ASSERT_TRUE(m);
  const DataPtr d(mj_makeData(m.get()));
  const double rate = 0.25;  // N·m/s
  double slip_torque = -1;
  std::vector<double> counts;  // lost steps at each step
  while (d->time < 2.6) {
    d->qfrc_applied[0] = -rate * d->time;  // against positive rotation: the rotor falls behind
    mj_step(m.get(), d.get());
    mj_forward(m.get(), d.get());  // the signals of the new state
    if (slip_torque < 0 && d->sensordata[kLostSteps] != 0) slip_torque = rate * d->time;
    counts.push_back(d->sensordata[kLostSteps]);
  }
  const double pull_out = 0.3 * 1.9;  // Km·I, N·m
  ASSERT_GT(slip_torque, 0) << "never slipped";
  EXPECT_NEAR(slip_torque, pull_out, 0.02 * pull_out);
  // Every change is one cycle lost (+4 full steps), and the count matches the cycles the rotor
  // actually fell behind: round((θcmd − θ)·Nr/2π) at the end.
  for (size_t k = 1; k < counts.size(); ++k) {
    if (counts[k] != counts[k - 1]) {
      EXPECT_EQ(counts[k] - counts[k - 1], 4.0) << "step " << k;
    }
  }
  const double cycles_behind = std::round(-d->qpos[0] * 50 / kTwoPi);
  EXPECT_GT(cycles_behind, 3);
  EXPECT_NEAR(counts.back() / 4, cycles_behind, 1.0);  // the last cycle may be under way
  EXPECT_GT(d->sensordata[SignalIndex("last_slip_time")], slip_torque / rate - 1e-9);
}

// The preset's rotor inertia must reach the model: without armature the load fails naming the
// exact value to add; rotor_inertia="0" says the model carries the rotor itself.
TEST(StepperPlugin, MissingRotorInertiaFailsNamingTheArmature) {
  const std::string bare = R"(<plugin name="m1" joint="j1" plugin="mjstepper.stepper" gear="3">)" +
                           Config("input", "velocity");
  std::string error;
  EXPECT_FALSE(LoadModel(RotorModel(bare + "</plugin>"), &error));
  EXPECT_THAT(error, AllOf(HasSubstr("actuator 'm1'"), HasSubstr("J = 3.6e-05 kg·m²"),
                           HasSubstr("add armature=\"3.6e-05\"")));
  EXPECT_TRUE(LoadModel(RotorModel(bare + Config("rotor_inertia", "0") + "</plugin>"), &error))
      << error;
  EXPECT_TRUE(LoadModel(RotorModel(TsuiActuator("m1", "j1", Config("input", "velocity"))), &error))
      << error;
}

// A NaN or absurd ctrl is not a command: the drive keeps its command (here its speed) and its
// state finite, MuJoCo's own bad-ctrl warning counts it (once per bad step), and the simulation is
// not reset.
TEST(StepperPlugin, BadCtrlKeepsTheDriveFiniteAndWarns) {
  const ModelPtr m = LoadModel(ProbedVelocityRotor());
  ASSERT_TRUE(m);
  const DataPtr d(mj_makeData(m.get()));
  const double h = m->opt.timestep;
  for (double bad : {std::nan(""), 1e12, -HUGE_VAL}) {
    for (int k = 0; k < 100; ++k) {
      d->ctrl[0] = 10.0;  // a run at 10 rad/s with one bad step
      mj_forward(m.get(), d.get());
      const double theta_cmd = d->sensordata[kThetaCmd];
      if (k == 50) d->ctrl[0] = bad;
      mj_step(m.get(), d.get());
      if (k == 50) {  // the bad step went on at 10 rad/s (stopping would leave θcmd where it was)
        d->ctrl[0] = 10.0;
        mj_forward(m.get(), d.get());
        EXPECT_NEAR(d->sensordata[kThetaCmd] - theta_cmd, 10.0 * h, 1e-12) << bad;
      }
    }
  }
  mj_forward(m.get(), d.get());
  for (int i = 0; i < kNumSignals; ++i) EXPECT_TRUE(std::isfinite(d->sensordata[i])) << i;
  EXPECT_EQ(d->warning[mjWARN_BADCTRL].number, 3);
  EXPECT_EQ(d->warning[mjWARN_BADQACC].number, 0);  // no reset
  EXPECT_NEAR(d->time, 300 * h, 1e-12);             // time ran on: nothing was reset
  EXPECT_EQ(d->sensordata[kLostSteps], 0.0);
}

// A position drive with a trapezoid profile keeps going to its target through a NaN sample: the
// move is the same, to the last bit, as the one with no bad sample (keeping θcmd instead would
// re-plan a stop there, then re-plan the move).
TEST(StepperPlugin, BadCtrlDoesNotDisturbAProfiledMove) {
  const ModelPtr m = LoadModel(RotorModel(
      TsuiActuator("m1", "j1",
                   Config("profile", "trapezoid") + Config("profile_speed", "20") +
                       Config("profile_accel", "200")),
      "", R"(<plugin name="s" plugin="mjstepper.stepper" objtype="actuator" objname="m1"/>)"));
  ASSERT_TRUE(m);
  const DataPtr clean(mj_makeData(m.get())), hit(mj_makeData(m.get()));
  for (int k = 0; k < 2000; ++k) {  // 0.1 s of a 1 rad move (0.14 s at 200 rad/s²)
    clean->ctrl[0] = 1.0;
    hit->ctrl[0] = k == 400 ? std::nan("") : 1.0;
    mj_step(m.get(), clean.get());
    mj_step(m.get(), hit.get());
  }
  EXPECT_EQ(hit->warning[mjWARN_BADCTRL].number, 1);
  EXPECT_GT(clean->qpos[0], 0.5);  // the move is under way: 0.5 rad at 0.1 s
  EXPECT_EQ(hit->qpos[0], clean->qpos[0]);
  for (int i = 0; i < m->nplugin; ++i) {
    const int adr = m->plugin_stateadr[i], n = m->plugin_statenum[i];
    for (int j = 0; j < n; ++j) EXPECT_EQ(hit->plugin_state[adr + j], clean->plugin_state[adr + j]);
  }
}

// On an actuator with a ctrlrange, MuJoCo clamps before it tests: an infinite ctrl is the range's
// end, as for MuJoCo's own actuators, and no warning (the drive runs at 5 rad/s).
TEST(StepperPlugin, InfiniteCtrlOnALimitedActuatorIsClamped) {
  std::string actuator = VelocityTsui();
  actuator.replace(actuator.find("armature="), 0, R"(ctrlrange="-5 5" )");
  const ModelPtr m = LoadModel(RotorModel(
      actuator, "",
      R"(<plugin name="s" plugin="mjstepper.stepper" objtype="actuator" objname="m1"/>)"));
  ASSERT_TRUE(m);
  ASSERT_TRUE(m->actuator_ctrllimited[0]);
  const DataPtr d(mj_makeData(m.get()));
  for (int k = 0; k < 100; ++k) {
    d->ctrl[0] = HUGE_VAL;
    mj_step(m.get(), d.get());
  }
  mj_forward(m.get(), d.get());
  EXPECT_EQ(d->warning[mjWARN_BADCTRL].number, 0);
  EXPECT_NEAR(d->sensordata[SignalIndex("omega_cmd")], 5.0, 1e-12);
  EXPECT_NEAR(d->sensordata[kThetaCmd], 5.0 * 100 * m->opt.timestep, 1e-9);
}

// gear = 0 would freeze the rotor and report a force on nothing: a load error naming the gear.
TEST(StepperPlugin, ZeroGearFailsLoad) {
  std::string error;
  const std::string actuator =
      R"(<plugin name="m1" joint="j1" plugin="mjstepper.stepper" gear="0" armature="0.36e-4">)" +
      Config("input", "velocity") + "</plugin>";
  EXPECT_FALSE(LoadModel(RotorModel(actuator), &error));
  EXPECT_THAT(error, AllOf(HasSubstr("actuator 'm1'"), HasSubstr("gear = 0")));
}

// Issue 16: gear="1e-300" loaded, and the rotor angle gear·q underflowed to 0. |gear| is bounded
// to [1e-6, 1e6]; a load error names the gear and the range, and the ends themselves load.
TEST(StepperPlugin, GearOutOfRangeFailsLoad) {
  const auto actuator = [](const std::string& gear) {
    return R"(<plugin name="m1" joint="j1" plugin="mjstepper.stepper" gear=")" + gear +
           R"(" armature="0.36e-4">)" + Config("input", "velocity") + "</plugin>";
  };
  for (const char* gear : {"1e-300", "9.9e-7", "-1.01e6", "1e300"}) {
    std::string error;
    EXPECT_FALSE(LoadModel(RotorModel(actuator(gear)), &error)) << gear;
    EXPECT_THAT(error, AllOf(HasSubstr("actuator 'm1'"),
                             HasSubstr(fmt::format("gear = {:g}", std::stod(gear))),
                             HasSubstr("|gear| must be between 1e-06 and 1e+06")));
  }
  for (const char* gear : {"1e-6", "-1e6"}) {
    std::string error;
    EXPECT_TRUE(LoadModel(RotorModel(actuator(gear)), &error)) << gear << ": " << error;
  }
}

// Issue 16: a timestep of NaN or inf in the MJCF was refused with "use isr_period >= nan", blaming
// the drive. The message now names the timestep.
TEST(StepperPlugin, NonFiniteTimestepFailsLoadNamingIt) {
  for (double timestep :
       {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    std::string error;
    EXPECT_FALSE(LoadModel(RotorModel(TsuiActuator("m1", "j1", ""), "", "", 1, timestep), &error));
    EXPECT_THAT(error, AllOf(HasSubstr("actuator 'm1'"),
                             HasSubstr(fmt::format("timestep = {:g} s", timestep)),
                             HasSubstr("must be finite and > 0")));
    EXPECT_THAT(error, ::testing::Not(HasSubstr("isr_period")));
  }
}

// The warnings mju_warning sends while it lives (restoring the previous handler after).
class CapturedWarnings {
 public:
  CapturedWarnings() : previous_(mju_user_warning) {
    Messages().clear();
    mju_user_warning = +[](const char* message) { Messages().emplace_back(message); };
  }
  ~CapturedWarnings() { mju_user_warning = previous_; }
  const std::vector<std::string>& messages() const { return Messages(); }
  // The plugin's own (MuJoCo's warnings, e.g. on a NaN qpos, are not counted).
  std::vector<std::string> ours() const {
    std::vector<std::string> out;
    for (const std::string& m : Messages()) {
      if (m.starts_with("mjstepper: ")) out.push_back(m);
    }
    return out;
  }

 private:
  static std::vector<std::string>& Messages() {
    static std::vector<std::string> messages;
    return messages;
  }
  void (*previous_)(const char*);
};

std::vector<std::string>* captured_warnings = nullptr;

// At a step too coarse for the stepper's mode, loading warns through mju_warning (the timestep
// rule on the model's modes, as info and run judge it), naming the step, the mode and the largest
// step that resolves it; at the shipped step it is silent.
TEST(StepperPlugin, CoarseTimestepWarnsAtLoad) {
  std::vector<std::string> warnings;
  captured_warnings = &warnings;
  mju_user_warning = [](const char* message) { captured_warnings->push_back(message); };
  const std::string actuator = TsuiActuator("m1", "j1", Config("input", "velocity"));
  std::vector<size_t> count;  // warnings after each load (the compiler makes an mjData too)
  for (double h : {5e-5, 1e-3}) {
    const ModelPtr m = LoadModel(RotorModel(actuator, "", "", 1, h));
    ASSERT_TRUE(m);
    const DataPtr d(mj_makeData(m.get()));
    count.push_back(warnings.size());
  }
  mju_user_warning = nullptr;
  EXPECT_EQ(count[0], 0u);
  ASSERT_GT(count[1], 0u);
  for (const std::string& w : warnings) {
    EXPECT_THAT(w, AllOf(HasSubstr("mode 1 (stepper 'm1' 100 %)"), HasSubstr("timestep 0.001 s"),
                         HasSubstr("use timestep <= 0.000213 s")));
  }
}

// Issue 30, item 4: with STEP/DIR input the load warning (given when the modes fail) recommends
// the step a move's ringing needs too: 0.065/ωn with ωn = √(28.5/3.6e-5) = 889.8 rad/s (the
// holding stiffness, as `info` lists the mode), 7.3e-5 s; with velocity input it does not.
TEST(StepperPlugin, CoarseTimestepWarningGivesTheRingingStepWithStepInput) {
  for (const char* input : {"steps", "velocity"}) {
    CapturedWarnings warnings;
    std::string error;
    const ModelPtr m = LoadModel(
        RotorModel(TsuiActuator("m1", "j1", Config("input", input) + Config("microsteps", "16")),
                   "", "", 1, 1e-3),
        &error);
    ASSERT_TRUE(m) << error;
    ASSERT_FALSE(warnings.ours().empty()) << input;
    const std::string ringing = "<= 7.3e-05 s for a move's ringing with STEP/DIR input";
    if (std::string(input) == "steps") {
      EXPECT_THAT(warnings.ours()[0],
                  AllOf(HasSubstr("use timestep <= 0.000213 s"), HasSubstr(ringing)));
    } else {
      EXPECT_THAT(warnings.ours()[0], Not(HasSubstr(ringing)));
    }
  }
}

// Issue 16: a detent of 1e12 N·m (harmonic 4) holds the rotor far more stiffly than the drive does,
// and loaded without a word while MuJoCo then reset every step. The timestep check now adds the
// detent's worst-case stiffness Σh h·Nr·Kdh = 4·50·1e12 N·m/rad to T' = 28.5 N·m/rad: at J =
// 3.6e-5 kg·m² (and the rotor body's 1e-9), ωn = 2.36e9 rad/s and the largest step 0.2/ωn =
// 8.4855e-11 s, suggested rounded down: 8.48e-11 s. The shipped detent (Σ = 3.15 N·m/rad) stays
// silent at 50 µs.
TEST(StepperPlugin, StiffDetentWarnsAtLoad) {
  CapturedWarnings warnings;
  const ModelPtr m = LoadModel(RotorModel(
      TsuiActuator("m1", "j1", Config("input", "velocity") + Config("detent", "4 1e12 0"))));
  ASSERT_TRUE(m);
  ASSERT_FALSE(warnings.ours().empty());
  EXPECT_THAT(warnings.ours()[0],
              AllOf(HasSubstr("stepper 'm1'"), HasSubstr("timestep 5e-05 s is too coarse"),
                    HasSubstr("use timestep <= 8.48e-11 s")));
  const size_t before = warnings.ours().size();
  ASSERT_TRUE(LoadModel(RotorModel(TsuiActuator("m1", "j1", Config("input", "velocity")))));
  EXPECT_EQ(warnings.ours().size(), before);
}

// A scene of (m, d) from MuJoCo's default camera, and its arrows (the gauges'), freed with it.
struct GaugeScene {
  GaugeScene(const mjModel* m, mjData* d) {
    mjv_defaultScene(&scene);
    mjv_makeScene(m, &scene, 100);
    mjvOption option;
    mjv_defaultOption(&option);
    mjvCamera camera;
    mjv_defaultCamera(&camera);
    mjv_updateScene(m, d, &option, nullptr, &camera, mjCAT_ALL, &scene);
    for (int g = 0; g < scene.ngeom; ++g) {
      if (scene.geoms[g].type == mjGEOM_ARROW) arrows.push_back(&scene.geoms[g]);
    }
  }
  ~GaugeScene() { mjv_freeScene(&scene); }
  GaugeScene(const GaugeScene&) = delete;
  GaugeScene& operator=(const GaugeScene&) = delete;
  mjvScene scene;
  std::vector<const mjvGeom*> arrows;
};

// The load-angle gauge (visualize callback): two arrows per stepper in the scene, the rotor's at
// −δ from the command's about the joint axis, so the angle between them is the load angle; none
// with gauge="off".
TEST(StepperPlugin, GaugeShowsTheLoadAngle) {
  for (const char* gauge : {"on", "off"}) {
    const ModelPtr m = LoadModel(RotorModel(TsuiActuator(
        "m1", "j1",
        Config("drive", "ideal_current") + Config("detent", "none") + Config("gauge", gauge))));
    ASSERT_TRUE(m);
    const DataPtr d(mj_makeData(m.get()));
    d->ctrl[0] = 0.01;  // rad: the drive starts at rest on θcmd = 0.01 with the rotor at 0
    mj_forward(m.get(), d.get());
    const GaugeScene scene(m.get(), d.get());
    const std::vector<const mjvGeom*>& arrows = scene.arrows;
    if (std::string(gauge) == "off") {
      EXPECT_TRUE(arrows.empty());
    } else {
      ASSERT_EQ(arrows.size(), 2u);
      // Directions: each arrow's z axis (third column of its row-major matrix), in the x-y plane.
      const double command = std::atan2(arrows[0]->mat[5], arrows[0]->mat[2]);
      const double rotor = std::atan2(arrows[1]->mat[5], arrows[1]->mat[2]);
      const double delta = 50 * 0.01;  // Nr·(θcmd − θ), electrical rad
      // float matrices: 1e-5 rad
      EXPECT_NEAR(std::remainder(command - rotor, kTwoPi), delta, 1e-5);
    }
  }
}

// Issue 32, item 4: the gauge is sized to the scene, not only to its rotor's body: a 3 mm pulley
// in a 2 m scene gets arrows of at least 2.5 % of the extent (it had 6 mm ones, a few pixels); a
// 0.5 m body keeps its own size, within half the extent (the arrows never longer than the scene).
// The command's arrow is two scales long.
TEST(StepperPlugin, GaugeIsSizedToTheScene) {
  for (double body_radius : {0.003, 0.5}) {
    const std::string xml = fmt::format(
        R"(<mujoco><option timestep="5e-5" integrator="implicitfast"/>
      <extension><plugin plugin="mjstepper.stepper"/></extension>
      <worldbody><geom type="box" size="1 1 0.01" pos="0 0 -0.1"/>
        <body name="r1"><joint name="j1" type="hinge" axis="0 0 1"/>
          <geom type="cylinder" size="{0} 0.002" mass="0.001"/></body></worldbody>
      <actuator>{1}</actuator></mujoco>)",
        body_radius, TsuiActuator("m1", "j1", Config("drive", "ideal_current")));
    std::string error;
    const ModelPtr m = LoadModel(xml, &error);
    ASSERT_TRUE(m) << error;
    const DataPtr d(mj_makeData(m.get()));
    mj_forward(m.get(), d.get());
    const GaugeScene scene(m.get(), d.get());
    ASSERT_FALSE(scene.arrows.empty());
    const double extent = m->stat.extent, length = scene.arrows[0]->size[2];  // m: the command's
    EXPECT_GE(length, 2 * 0.025 * extent * (1 - 1e-5)) << body_radius;
    EXPECT_LE(length, 2 * 0.5 * extent * (1 + 1e-5)) << body_radius;
  }
}

struct BadConfig {
  const char* key;
  const char* value;
  const char* rule;  // a word of the expected rule
};

class BadConfigFailsLoad : public ::testing::TestWithParam<BadConfig> {};

TEST_P(BadConfigFailsLoad, NamesAttributeAndValue) {
  const BadConfig& bad = GetParam();
  std::string error;
  const ModelPtr m =
      LoadModel(RotorModel(TsuiActuator("shaft", "j1", Config(bad.key, bad.value))), &error);
  EXPECT_FALSE(m);
  EXPECT_THAT(error, AllOf(HasSubstr("actuator 'shaft'"), HasSubstr(bad.key),
                           HasSubstr(std::string("\"") + bad.value + "\""), HasSubstr(bad.rule)));
}

INSTANTIATE_TEST_SUITE_P(
    StepperPlugin, BadConfigFailsLoad,
    ::testing::Values(BadConfig{"resistance", "-0.9", "> 0"}, BadConfig{"inductance", "0", "> 0"},
                      BadConfig{"torque_constant", "nan", "not a finite number"},
                      BadConfig{"bus_voltage", "48V", "not a finite number"},
                      BadConfig{"hold_current", "1.9 A", "not a finite number"},
                      BadConfig{"kp", "inf", "not a finite number"},
                      BadConfig{"drive", "stepper9000", "must be one of"},
                      BadConfig{"motor", "tsui2010", "unknown preset"},
                      BadConfig{"input", "torque", "position"},
                      BadConfig{"rotor_teeth", "50.5", "integer"},
                      BadConfig{"detent", "4 0.006", "triplets"},
                      BadConfig{"compute_delay", "50e-6", "< isr_period"},
                      BadConfig{"voltage_amplitude", "-1", "not read by drive current_microstep"},
                      BadConfig{"ki", "-0.01", ">= 0"}, BadConfig{"isr_period", "0", "> 0"},
                      BadConfig{"hold_current", "1000", "more than bus_voltage = 48 V"},
                      BadConfig{"damping", "4 4", "harmonic 4 is named twice"}),
    [](const ::testing::TestParamInfo<BadConfig>& info) {
      return std::string(info.param.key) + "_" + std::to_string(info.index);
    });

// A step runs every interrupt in it, and MuJoCo's compiler steps once while loading: 1e-12 s took
// 18 s to load (5e7 interrupts) and 1e-9 s made each step 0.1 s. Now a load error names the
// attribute, its value and the least period the timestep (50 µs here) allows.
TEST(StepperPlugin, InterruptsPerStepAreBounded) {
  for (const char* period : {"1e-12", "1e-9"}) {
    std::string error;
    const auto start = std::chrono::steady_clock::now();
    const ModelPtr m =
        LoadModel(RotorModel(TsuiActuator(
                      "shaft", "j1", Config("isr_period", period) + Config("compute_delay", "0"))),
                  &error);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_FALSE(m) << period;
    EXPECT_THAT(error, AllOf(HasSubstr("actuator 'shaft'"),
                             HasSubstr(std::string("isr_period = \"") + period + "\""),
                             HasSubstr("isr_period >= 5e-09")));
    EXPECT_LT(seconds, 5.0) << "not a bound on the work";  // (a guard, not a timing target)
  }
  // 10 000 interrupts per step still load.
  EXPECT_TRUE(LoadModel(RotorModel(
      TsuiActuator("shaft", "j1", Config("isr_period", "5e-9") + Config("compute_delay", "0")))));
  // The least period the message names is accepted when copied back, also on timesteps whose
  // 1/10 000 has more digits than it prints (they once suggested 3.33333e-08 for 1/3000 s, which
  // was refused again).
  for (double timestep : {1.0 / 3000, 2.0 / 3000, 1.0 / 7000, 3e-5 / 7}) {
    std::string error;
    const auto actuator = [](const std::string& period) {
      return TsuiActuator("shaft", "j1",
                          Config("isr_period", period) + Config("compute_delay", "0"));
    };
    EXPECT_FALSE(LoadModel(RotorModel(actuator("1e-12"), "", "", 1, timestep), &error));
    const size_t at = error.find("isr_period >= ");
    ASSERT_NE(at, std::string::npos) << error;
    const std::string least = error.substr(at + 14, error.find(' ', at + 14) - at - 14);
    EXPECT_TRUE(LoadModel(RotorModel(actuator(least), "", "", 1, timestep), &error))
        << "timestep " << timestep << ": the suggested " << least << " is refused: " << error;
  }
}

// A timestep raised past the bound after loading (which would refuse it) is not refused mid-run,
// but said, once, through MuJoCo's warning mechanism: each step now runs 20 000 interrupts.
TEST(StepperPlugin, TimestepRaisedAfterLoadingIsReportedOnce) {
  const ModelPtr m = LoadModel(RotorModel(
      TsuiActuator("shaft", "j1", Config("isr_period", "1e-6") + Config("compute_delay", "0"))));
  ASSERT_TRUE(m);
  const DataPtr d(mj_makeData(m.get()));
  m->opt.timestep = 0.02;
  static std::vector<std::string> warnings;
  warnings.clear();
  void (*previous)(const char*) = mju_user_warning;
  mju_user_warning = +[](const char* message) { warnings.emplace_back(message); };
  for (int k = 0; k < 3; ++k) mj_step(m.get(), d.get());
  mju_user_warning = previous;
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_THAT(warnings[0], AllOf(HasSubstr("timestep 0.02 s runs 20000 interrupts per step"),
                                 HasSubstr("isr_period >= 2e-06")));
}

// Runs `steps` of mj_step on another thread and waits at most `seconds` for them; a step that
// never returns (issue 16: the drive's event loop once stalled on NaN or huge times) fails the
// test and ends the process, which could not otherwise stop the thread.
void StepsReturnWithin(const mjModel* m, mjData* d, int steps, double seconds) {
  std::packaged_task<void()> task([m, d, steps] {
    for (int k = 0; k < steps; ++k) mj_step(m, d);
  });
  std::future<void> done = task.get_future();
  std::thread thread(std::move(task));
  if (done.wait_for(std::chrono::duration<double>(seconds)) != std::future_status::ready) {
    ADD_FAILURE() << steps << " steps did not return within " << seconds << " s";
    std::fprintf(stderr, "mj_step never returned: ending the test process\n");
    std::_Exit(1);
  }
  thread.join();
}

bool AllFinite(const mjModel* m, const mjData* d) {
  for (int i = 0; i < m->npluginstate; ++i) {
    if (!std::isfinite(d->plugin_state[i])) return false;
  }
  for (int i = 0; i < m->nu; ++i) {
    if (!std::isfinite(d->actuator_force[i])) return false;
  }
  return true;
}

std::string ShippedModel(const std::string& name) {
  std::ifstream file(std::string(MJSTEPPER_SOURCE_DIR "/models/") + name);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

// Issue 33: ±1e300 written into a started drive's plugin_state (finite, so the drive's own check
// after the step found it only once it overflowed) applied its force for that step: a kick of
// −2 880 rad/s. Now the state is restarted at rest before any force is read: the step's force is
// at most the motor's holding torque (√2·Km·I = 0.57 N·m for the Tsui motor at 1.9 A... with the
// detent, under 1 N·m), the rotor's speed changes by at most h·1 N·m/J, and one warning says so.
TEST(StepperPlugin, GarbageInTheStateIsNeverAppliedAsAForce) {
  for (const char* coupling : {"explicit", "consistent"}) {
    std::string xml = ShippedModel("tsui_rigid.xml");
    xml.insert(xml.find("</plugin>"), Config("coupling", coupling));
    const ModelPtr m = LoadModel(xml);
    ASSERT_TRUE(m);
    const DataPtr d(mj_makeData(m.get()));
    d->ctrl[0] = 10;  // rad/s
    for (int k = 0; k < 400; ++k) mj_step(m.get(), d.get());
    // The phase currents (DriveCoreState's current_a, current_b), the force's source.
    const int adr = m->plugin_stateadr[0] + offsetof(DriveCoreState, current_a) / sizeof(double);
    d->plugin_state[adr] = 1e300;
    d->plugin_state[adr + 1] = -1e300;
    const double speed = d->qvel[0];  // rad/s
    CapturedWarnings warnings;
    mj_step(m.get(), d.get());
    EXPECT_LE(std::abs(d->actuator_force[0]), 1.0) << coupling;
    std::vector<mjtNum> full(m->nv * m->nv);
    mj_fullM(m.get(), d.get(), full.data());
    const double inertia = full[0];  // kg·m², the rotor and its load
    EXPECT_LE(std::abs(d->qvel[0] - speed), m->opt.timestep * 1.0 / inertia) << coupling;
    // (Applied, the force made MuJoCo find a huge qacc and reset the simulation.)
    EXPECT_EQ(d->warning[mjWARN_BADQACC].number, 0) << coupling;
    // The state the step leaves is the drive's own again: its currents within 2 A (1.9 A peak).
    EXPECT_LE(std::hypot(d->plugin_state[adr], d->plugin_state[adr + 1]), 2.0) << coupling;
    ASSERT_EQ(warnings.ours().size(), 1u) << coupling;
    EXPECT_THAT(warnings.ours()[0], AllOf(HasSubstr("actuator 'shaft' (id 0)"),
                                          HasSubstr("the drive restarted at rest")));
    EXPECT_TRUE(AllFinite(m.get(), d.get()));
  }
}

// Issue 16's first reproduction: a keyframe at time NaN (the CLI's --keyframe nan). The event loop
// waited for a tick time above NaN for ever; now each step returns at once, the drive held, and
// one warning names the actuator, the time and the cause.
TEST(StepperPlugin, NanTimeFromAKeyframeReturnsAndWarnsOnce) {
  std::string xml = ShippedModel("tsui_rigid.xml");
  xml.replace(xml.rfind("</mujoco>"), 9,
              R"(<keyframe><key name="nan" time="nan" qpos="0"/></keyframe></mujoco>)");
  const ModelPtr m = LoadModel(xml);
  ASSERT_TRUE(m);
  const DataPtr d(mj_makeData(m.get()));
  mj_resetDataKeyframe(m.get(), d.get(), 0);
  d->ctrl[0] = 10;
  CapturedWarnings warnings;
  StepsReturnWithin(m.get(), d.get(), 100, 10.0);
  ASSERT_EQ(warnings.ours().size(), 1u);
  EXPECT_THAT(warnings.ours()[0], AllOf(HasSubstr("actuator 'shaft' (id 0) at time nan s"),
                                        HasSubstr("the step's time is not finite")));
  EXPECT_TRUE(AllFinite(m.get(), d.get()));
}

// Issue 16: a 10 MHz drive at a Unix time (1.7e9 s, where times are 2.4e-7 s apart, coarser than
// the 1e-7 s period: t + T was t) and the default 20 kHz drive at 1e13 s (tick indices past 2^53,
// where k + 1 was k). Both stalled; now the steps return, the drive's state stays finite, and one
// warning says the time is too coarse for the clock.
TEST(StepperPlugin, HugeTimesReturnAndWarnOnce) {
  struct Case {
    std::string configs;
    double time;  // s
  };
  for (const Case& c :
       {Case{Config("isr_period", "1e-7") + Config("compute_delay", "0"), 1.7e9}, Case{"", 1e13}}) {
    const ModelPtr m = LoadModel(RotorModel(TsuiActuator("shaft", "j1", c.configs)));
    ASSERT_TRUE(m);
    const DataPtr d(mj_makeData(m.get()));
    d->time = c.time;
    d->ctrl[0] = 0.5;  // rad
    CapturedWarnings warnings;
    StepsReturnWithin(m.get(), d.get(), 200, 10.0);
    ASSERT_EQ(warnings.ours().size(), 1u) << c.time;
    EXPECT_THAT(warnings.ours()[0], AllOf(HasSubstr("actuator 'shaft' (id 0) at time "),
                                          HasSubstr(fmt::format("{:g} s", c.time)),
                                          HasSubstr("round-off is not small against isr_period")));
    EXPECT_TRUE(AllFinite(m.get(), d.get())) << c.time;
  }
}

// Issue 16: a timestep set after loading to NaN, ±inf, a negative value or 0 (the compiler refuses
// them all): each step returns, the drive is held, one warning names the timestep.
TEST(StepperPlugin, BadTimestepAfterLoadingReturnsAndWarnsOnce) {
  const double kInf = std::numeric_limits<double>::infinity();
  for (double timestep : {std::numeric_limits<double>::quiet_NaN(), kInf, -kInf, -1e-3, 0.0}) {
    const ModelPtr m = LoadModel(RotorModel(TsuiActuator("shaft", "j1", "")));
    ASSERT_TRUE(m);
    const DataPtr d(mj_makeData(m.get()));
    d->ctrl[0] = 0.5;                               // rad
    StepsReturnWithin(m.get(), d.get(), 10, 10.0);  // started
    m->opt.timestep = timestep;
    CapturedWarnings warnings;
    StepsReturnWithin(m.get(), d.get(), 100, 10.0);
    ASSERT_EQ(warnings.ours().size(), 1u) << timestep;
    EXPECT_THAT(warnings.ours()[0],
                AllOf(HasSubstr("actuator 'shaft' (id 0) at time "),
                      HasSubstr(fmt::format("timestep = {:g} s is not a positive finite number",
                                            timestep))));
    EXPECT_TRUE(AllFinite(m.get(), d.get())) << timestep;
  }
}

// When an instance's init fails, MuJoCo's mj_initPlugin (used by mj_copyData and the compiler's
// MakeData) frees mjData without destroying the instances made before it, and LeakSanitizer found
// the earlier Stepper lost. (4.0.0's mj_makeData destroys them itself; the others do not.) So
// the first instance checks the later ones before any is made: its init, called as MuJoCo calls
// it, fails and makes nothing when the second drive's 1 µs interrupt stops fitting the bound
// after the model's timestep is raised.
TEST(StepperPlugin, ABadLaterInstanceLeaksNoEarlierOne) {
  const ModelPtr m = LoadModel(RotorModel(
      TsuiActuator("good", "j1", "") +
      TsuiActuator("bad", "j1", Config("isr_period", "1e-6") + Config("compute_delay", "0"))));
  ASSERT_TRUE(m);
  const DataPtr d(mj_makeData(m.get()));
  const uintptr_t made = d->plugin_data[0];
  m->opt.timestep = 0.02;  // 400 interrupts per step for "good", 20 000 for "bad"
  const mjpPlugin* plugin = mjp_getPluginAtSlot(m->plugin[0]);
  const int live = plugin::Stepper::LiveCount();
  EXPECT_EQ(plugin->init(m.get(), d.get(), 0), -1);
  EXPECT_EQ(plugin::Stepper::LiveCount(), live);
  EXPECT_EQ(d->plugin_data[0], made);  // untouched, and destroyed with d
}

// Issue 16: with two bad steppers, the first instance checked the later one first and returned,
// so the later one's error was reported and the first one's hidden. Errors now come in model
// order, all of them: the first actuator's, then the second's; with only the first bad, its own.
TEST(StepperPlugin, LoadErrorsComeInModelOrder) {
  const std::string first_error = "actuator 'a' (id 0): bus_voltage = \"48V\"";
  const std::string second_error = "actuator 'b' (id 1): kp = \"x\"";
  std::string error;
  EXPECT_FALSE(LoadModel(RotorModel(TsuiActuator("a", "j1", Config("bus_voltage", "48V")) +
                                    TsuiActuator("b", "j1", Config("kp", "x"))),
                         &error));
  const size_t first = error.find(first_error), second = error.find(second_error);
  ASSERT_NE(first, std::string::npos) << error;
  ASSERT_NE(second, std::string::npos) << error;
  EXPECT_LT(first, second) << error;
  EXPECT_FALSE(LoadModel(RotorModel(TsuiActuator("a", "j1", Config("bus_voltage", "48V")) +
                                    TsuiActuator("b", "j1", "")),
                         &error));
  EXPECT_THAT(error, HasSubstr(first_error));
}

// Issue 16: dyntype="filter" loaded and MuJoCo integrated act, but the drive read the raw ctrl, so
// the dynamics were silently ignored. The drive now reads the activation, as MuJoCo's own
// actuators feed act to their gain: a 1 rad step of ctrl through a 20 ms filter reaches the drive
// as MuJoCo's act (exactly: the command θcmd it holds after each step is act at the step's end),
// 0.39 rad after 10 ms where ctrl is 1 rad.
TEST(StepperPlugin, DyntypeFeedsTheActivation) {
  const std::string actuator =
      R"(<plugin name="m1" joint="j1" plugin="mjstepper.stepper" armature="0.36e-4" )"
      R"(dyntype="filter" dynprm="0.02">)" +
      Config("drive", "ideal_current") + "</plugin>";
  const ModelPtr m = LoadModel(RotorModel(
      actuator, "", R"(<plugin plugin="mjstepper.stepper" objtype="actuator" objname="m1"/>)"));
  ASSERT_TRUE(m);
  ASSERT_EQ(m->na, 1);
  const DataPtr d(mj_makeData(m.get()));
  d->ctrl[0] = 1.0;  // rad
  for (int k = 0; k < 200; ++k) {
    mj_step(m.get(), d.get());
    mj_forward(m.get(), d.get());  // the signals of the state after the step
    ASSERT_EQ(d->sensordata[kThetaCmd], d->act[0]) << "step " << k;
  }
  EXPECT_NEAR(d->act[0], 1 - std::exp(-0.01 / 0.02), 0.01);  // Euler's 1 − (1 − h/τ)^200
  EXPECT_LT(d->sensordata[kThetaCmd], 0.5);
}

// Issue 16: with forcerange="-0.01 0.01" MuJoCo clips actuator_force to 0.01 N·m while the
// torque_total signal said 0.5 N·m and the docs called it the actuator force. It is the motor's
// own torque τm + τdet, before the clamp, and the signal table says so: a rotor held 0.02 rad
// behind its command by ideal currents (δ = Nr·0.02 = 1 rad) makes Km·I·sin δ ≈ 0.48 N·m.
TEST(StepperPlugin, ForcerangeClipsTheForceNotTheMotorTorque) {
  const std::string actuator =
      R"(<plugin name="m1" joint="j1" plugin="mjstepper.stepper" armature="0.36e-4" )"
      R"(forcelimited="true" forcerange="-0.01 0.01">)" +
      Config("drive", "ideal_current") + Config("detent", "none") + "</plugin>";
  const ModelPtr m = LoadModel(RotorModel(
      actuator, "", R"(<plugin plugin="mjstepper.stepper" objtype="actuator" objname="m1"/>)"));
  ASSERT_TRUE(m);
  const DataPtr d(mj_makeData(m.get()));
  d->ctrl[0] = 0.02;  // rad: δ = 1 electrical rad
  mj_forward(m.get(), d.get());
  EXPECT_EQ(d->actuator_force[0], 0.01);
  const double torque = 1.9 * 0.3 * std::sin(1.0);  // I·Km·sin δ, N·m
  EXPECT_NEAR(d->sensordata[kTorqueTotal], torque, 1e-9);
  EXPECT_THAT(SignalTable()[kTorqueTotal].meaning,
              AllOf(HasSubstr("before MuJoCo's forcerange clamp"), HasSubstr("actuator_force")));
}

TEST(StepperPlugin, UnknownAttributeFailsLoad) {
  std::string error;
  const ModelPtr m =
      LoadModel(RotorModel(TsuiActuator("shaft", "j1", Config("hold_curent", "1.9"))), &error);
  EXPECT_FALSE(m);
  EXPECT_THAT(error, HasSubstr("hold_curent"));
}

TEST(StepperPlugin, SensorNeedsAStepperActuator) {
  std::string error;
  const ModelPtr m = LoadModel(
      RotorModel(
          VelocityTsui() + R"(<motor name="plain" joint="j1"/>)", "",
          R"(<plugin name="s" plugin="mjstepper.stepper" objtype="actuator" objname="plain"/>)"),
      &error);
  EXPECT_FALSE(m);
  EXPECT_THAT(error, AllOf(HasSubstr("sensor 's'"), HasSubstr("objtype=\"actuator\"")));
}

TEST(StepperPlugin, VersionMismatchNamesBothVersions) {
  EXPECT_EQ(plugin::VersionMismatch(3014000, 3014000), "");
  EXPECT_THAT(plugin::VersionMismatch(3014000, 3003007),
              AllOf(HasSubstr("3.14.0"), HasSubstr("3.3.7"), HasSubstr("3014000")));
  // And the library this test runs with is the one it was built for.
  EXPECT_EQ(plugin::VersionMismatch(mjVERSION_HEADER, mj_version()), "");
}

}  // namespace
}  // namespace mjstepper::testing
