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

using namespace two_mass;  // NOLINT: the coupling model's constants

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
