// models/parol6.xml (issue 29, item 8): the real PAROL6 on its TMC5160s in StealthChop, settled
// under gravity with its 0.5 kg payload at the standby pose. Each rotor sits at the static load
// angle of its hold current: Km·I_hold·sin δ = τ (S-4; no detent on these presets), τ = the
// joint's gravity torque through the gear, within the band the joint's gear-train friction leaves
// (frictionloss/gear at the rotor), 2 % beyond it (StealthChop's regulation of the current about
// its target). The drives hold at IHOLD (TPOWERDOWN and IHOLDDELAY elapsed long before: a drive at
// rest from the start has stood still for ever).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <numbers>
#include <string>

#include "runner.h"
#include "stepper_model.h"

namespace mjstepper::tools {
namespace {

const std::string kParol6 = MJSTEPPER_SOURCE_DIR "/models/parol6.xml";

TEST(Parol6, SettledEveryRotorSitsAtItsHoldCurrentsLoadAngle) {
  StepperModel sm = LoadStepperModel(kParol6, {});
  const mjModel* m = sm.model.get();
  ASSERT_EQ(sm.steppers.size(), 6u);
  const DataPtr d(mj_makeData(m));
  mj_forward(m, d.get());
  RunOptions o;
  o.model = kParol6;
  o.duration = 0.02;
  o.progress = false;
  o.keep_traces = true;
  const RunResult r = tools::Run(o, std::cerr);
  EXPECT_EQ(r.settle_time, kSettleTime);
  int loaded = 0;
  for (size_t i = 0; i < sm.steppers.size(); ++i) {
    const StepperActuator& s = sm.steppers[i];
    const Drive drive(s.config);
    const double holding = s.config.motor.torque_constant * drive.RestCurrentMagnitude();  // N·m
    const int dof = m->jnt_dofadr[m->actuator_trnid[2 * s.actuator]];
    const double gear = Gear(m, s);
    const double load = d->qfrc_bias[dof] / gear;             // N·m at the rotor
    const double friction = m->dof_frictionloss[dof] / gear;  // N·m at the rotor
    auto angle = [&](double torque) { return std::asin(std::clamp(torque / holding, -1.0, 1.0)); };
    const double low = angle(load - friction), high = angle(load + friction);
    const double delta = r.traces[i].load_angle.front();
    std::printf(
        "%s: gear %.3f, load %+.4f N·m at the rotor (friction ±%.4f), Km·I_hold %.4f N·m: "
        "δ %+.4f rad, static band [%+.4f, %+.4f]\n",
        s.name.c_str(), gear, load, friction, holding, delta, low, high);
    EXPECT_GE(delta, low - 0.02 * std::abs(low) - 1e-3) << s.name;
    EXPECT_LE(delta, high + 0.02 * std::abs(high) + 1e-3) << s.name;
    EXPECT_EQ(r.steppers[i].lost_steps, 0) << s.name;
    if (std::abs(load) > friction) ++loaded;
  }
  EXPECT_GE(loaded, 2);  // J2 and J3 carry the arm (J5 the payload's moment about the wrist)
}

}  // namespace
}  // namespace mjstepper::tools
