// core/coupling.h: C-1 and C-2 on the linear oscillator they are derived for; core/substep.h's
// sub-step count.
#include "core/coupling.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <span>
#include <stdexcept>
#include <vector>

#include "core/substep.h"

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

// C-1's σ: its series (C-4's, for |u| <= 9) and closed forms meet, near zero and either side of
// the switch at |u| = 9; negative stiffness grows as cosh; beyond ωh = π the spring is held just
// inside Euler's stability limit σ·u < 4.
TEST(Coupling, StiffnessScale) {
  EXPECT_EQ(StiffnessScale(0), 1.0);
  for (double u : {0.99e-4, 1.01e-4, -0.99e-4, -1.01e-4, 0.5, -3.0, 8.999, 9.001, -8.999, -9.001}) {
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
      std::vector<double> out(2);
      ConsistentTorques(std::span(rows.data(), 4), std::span(k.data(), 2), std::span(tau.data(), 2),
                        zero, h, out);
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
  // One rotor: C-3 is C-2.
  const std::vector<double> one = {1 / 3.6e-5}, k1 = {28.5}, tau1 = {0.3}, a1 = {-500};
  std::vector<double> out1(1);
  ConsistentTorques(one, k1, tau1, a1, 1e-3, out1);
  EXPECT_NEAR(out1[0], ConsistentTorque(0.3, 28.5, 3.6e-5, -500, 1e-3), 1e-12);
}

// The two routes to C-3 (C-4's series while ‖h²·G·K‖∞ <= 9, the eigenproblem beyond) are one
// function: on six coupled rotors (an arm-like G, stiffnesses of both signs) at steps whose
// ‖h²·G·K‖∞ is 0.04, 1 and 8.9 (series) and 9.1 and 11 (eigenproblem), the handed torques agree
// with σ(h²·A) formed from A's own eigenvectors (to 1e-9: that reference's own round-off is about
// 1e-11).
TEST(Coupling, SeriesAndEigenproblemAgree) {
  constexpr int n = 6;
  Eigen::MatrixXd r(n, n);  // moment rows of a random-ish, well-conditioned arm
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) r(i, j) = (i == j ? 3.0 : 0.0) + std::sin(1.7 * i + 0.9 * j);
  }
  const Eigen::MatrixXd g = r * r.transpose() * 2e4;  // 1/(kg·m²), positive definite
  Eigen::VectorXd k(n), tau(n), a(n);
  k << 13.5, 17.5, 9.0, -2.0, 11.0, 6.5;  // N·m/rad: one rotor past its pull-out angle
  tau << 0.3, -0.1, 0.05, 0.2, -0.25, 0.12;
  a << -500, 200, 40, -90, 10, 300;
  // Reference: σ(h²·A)·a0 from A's eigendecomposition, then τ = G⁻¹·(σ·a0 − a_ext) (C-3).
  const Eigen::EigenSolver<Eigen::MatrixXd> modes(g * k.asDiagonal());
  const Eigen::MatrixXd g_rows = g;  // column-major; G is symmetric, so row-major reads the same
  const std::vector<double> gv(g_rows.data(), g_rows.data() + n * n);
  const std::vector<double> kv(k.data(), k.data() + n), tv(tau.data(), tau.data() + n),
      av(a.data(), a.data() + n);
  double largest = 0;  // 1/s²: the fastest mode's ω²
  for (int i = 0; i < n; ++i) largest = std::max(largest, std::abs(modes.eigenvalues()(i).real()));
  double norm = 0;  // ‖G·K‖∞
  for (int i = 0; i < n; ++i)
    norm = std::max(norm, (g.row(i).cwiseProduct(k.transpose())).cwiseAbs().sum());
  // Steps whose ‖h²·G·K‖∞ is 0.04 (the rule's steps), 1, 8.9 and 9.1 (either side of the switch)
  // and whose fastest ωh is 2.9 (eigenproblem only).
  std::vector<double> steps;
  for (double x : {0.04, 1.0, 8.9, 9.1}) steps.push_back(std::sqrt(x / norm));
  steps.push_back(2.9 / std::sqrt(largest));
  for (double h : steps) {
    Eigen::VectorXcd sigma(n);
    for (int i = 0; i < n; ++i) sigma(i) = StiffnessScale(h * h * modes.eigenvalues()(i).real());
    const Eigen::MatrixXcd v = modes.eigenvectors();
    const Eigen::VectorXd a0 = g * tau + a;
    const Eigen::VectorXd scaled = (v * sigma.asDiagonal() * v.inverse() * a0).real();
    const Eigen::VectorXd want = g.ldlt().solve(scaled - a);
    std::vector<double> got(n);
    ConsistentTorques(gv, kv, tv, av, h, got);
    for (int i = 0; i < n; ++i) {
      EXPECT_NEAR(got[i], want[i], 1e-9 * want.cwiseAbs().maxCoeff()) << "h = " << h << ", i " << i;
      EXPECT_NE(got[i], tau(i));  // solved, not left at τ0
    }
  }
}

// Uncoupled rotors (G diagonal): C-3 is C-2 on each (in closed form), whichever route serves, to
// round-off. The
// stiffnesses are spread so that at the coarsest step one rotor is past ωh = π, where C-1 holds
// σ·u at 3.96 (the series, continued there, would not).
TEST(Coupling, UncoupledRotorsGetTheirOwnConsistentTorque) {
  constexpr double kPiSquared = std::numbers::pi * std::numbers::pi;
  const std::vector<double> inertia = {3.6e-5, 1e-4, 2e-5};  // kg·m²
  const std::vector<double> g = {1 / inertia[0], 0, 0, 0, 1 / inertia[1], 0, 0, 0, 1 / inertia[2]};
  const std::vector<double> k = {28.5, 5.0, -3.0}, tau = {0.3, -0.1, 0.05}, a = {-500, 40, 900};
  for (double h : {1e-5, 3e-4, 1e-3, 2.2e-3, 3.3e-3, 4e-3}) {  // ‖X‖∞ = h²·28.5/3.6e-5: to 12.7
    std::vector<double> out(3);
    ConsistentTorques(g, k, tau, a, h, out);
    for (int i = 0; i < 3; ++i) {
      // C-1 and C-2 in closed form (sin, sinh, the hold), not through StiffnessScale's series.
      const double u = k[i] * h * h / inertia[i], r = std::sqrt(std::abs(u));
      const double half = u > 0 ? std::sin(r / 2) : std::sinh(r / 2);
      const double sigma = u >= kPiSquared ? 3.96 / u : 4 * half * half / std::abs(u);
      const double want = sigma * tau[i] + (sigma - 1) * inertia[i] * a[i];
      EXPECT_NEAR(out[i], want, 1e-14 * (std::abs(tau[i]) + inertia[i] * std::abs(a[i]))) << h;
    }
  }
  std::vector<double> out(2);
  EXPECT_THROW(ConsistentTorques(g, k, tau, a, 1e-3, out), std::invalid_argument);  // out too short
}

// Two steppers on one joint make G singular (both rows the joint's). C-4 hands the pair C-2 of
// their joint (the sum of their torques is the joint's C-2 with the summed stiffness), shared in
// proportion to their stiffnesses; beyond C-4's reach, where C-3 needs G⁻¹, each keeps its τ0.
TEST(Coupling, TwoSteppersOnOneJoint) {
  const double j = 3.6e-5;  // kg·m², the joint's inertia
  const std::vector<double> same = {1 / j, 1 / j, 1 / j, 1 / j};
  const std::vector<double> k2 = {28.5, 14.25}, tau2 = {0.3, -0.1}, a2 = {-500, -500};
  std::vector<double> out(2);
  const double h = 1e-3;  // h²·(k1 + k2)/J = 1.19
  ConsistentTorques(same, k2, tau2, a2, h, out);
  EXPECT_NEAR(out[0] + out[1], ConsistentTorque(0.2, 42.75, j, -500, h), 1e-12);
  EXPECT_NEAR((out[0] - tau2[0]) / (out[1] - tau2[1]), 2.0, 1e-12);
  const double coarse = 3e-3;  // h²·(k1 + k2)/J = 10.7: past the series' reach
  ConsistentTorques(same, k2, tau2, a2, coarse, out);
  EXPECT_EQ(out, tau2);
}

// The sub-step count (core/substep.h): the stiffest rotor mode at ω·δ <= 0.6, whose linearised
// ring C-3 makes exact at any ω·δ, and the torque's forcing at ω·δ <= 0.3, whose change over a
// sub-step C-3 holds. PAROL6 holding at 1 ms (its ring bound about 2 400 rad/s, no forcing at rest)
// takes 4 sub-steps, not the 8 of one bound of 0.3 for both.
TEST(SubstepCount, TheRingAtSixTenthsAndTheForcingAtThreeTenthsOfARadianPerSubstep) {
  EXPECT_EQ(SubstepCount(2400, 0, 1e-3), 4);
  EXPECT_EQ(SubstepCount(0, 2400, 1e-3), 8);
  EXPECT_EQ(SubstepCount(2400, 2400, 1e-3), 8);  // the larger count
  EXPECT_EQ(SubstepCount(2401, 0, 1e-3), 5);     // the least N at or under the bound
  EXPECT_EQ(SubstepCount(0, 0, 1e-3), 1);
  EXPECT_EQ(SubstepCount(std::numeric_limits<double>::quiet_NaN(), 0, 1e-3), 1);
  EXPECT_EQ(SubstepCount(0, 1e12, 1e-3), kMaxSubsteps);
}

}  // namespace
}  // namespace mjstepper
