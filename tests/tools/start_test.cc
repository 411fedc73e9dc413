// Issue 29, item 5: a settled start (runner.h, StartMode). models/arm3.xml holds a 1 kg payload
// with its arm horizontal; the shoulder's rotor then carries τ = qfrc_bias/gear.
//   settled: gravity ramped in while the drives hold, the rotor sits at the static load angle δ
//            that solves Km·I·sin δ + τdet(x) = τ (S-4, S-5; x = Nr·θ = −δ at qpos0), within the
//            band the joint's dry friction (frictionloss/gear) leaves;
//   aligned: gravity at full strength at t = 0 on the aligned rotor: it overshoots to about twice
//            δ (a step load on the holding stiffness; 2× for an undamped linear spring).
#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <numbers>
#include <string>

#include "runner.h"
#include "size.h"
#include "stepper_model.h"

namespace mjstepper::tools {
namespace {

const std::string kArm = MJSTEPPER_SOURCE_DIR "/models/arm3.xml";

RunOptions Hold(StartMode start, double payload) {
  RunOptions o;
  o.model = kArm;
  o.duration = 0.3;
  o.progress = false;
  o.keep_traces = true;
  o.start = start;
  o.masses["payload"] = payload;
  return o;
}

// The shoulder's static load angle (electrical rad) for a rotor-side load `torque` (N·m, the
// motor's torque that holds it): the root of Km·I·sin δ + τdet(−δ) = torque in [−π/2, π/2] by
// bisection (τdet of S-5 at x = −δ; the left side rises with δ: the holding stiffness exceeds the
// detent's).
double StaticLoadAngle(const StepperActuator& s, double torque) {
  const MotorParams& motor = s.config.motor;
  const double holding =
      motor.torque_constant *
      std::get<CurrentMicrostep>(s.config.controller).setpoint.hold_current;  // N·m, Km·I
  auto net = [&](double delta) {
    double detent = 0;
    for (const DetentHarmonic& h : motor.detent) {
      detent -= h.amplitude * std::sin(h.order * -delta + h.phase);
    }
    return holding * std::sin(delta) + detent - torque;
  };
  double lo = -std::numbers::pi / 2, hi = std::numbers::pi / 2;
  for (int k = 0; k < 60; ++k) (net(0.5 * (lo + hi)) < 0 ? lo : hi) = 0.5 * (lo + hi);
  return 0.5 * (lo + hi);
}

TEST(Start, SettledSitsAtTheStaticLoadAngleAlignedOvershootsToTwice) {
  const double payload = 1.0;  // kg
  // The shoulder's gravity load at the start pose, through a copy of the model.
  StepperModel sm = LoadStepperModel(kArm, {});
  SetBodyMass(sm.model.get(), "payload", payload);
  const mjModel* m = sm.model.get();
  const DataPtr d(mj_makeData(m));
  mj_forward(m, d.get());
  size_t shoulder = 0;
  while (sm.steppers[shoulder].name != "shoulder") ++shoulder;
  const StepperActuator& s = sm.steppers[shoulder];
  const int dof = m->jnt_dofadr[m->actuator_trnid[2 * s.actuator]];
  const double gear = Gear(m, s);
  const double load = d->qfrc_bias[dof] / gear;             // N·m at the rotor
  const double friction = m->dof_frictionloss[dof] / gear;  // N·m at the rotor
  // Signed: the rotor holds with δ of the load's sign; dry friction takes up to `friction`.
  const double delta = StaticLoadAngle(s, load);
  const double least =
      std::min(StaticLoadAngle(s, load - friction), StaticLoadAngle(s, load + friction));
  const double most =
      std::max(StaticLoadAngle(s, load - friction), StaticLoadAngle(s, load + friction));

  const RunResult settled = tools::Run(Hold(StartMode::kSettled, payload), std::cerr);
  const RunResult aligned = tools::Run(Hold(StartMode::kAligned, payload), std::cerr);
  EXPECT_EQ(settled.settle_time, kSettleTime);
  EXPECT_EQ(aligned.settle_time, 0.0);
  const StepperTrace& st = settled.traces[shoulder];
  const StepperTrace& at = aligned.traces[shoulder];
  EXPECT_NEAR(st.time.front(), 0.0, 1e-12);  // the log's clock starts with the motion
  // The largest excursion of δ beyond zero on the load's side, and the least, over the runs.
  const double sign = delta < 0 ? -1.0 : 1.0;
  double settled_most = 0, settled_least = 1e9, aligned_most = 0;
  for (double x : st.load_angle) {
    settled_most = std::max(settled_most, sign * x);
    settled_least = std::min(settled_least, sign * x);
  }
  for (double x : at.load_angle) aligned_most = std::max(aligned_most, sign * x);
  const double band_low = std::min(sign * least, sign * most);
  const double band_high = std::max(sign * least, sign * most);
  std::printf(
      "shoulder: load %.4f N·m at the rotor, static δ %.4f rad (friction band %.4f-%.4f); "
      "settled: start %.4f, %.4f-%.4f; aligned: max %.4f (%.2f × δ)\n",
      load, delta, sign * band_low, sign * band_high, st.load_angle.front(), sign * settled_least,
      sign * settled_most, sign * aligned_most, aligned_most / std::abs(delta));
  // Settled: over the whole hold, in the friction band (2 % beyond it: what rings on after the
  // ramp, and the drive's current ripple).
  EXPECT_GE(sign * st.load_angle.front(), 0.98 * band_low);
  EXPECT_LE(sign * st.load_angle.front(), 1.02 * band_high);
  EXPECT_GE(settled_least, 0.98 * band_low);
  EXPECT_LE(settled_most, 1.02 * band_high);
  // Aligned: the step load overshoots to about twice δ (1.8-2.4×: friction and damping take a
  // little, the sine's softening adds).
  EXPECT_GT(aligned_most, 1.8 * std::abs(delta));
  EXPECT_LT(aligned_most, 2.4 * std::abs(delta));
  EXPECT_EQ(settled.steppers[shoulder].lost_steps, 0);
}

// A payload the drives hold at rest once settled, but not when dropped on them: 1.5 kg.
TEST(Start, ADroppedPayloadSlipsThatASettledOneHolds) {
  const RunResult settled = tools::Run(Hold(StartMode::kSettled, 1.5), std::cerr);
  const RunResult aligned = tools::Run(Hold(StartMode::kAligned, 1.5), std::cerr);
  double slipped_aligned = 0, slipped_settled = 0;
  for (const StepperSummary& s : aligned.steppers) slipped_aligned += std::abs(s.lost_steps);
  for (const StepperSummary& s : settled.steppers) slipped_settled += std::abs(s.lost_steps);
  EXPECT_GT(slipped_aligned, 0);
  EXPECT_EQ(slipped_settled, 0);
}

// A model without gravity on its steppers has nothing to settle: the run starts at once.
TEST(Start, NothingToSettleStartsAtOnce) {
  RunOptions o;
  o.model = MJSTEPPER_SOURCE_DIR "/models/tsui_rigid.xml";
  o.duration = 0.01;
  o.progress = false;
  const RunResult r = tools::Run(o, std::cerr);
  EXPECT_EQ(r.settle_time, 0.0);
  EXPECT_NEAR(r.sim_time, 0.01, 1e-9);
}

}  // namespace
}  // namespace mjstepper::tools
