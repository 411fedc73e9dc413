// Steppers on real loads (issue 9): the compliant coupling's two-mass resonance against its closed
// form.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "core/units.h"
#include "test_model.h"

namespace mjstepper::testing {
namespace {

// models/tsui_coupling.xml without its detent (whose torque would move the rest position off the
// command and ring the slow mode by itself): rotor J_r (armature), coupling spring k, load J_l;
// the motor holds the rotor with T' = Nr·Km·I.
constexpr double kRotorInertia = 0.36e-4;  // kg·m²
constexpr double kLoadInertia = 0.72e-4;   // kg·m²
constexpr double kCoupling = 50;           // N·m/rad
constexpr double kHolding = 50 * 0.3 * 1.9;  // Nr·Km·I, N·m/rad

// The two-mass eigenfrequencies, rad/s: det(K − ω²·M) = 0 with K = [[T' + k, −k], [−k, k]],
// M = diag(J_r, J_l): J_r·J_l·ω⁴ − (J_r·k + J_l·(T' + k))·ω² + T'·k = 0.
std::pair<double, double> TwoMassFrequencies() {
  const double a = kRotorInertia * kLoadInertia;
  const double b = -(kRotorInertia * kCoupling + kLoadInertia * (kHolding + kCoupling));
  const double c = kHolding * kCoupling;
  const double root = std::sqrt(b * b - 4 * a * c);
  return {std::sqrt((-b - root) / (2 * a)), std::sqrt((-b + root) / (2 * a))};
}

// Angular frequency, rad/s, from the zero crossings of x(t) about its equilibrium 0 (the
// oscillations decay, so the mean of a window is not the equilibrium).
double ZeroCrossingFrequency(const std::vector<double>& t, const std::vector<double>& x) {
  std::vector<double> crossings;
  for (size_t i = 0; i + 1 < x.size(); ++i) {
    if ((x[i] > 0) != (x[i + 1] > 0)) {
      crossings.push_back(t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i]));
    }
  }
  if (crossings.size() < 2) return 0;
  return std::numbers::pi * (crossings.size() - 1) / (crossings.back() - crossings.front());
}

// Each mode excited alone (a velocity along its mode shape, from rest on the command; friction
// off, as Coulomb friction would stop an oscillation this small) rings at its closed-form
// frequency:
// - under an ideal current source (the torque exactly Km·I·sin δ, a spring) to 0.1 %, the
//   integrator's share ((ω·h)²/24 < 3e-4);
// - under the PI current loop to 3 %: its electrical dynamics make the holding torque a spring
//   only at low frequency, and stiffen the fast mode by 2.5 % (0.4 % the slow one).
// The single resonance splits as predicted: the slow mode lies below the rigidly coupled pair's
// √(T'/(J_r + J_l)), the fast one above the rotor's own √(T'/J_r).
TEST(Loads, CompliantCouplingRingsAtTheTwoMassFrequencies) {
  const auto [w1, w2] = TwoMassFrequencies();
  for (const char* drive : {"ideal_current", "current_microstep"}) {
    std::string xml = ShippedModelWithSignals("tsui_coupling.xml", "shaft",
                                              R"(<config key="detent" value="none"/>)");
    xml.replace(xml.find("current_microstep"), 17, drive);
    const ModelPtr m = LoadModel(xml);
    ASSERT_TRUE(m);
    ASSERT_EQ(m->nv, 2);
    m->dof_frictionloss[0] = 0;
    std::vector<double> measured;
    for (const double w : {w1, w2}) {
      const DataPtr d(mj_makeData(m.get()));
      // Mode shape (rotor 1, load b); MuJoCo's second coordinate is the twist, load − rotor.
      const double b = (kHolding + kCoupling - kRotorInertia * w * w) / kCoupling;
      const double speed = 0.01;  // rad/s: amplitude < 2.2e-5 rad, deep in the linear range
      d->qvel[0] = speed;
      d->qvel[1] = speed * (b - 1);
      std::vector<double> t, q;
      while (d->time < 10 * kTwoPi / w) {  // ten periods (the fast mode has ζ ≈ 0.03)
        mj_step(m.get(), d.get());
        t.push_back(d->time);
        q.push_back(d->qpos[0]);
      }
      measured.push_back(ZeroCrossingFrequency(t, q));
    }
    const double tolerance = std::string(drive) == "ideal_current" ? 0.001 : 0.03;
    EXPECT_NEAR(measured[0], w1, tolerance * w1) << drive;
    EXPECT_NEAR(measured[1], w2, tolerance * w2) << drive;
    EXPECT_LT(measured[0], std::sqrt(kHolding / (kRotorInertia + kLoadInertia))) << drive;
    EXPECT_GT(measured[1], std::sqrt(kHolding / kRotorInertia)) << drive;
  }
}

}  // namespace
}  // namespace mjstepper::testing
