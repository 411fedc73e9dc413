// Kim 2016 on MuJoCo: the shipped models (models/kim_*.xml: kim2016 preset, τl = 0.1 N·m as a
// constant generalised force, 24 V, 1 MHz control inside 50 µs steps, Kim's trajectory from the
// drive's trapezoid profile), targets H21-H23 of SPEC §5.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "../plugin/test_model.h"
#include "core/drive.h"

namespace mjstepper::testing {
namespace {

constexpr double kTarget = 5 * std::numbers::pi;  // rad: Kim's final position

struct KimRun {
  double max_error_in_motion = 0;  ///< max |e1| over 0.5-3.5 s, rad
  double final_error = 0;          ///< |e1(4 s)|, rad
  double peak_voltage = 0;         ///< V
};

// Runs a shipped Kim model for 4 s with ctrl = 5π; e1 = θ − θd from qpos and the theta_cmd signal.
KimRun RunKim(const std::string& model, const std::string& extra = "") {
  const ModelPtr m = LoadModel(ShippedModelWithSignals(model, "shaft", extra));
  EXPECT_TRUE(m) << model;
  KimRun r;
  if (!m) return r;
  const DataPtr d(mj_makeData(m.get()));
  const long steps = std::lround(4.0 / m->opt.timestep);
  for (long k = 0; k < steps; ++k) {
    d->ctrl[0] = kTarget;
    mj_step(m.get(), d.get());
    // sensordata describes the step's start, as qpos did before mj_step: compare at d->time − h.
    const double t = d->time - m->opt.timestep;
    const double* s = d->sensordata;
    r.peak_voltage = std::max({r.peak_voltage, std::abs(s[kVoltageA]), std::abs(s[kVoltageB])});
    if (t >= 0.5 && t <= 3.5) {
      r.max_error_in_motion =
          std::max(r.max_error_in_motion, std::abs(d->actuator_length[0] - s[kThetaCmd]));
    }
  }
  mj_forward(m.get(), d.get());
  r.final_error = std::abs(d->qpos[0] - d->sensordata[kThetaCmd]);
  EXPECT_EQ(d->sensordata[kThetaCmd], kTarget);
  return r;
}

// H22: every Kim controller ends within 1e-5 rad of 5π at 4 s (fast control, ideal sensors).
TEST(KimPaper, H22_AllControllersSettleOnTheTarget) {
  for (const char* model : {"kim_stmms.xml", "kim_foc_case1.xml", "kim_foc_case2.xml"}) {
    const KimRun r = RunKim(model);
    EXPECT_LT(r.final_error, 1e-5) << model;
    EXPECT_LE(r.peak_voltage, 24.0) << model;  // the bus limit holds on every controller
    std::printf("H22: %s: max |e1| in motion %.3g rad, |e1(4 s)| %.3g rad, peak |v| %.3g V\n",
                model, r.max_error_in_motion, r.final_error, r.peak_voltage);
  }
}

// H23: the STMMS's tracking error is O(L) (Kim Theorem 1): with L halved the largest error during
// the motion is at least 2× smaller.
TEST(KimPaper, H23_StmmsErrorScalesWithInductance) {
  const KimRun nominal = RunKim("kim_stmms.xml");
  const KimRun halved = RunKim("kim_stmms.xml", Config("inductance", "4.5e-3"));
  EXPECT_GE(nominal.max_error_in_motion, 2.0 * halved.max_error_in_motion);
  std::printf("H23: max |e1| in motion %.4g rad at L = 9 mH, %.4g rad at 4.5 mH (x%.2f)\n",
              nominal.max_error_in_motion, halved.max_error_in_motion,
              nominal.max_error_in_motion / halved.max_error_in_motion);
}

// H21: the STMMS holding at rest against τl = 0.1 N·m, started with no current (the load then
// pulls the rotor back), returns within 1e-6 rad of its command within 0.5 s, and its current
// settles at τl/Km = 0.2083 A (a τd = τl feed-forward; 1e-4 relative).
TEST(KimPaper, H21_StmmsHoldsAgainstTheLoad) {
  const ModelPtr m = LoadModel(ShippedModelWithSignals("kim_stmms.xml", "shaft"));
  ASSERT_TRUE(m);
  const DataPtr d(mj_makeData(m.get()));
  mj_step(m.get(), d.get());  // the drive starts at rest on the rotor (SPEC §6)...
  for (const size_t field : {offsetof(DriveCoreState, current_a),
                             offsetof(DriveCoreState, current_b),
                             offsetof(DriveCoreState, voltage_a),
                             offsetof(DriveCoreState, voltage_b)}) {
    d->plugin_state[field / sizeof(double)] = 0.0;  // ...then loses its current
  }
  double worst = 0;
  for (long k = 0; k < 10000; ++k) {  // 0.5 s
    d->ctrl[0] = 0.0;
    mj_step(m.get(), d.get());
    worst = std::max(worst, std::abs(d->qpos[0]));
  }
  mj_forward(m.get(), d.get());
  const double e1 = d->qpos[0] - d->sensordata[kThetaCmd];
  const double current = std::hypot(d->sensordata[kCurrentA], d->sensordata[SignalIndex("current_b")]);
  EXPECT_GT(worst, 1e-5);  // the load did pull it away
  EXPECT_LT(std::abs(e1), 1e-6);
  EXPECT_NEAR(current, 0.1 / 0.48, 1e-4 * 0.1 / 0.48);
  std::printf("H21: pulled %.3g rad away, |e1(0.5 s)| = %.3g rad, |i| = %.6f A\n", worst,
              std::abs(e1), current);
}

}  // namespace
}  // namespace mjstepper::testing
