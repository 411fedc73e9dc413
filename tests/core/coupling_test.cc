// core/coupling.h: C-1 and C-2 on the linear oscillator they are derived for.
#include "core/coupling.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <span>
#include <vector>

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

// C-3 on two coupled rotors (G with an off-diagonal term, as an arm's parallel wrist axes give):
// symplectic Euler with the handed torques is the exact map of the linearised pair, mode by mode:
// its eigenvalues are e^(±jωᵢh) for the eigenfrequencies ωᵢ² of G·K, at ωᵢh up to 2.5; and C-3 on
// one rotor is C-2.
TEST(Coupling, CoupledRotorsRingAtTheirModes) {
  Eigen::MatrixXd g(2, 2);
  g << 1.0 / 4e-6, -0.6 / 4e-6, -0.6 / 4e-6, 1.0 / 2e-6;  // 1/(kg·m²)
  Eigen::VectorXd k(2);
  k << 13.5, 17.5;  // N·m/rad
  const Eigen::EigenSolver<Eigen::MatrixXd> exact(g * k.asDiagonal());
  const double fastest = std::sqrt(exact.eigenvalues().real().maxCoeff());  // rad/s
  for (double wh : {0.3, 1.0, 2.5}) {
    const double h = wh / fastest;
    // The map of (θ1, θ2, v1, v2) over one step, column by column.
    Eigen::MatrixXd map(4, 4);
    for (int c = 0; c < 4; ++c) {
      Eigen::VectorXd theta = Eigen::VectorXd::Zero(2), v = Eigen::VectorXd::Zero(2);
      (c < 2 ? theta : v)(c % 2) = 1;
      const Eigen::VectorXd tau = -(k.asDiagonal() * theta).eval();
      const Eigen::Matrix<double, 2, 2, Eigen::RowMajor> rows = g;
      const std::vector<double> zero(2, 0.0);
      const std::vector<double> out = ConsistentTorques(
          std::span(rows.data(), 4), std::span(k.data(), 2), std::span(tau.data(), 2), zero, h);
      const Eigen::Vector2d handed(out[0], out[1]);
      const Eigen::VectorXd v1 = v + h * g * handed;
      map.col(c) << theta + h * v1, v1;
    }
    const Eigen::EigenSolver<Eigen::MatrixXd> step(map);
    std::vector<double> angles, want;
    for (int i = 0; i < 4; ++i) {
      EXPECT_NEAR(std::abs(step.eigenvalues()(i)), 1.0, 1e-9) << wh;  // no energy gained or lost
      angles.push_back(std::abs(std::arg(step.eigenvalues()(i))));
    }
    for (int i = 0; i < 2; ++i) {
      const double w = std::sqrt(exact.eigenvalues()(i).real());
      want.insert(want.end(), {w * h, w * h});
    }
    std::sort(angles.begin(), angles.end());
    std::sort(want.begin(), want.end());
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(angles[i], want[i], 1e-9) << wh;
  }
  // Two steppers on one joint make G singular (both rows the joint's): each keeps its τ0.
  const std::vector<double> same = {1 / 3.6e-5, 1 / 3.6e-5, 1 / 3.6e-5, 1 / 3.6e-5};
  const std::vector<double> k2 = {28.5, 28.5}, tau2 = {0.3, -0.1}, a2 = {-500, -500};
  EXPECT_EQ(ConsistentTorques(same, k2, tau2, a2, 1e-3), tau2);
  // One rotor: C-3 is C-2.
  const std::vector<double> one = {1 / 3.6e-5}, k1 = {28.5}, tau1 = {0.3}, a1 = {-500};
  EXPECT_NEAR(ConsistentTorques(one, k1, tau1, a1, 1e-3)[0],
              ConsistentTorque(0.3, 28.5, 3.6e-5, -500, 1e-3), 1e-12);
}

}  // namespace
}  // namespace mjstepper
