// core/coupling.h: C-1 and C-2 on the linear oscillator they are derived for.
#include "core/coupling.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace mjstepper {
namespace {

// Symplectic Euler (MuJoCo's semi-implicit step) on θ'' = τ/J + a_ext with τ from `torque` at the
// step's start; the ring's frequency from the one-step map's trace (2·cos Ωh), rad/s.
double DiscreteFrequency(double k, double J, double h, Coupling coupling) {
  // The map of (θ, v) is linear: its columns from θ = 1 and v = 1.
  auto step = [&](double theta, double v) {
    const double tau = -k * theta;
    const double handed =
        coupling == Coupling::kConsistent ? ConsistentTorque(tau, k, J, 0.0, h) : tau;
    const double v1 = v + h * handed / J;
    return std::pair{theta + h * v1, v1};
  };
  const auto [a, c] = step(1, 0);
  const auto [b, e] = step(0, 1);
  EXPECT_NEAR(a * e - b * c, 1.0, 1e-12);  // determinant 1: no energy gained or lost
  return std::acos((a + e) / 2) / h;
}

// C-1: the consistent step rings at the linearised rotor's own ω at any ωh < π; the explicit one
// at 2·asin(ωh/2)/h, 4.7 % fast at ωh = 1 (so the test fails without C-1).
TEST(Coupling, RingsAtTheOwnFrequency) {
  const double J = 3.6e-5, k = 28.5, omega = std::sqrt(k / J);  // the Tsui rotor
  for (double wh : {0.05, 0.2, 0.5, 1.0, 1.5, 2.5, 3.0}) {
    const double h = wh / omega;
    EXPECT_NEAR(DiscreteFrequency(k, J, h, Coupling::kConsistent) / omega, 1.0, 1e-9) << wh;
    if (wh < 2) {  // beyond, the explicit step is unstable
      EXPECT_NEAR(DiscreteFrequency(k, J, h, Coupling::kExplicit) / omega,
                  2 * std::asin(wh / 2) / wh, 1e-9)
          << wh;
    }
  }
  EXPECT_GT(DiscreteFrequency(k, J, 1 / omega, Coupling::kExplicit) / omega, 1.04);
}

// C-1's σ: its series and closed forms meet; negative stiffness grows as cosh; beyond ωh = π the
// spring is held just inside Euler's stability limit σ·u < 4.
TEST(Coupling, StiffnessScale) {
  EXPECT_EQ(StiffnessScale(0), 1.0);
  for (double u : {0.99e-4, 1.01e-4, -0.99e-4, -1.01e-4}) {
    const double r = std::sqrt(std::abs(u));
    // 2·(1 − cos r)/u written as 4·sin²(r/2)/u, free of cancellation
    const double half = u > 0 ? std::sin(r / 2) : std::sinh(r / 2);
    EXPECT_NEAR(StiffnessScale(u), 4 * half * half / std::abs(u), 1e-15) << u;
  }
  EXPECT_NEAR(StiffnessScale(1.0), 2 * (1 - std::cos(1.0)), 1e-15);
  EXPECT_NEAR(StiffnessScale(-1.0), 2 * (std::cosh(1.0) - 1), 1e-15);
  const double pi2 = std::numbers::pi * std::numbers::pi;
  EXPECT_NEAR(StiffnessScale(0.999 * pi2) * 0.999 * pi2, 4.0, 1e-2);
  EXPECT_LT(StiffnessScale(2 * pi2) * 2 * pi2, 4.0);
  EXPECT_EQ(StiffnessScale(-100 * pi2), StiffnessScale(-pi2));  // held at |ω|h = π
  EXPECT_NEAR(StiffnessScale(-pi2), 2 * (std::cosh(std::numbers::pi) - 1) / pi2, 1e-12);
  EXPECT_EQ(StiffnessScale(std::nan("")), 1.0);
}

// C-2 keeps static equilibria: where τ0 + J·a_ext = 0 (a held load) the handed torque is τ0, at
// any ωh; and it is τ0 without an inertia or a step.
TEST(Coupling, StaticEquilibriumUnmoved) {
  const double J = 3.6e-5, k = 28.5, h = 1e-3;  // ωh = 0.89
  const double tau0 = 0.3, a_ext = -tau0 / J;   // a 0.3 N·m load held
  EXPECT_NEAR(ConsistentTorque(tau0, k, J, a_ext, h), tau0, 1e-15);
  EXPECT_NE(ConsistentTorque(tau0, k, J, 0.0, h), tau0);
  EXPECT_EQ(ConsistentTorque(tau0, k, 0.0, a_ext, h), tau0);
  EXPECT_EQ(ConsistentTorque(tau0, k, J, a_ext, 0.0), tau0);
}

}  // namespace
}  // namespace mjstepper
