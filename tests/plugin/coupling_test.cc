// The coupling to MuJoCo at coarse timesteps (issue 20, SPEC §10, core/coupling.h): the held
// rotor's free ring (H3's set-up) at ωn·h = 0.5 and 1 against a 1 µs reference of the same model.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include "core/analysis.h"
#include "test_model.h"

namespace mjstepper::testing {
namespace {

using namespace two_mass;  // NOLINT: the coupling model's constants

struct Ring {
  double frequency;  // Hz
  double damping;    // ζ
};

// H3: the Tsui rotor held by an ideal 1.9 A source, detent off (a spring T' = 28.5 N·m/rad on
// J = 0.36e-4 kg·m², B = 0.001 N·m·s/rad: ωn = 889.8 rad/s), released from 2 mrad, 0.2 s.
Ring Released(double h, const char* coupling) {
  const ModelPtr m = LoadModel(
      RotorModel(TsuiActuator("m1", "j1",
                              Config("drive", "ideal_current") + Config("detent", "none") +
                                  Config("coupling", coupling)),
                 "", "", 1, h));
  EXPECT_TRUE(m);
  if (!m) return {};
  const DataPtr d(mj_makeData(m.get()));
  d->qpos[0] = 0.002;  // rad
  std::vector<double> t, q;
  while (d->time < 0.2) {
    mj_step(m.get(), d.get());
    t.push_back(d->time);
    q.push_back(d->qpos[0]);
  }
  // ζ from the decay of the ring's fitted amplitude between two 50 ms windows (sampled peaks are
  // too coarse at a few samples per period): ζ = ln(A1/A2)/(Δt·ωd) for ζ << 1.
  const double f = CrossingFrequency(t, q);
  auto amplitude = [&](double from, double to) {
    std::vector<double> tw, qw;
    for (size_t k = 0; k < t.size(); ++k) {
      if (t[k] >= from && t[k] < to) tw.push_back(t[k]), qw.push_back(q[k]);
    }
    return FitTone(tw, qw, f).amplitude;
  };
  const double decay = std::log(amplitude(0.02, 0.07) / amplitude(0.12, 0.17)) / 0.1;  // 1/s
  return {f, decay / (2 * std::numbers::pi * f)};
}

constexpr double kOmegaN = 889.76;  // rad/s, √(28.5/0.36e-4)

// The ring's frequency within 1 % of the 1 µs reference at ωn·h = 0.2, 0.5 and 1 with the
// consistent coupling (measured −0.37 % and −0.79 %: C-2 makes the undamped linearised step exact;
// what is left is MuJoCo's implicit damping of B = 0.001, whose step 1/(1 + h·B/J) lowers the
// discrete ring, and which C-2 leaves as MuJoCo does it). Its damping ratio within 2 % (measured
// −0.6 % and −1.2 %: the same implicit step against e^(−h·B/J)). The explicit coupling is fast by
// about 2·asin(ωn·h/2)/(ωn·h) − 1 less the damping's share (measured +0.70 % and +3.88 %) and its ζ
// low by 1.5 % and 4.8 %: the test fails without C-2.
TEST(Coupling, RingsAtTheReferenceFrequencyAtCoarseSteps) {
  const Ring reference = Released(1e-6, "consistent");
  EXPECT_NEAR(reference.frequency, 141.6, 0.01 * 141.6);  // H3
  std::printf("reference (1 us): fn %.3f Hz, zeta %.5f\n", reference.frequency, reference.damping);
  for (double wh : {0.2, 0.5, 1.0}) {
    const Ring consistent = Released(wh / kOmegaN, "consistent");
    const Ring explicit_ = Released(wh / kOmegaN, "explicit");
    std::printf(
        "wn*h = %.1f: consistent fn %.3f Hz (%+.3f %%), zeta %.5f (%+.1f %%); explicit "
        "fn %.3f Hz (%+.3f %%), zeta %.5f (%+.1f %%)\n",
        wh, consistent.frequency, 100 * (consistent.frequency / reference.frequency - 1),
        consistent.damping, 100 * (consistent.damping / reference.damping - 1), explicit_.frequency,
        100 * (explicit_.frequency / reference.frequency - 1), explicit_.damping,
        100 * (explicit_.damping / reference.damping - 1));
    EXPECT_NEAR(consistent.frequency / reference.frequency, 1.0, 0.01) << wh;
    EXPECT_NEAR(consistent.damping / reference.damping, 1.0, 0.02) << wh;
    if (wh < 0.5) continue;  // 0.2: printed (the explicit error is itself small there)
    EXPECT_GT(explicit_.frequency / reference.frequency - 1, 0.6 * (2 * std::asin(wh / 2) / wh - 1))
        << wh;
    EXPECT_GT(std::abs(explicit_.frequency / reference.frequency - 1), 0.006) << wh;
    if (wh == 1.0) {
      EXPECT_LT(explicit_.damping / reference.damping, 0.97);
    }
  }
}

// The two-mass modes of models/tsui_coupling.xml (72.2 and 260.0 Hz, tests/plugin/loads_test.cc)
// at the step where the rotor alone has ωn·h = 0.5 (the fast mode's ω·h is then 0.92), each mode
// excited alone under the ideal current source, against a 1 µs reference. Measured: the slow mode
// −0.01 % (explicit +0.20 %), asserted within 0.1 %; the fast one +2.59 % (explicit +3.49 %):
// MuJoCo integrates the coupling's own spring (k = 50 N·m/rad, the fast mode's larger share)
// explicitly whatever the stepper's coupling, so there C-2 removes only the stepper's share of the
// error; asserted only to be smaller than the explicit coupling's (docs/coupling.md).
// The coupling as each instance parses it (trimmed): " explicit " is the explicit coupling, in
// the instance itself and in the model's solve of its coupled steppers, which must not hand it the
// consistent torque. At ωn·h = 1 the two ring 3.9 % apart.
TEST(Coupling, ASpacedValueIsTheCouplingItNames) {
  const double h = 1.0 / kOmegaN;
  const Ring explicit_ = Released(h, "explicit");
  EXPECT_DOUBLE_EQ(Released(h, " explicit ").frequency, explicit_.frequency);
  EXPECT_GT(explicit_.frequency / Released(h, "consistent").frequency - 1, 0.03);
}

TEST(Coupling, TwoMassModesAtCoarseSteps) {
  const auto [w1, w2] = TwoMassFrequencies();
  auto ring = [&](double h, const char* coupling, double w) {
    std::string xml = ShippedModelWithSignals(
        "tsui_coupling.xml", "shaft", Config("detent", "none") + Config("coupling", coupling));
    xml.replace(xml.find("current_microstep"), 17, "ideal_current");
    const size_t at = xml.find("timestep=\"");
    xml.replace(at + 10, xml.find('"', at + 10) - at - 10, fmt::format("{:.17g}", h));
    const ModelPtr m = LoadModel(xml);
    EXPECT_TRUE(m);
    if (!m) return 0.0;
    m->dof_frictionloss[0] = 0;
    const DataPtr d(mj_makeData(m.get()));
    const double b = (kHolding + kCoupling - kRotorInertia * w * w) / kCoupling;
    d->qvel[0] = 0.01;
    d->qvel[1] = 0.01 * (b - 1);
    std::vector<double> t, q;
    while (d->time < 10 * 2 * std::numbers::pi / w) {
      mj_step(m.get(), d.get());
      t.push_back(d->time);
      q.push_back(d->qpos[0]);
    }
    return ZeroCrossingFrequency(t, q);
  };
  const double h = 0.5 / kOmegaN;
  for (const double w : {w1, w2}) {
    const double reference = ring(1e-6, "consistent", w);
    EXPECT_NEAR(reference, w, 1e-3 * w);
    const double consistent = ring(h, "consistent", w), explicit_ = ring(h, "explicit", w);
    std::printf(
        "mode %.1f Hz at wn*h = 0.5 (its w*h %.2f): consistent %+.2f %%, explicit %+.2f %%\n",
        w / (2 * std::numbers::pi), w * h, 100 * (consistent / reference - 1),
        100 * (explicit_ / reference - 1));
    EXPECT_LT(std::abs(consistent / reference - 1), std::abs(explicit_ / reference - 1));
    if (w == w1) {
      EXPECT_NEAR(consistent / reference, 1.0, 1e-3);
    }
  }
}

// The consistent coupling counts, among the model's other forces, the gravity compensation that
// MuJoCo applies through the actuators (a joint's actuatorgravcomp: qfrc_gravcomp goes to
// qfrc_actuator, not qfrc_passive). A 0.1 kg arm 0.1 m out on a horizontal Tsui rotor, its body
// gravcomp="1": weightless, held at θ = 0 by a torque of exactly 0 (ideal 1.9 A, detent off), at
// ωn·h = 1 (ωn = √(28.5/1.036e-3) = 166 rad/s). Counted, a_ext = 0 and the handed torque is 0: the
// rotor stays at 0 to round-off (measured below 1e-15 rad). Left out, a_ext is gravity's −m·g·r/J
// and C-2 hands (1 − σ(1))·m·g·r = 0.081 · 0.098 N·m, a spurious 7.9e-3 N·m that moves the rotor's
// equilibrium by 7.9e-3 / 28.5 = 2.8e-4 rad (with the plugin's gravcomp line removed the rotor,
// ringing about it, is at −9.3e-5 rad at 0.5 s).
// Asserted: below 1e-9 rad after 0.5 s, through the actuators and through MuJoCo's passive route.
TEST(Coupling, CountsGravityCompensatedThroughTheActuators) {
  constexpr double kArmInertia = 0.1 * 0.1 * 0.1;                    // m·r², kg·m²
  const double omega_n = std::sqrt(28.5 / (kArmInertia + 0.36e-4));  // rad/s
  auto held = [&](const char* actuatorgravcomp) {
    const std::string xml = fmt::format(
        R"(<mujoco>
  <option timestep="{:.17g}" integrator="implicitfast"/>
  <extension><plugin plugin="mjstepper.stepper"/></extension>
  <worldbody>
    <body name="arm" gravcomp="1">
      <joint name="j1" type="hinge" axis="0 1 0" actuatorgravcomp="{}"/>
      <inertial pos="0.1 0 0" mass="0.1" diaginertia="1e-9 1e-9 1e-9"/>
    </body>
  </worldbody>
  <actuator>{}</actuator>
</mujoco>)",
        1.0 / omega_n, actuatorgravcomp,
        TsuiActuator("m1", "j1",
                     Config("drive", "ideal_current") + Config("detent", "none") +
                         Config("coupling", "consistent")));
    const ModelPtr m = LoadModel(xml);
    EXPECT_TRUE(m);
    if (!m) return 0.0;
    const DataPtr d(mj_makeData(m.get()));
    while (d->time < 0.5) mj_step(m.get(), d.get());
    EXPECT_NEAR(std::abs(d->qfrc_gravcomp[0]), 0.1 * 9.81 * 0.1, 1e-9);  // the weight compensated
    return d->qpos[0];
  };
  const double through_actuators = held("true");
  const double passive = held("false");  // MuJoCo's passive route, which the coupling reads there
  std::printf(
      "arm weightless by gravcomp at wn*h = 1: rotor at %.3g rad (actuators), %.3g rad "
      "(passive)\n",
      through_actuators, passive);
  EXPECT_LT(std::abs(through_actuators), 1e-9);
  EXPECT_LT(std::abs(passive), 1e-9);
}

}  // namespace
}  // namespace mjstepper::testing
