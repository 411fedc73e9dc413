// The exact winding solution (winding.h) against closed forms, RK4 and explicit Euler.
#include "core/winding.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/presets.h"
#include "core/units.h"

namespace mjstepper {
namespace {

MotorParams Tsui() { return FindPreset("tsui2009")->motor; }

// One 50 µs tick, rotor still, V held: i(T) = V/R + (i0 − V/R)·exp(−R·T/L). Closed form: the
// bound is round-off (1e-12 relative). Explicit Euler with the same interval must be worse.
TEST(Winding, ExactAtRestMatchesClosedFormAndBeatsEuler) {
  const MotorParams p = Tsui();
  const PhaseVector v(10.0, -4.0), i0(0.5, 0.2);
  const double h = 50e-6;
  const PhaseVector exact =
      v / p.resistance + (i0 - v / p.resistance) * std::exp(-p.resistance * h / p.inductance);
  const PhaseVector got = WindingInterval(p, i0, v, 0.3, 0.0).CurrentAt(h);
  EXPECT_NEAR(std::abs(got - exact), 0.0, 1e-12 * std::abs(exact));
  const PhaseVector euler = i0 + h * (v - p.resistance * i0) / p.inductance;
  EXPECT_LT(std::abs(got - exact), std::abs(euler - exact));
}

// Rotor at 1200 r/min: the exact solution against RK4 with 0.1 µs steps over 1 ms. RK4's error is
// about (Nr·ω·dt)⁴ ≈ 4e-13 of the current per step, 1e4 steps: the bound 1e-8 A is RK4's, not ours.
TEST(Winding, ExactMatchesFineRk4WhileTurning) {
  const MotorParams p = Tsui();
  const double omega = RpmToRadPerSec(1200);
  const PhaseVector v(20.0, 5.0), i0(1.9, -0.3);
  const double theta0 = 0.01, h = 1e-3;
  const PhaseVector exact = WindingInterval(p, i0, v, theta0, omega).CurrentAt(h);
  const PhaseVector rk4 = IntegrateWindingRk4(p, i0, v, theta0, omega, h, 1e-7);
  EXPECT_NEAR(std::abs(exact - rk4), 0.0, 1e-8);
}

// Stable for any interval: over 10 s (4000 electrical time constants) the transient is gone and
// the current is the steady response v/R + P·e^{jx(h)}, P = −j·Km·ω/(R + j·Nr·ω·L). Euler with the
// same interval diverges (|1 − h·R/L| ≈ 4e3).
TEST(Winding, StableForAnyIntervalLength) {
  const MotorParams p = Tsui();
  const double omega = RpmToRadPerSec(1200), h = 10.0;
  const PhaseVector v(24.0, 0.0), i0(3.0, 3.0);
  const PhaseVector got = WindingInterval(p, i0, v, 0.0, omega).CurrentAt(h);
  const PhaseVector emf_gain = PhaseVector(0, -p.torque_constant * omega) /
                               PhaseVector(p.resistance, p.rotor_teeth * omega * p.inductance);
  const PhaseVector steady = v / p.resistance + emf_gain * UnitPhasor(p.rotor_teeth * omega * h);
  ASSERT_TRUE(std::isfinite(got.real()) && std::isfinite(got.imag()));
  // The phase x(h) = 6e4 rad carries round-off of about 1e-11 rad; the bound allows 1e-9 A.
  EXPECT_NEAR(std::abs(got - steady), 0.0, 1e-9);
  const PhaseVector euler =
      i0 + h * (v - p.resistance * i0 - BackEmf(p, 0.0, omega)) / p.inductance;
  EXPECT_GT(std::abs(euler), 1e3);
}

// S-8 on one interval: ∫(va·ia + vb·ib) = ∫R·|i|² + Δ(L·|i|²/2) + ∫τm·ω. Each integral is in
// closed form from the exact solution, so the balance holds to round-off (1e-12 of the input)
// only if the solution satisfies S-3: a wrong CurrentAt fails it.
TEST(Winding, IntervalEnergyBalances) {
  const MotorParams p = Tsui();
  const double omega = RpmToRadPerSec(1200), h = 50e-6;
  const PhaseVector v(30.0, -12.0), i0(1.0, 2.0);
  const WindingInterval w(p, i0, v, 0.2, omega);
  const IntervalEnergy e = w.Energy(h);
  const double stored = 0.5 * p.inductance * (std::norm(w.CurrentAt(h)) - std::norm(i0));
  EXPECT_NEAR(e.input, e.copper + stored + e.mechanical, 1e-12 * std::abs(e.input));
  // And a cross-check of the closed-form integrals against a fine midpoint sum (1e-6: the sum's).
  double input = 0, copper = 0, mechanical = 0;
  const int n = 20000;
  for (int k = 0; k < n; ++k) {
    const double t = (k + 0.5) * h / n;
    const PhaseVector i = w.CurrentAt(t);
    input += (std::conj(v) * i).real() * h / n;
    copper += p.resistance * std::norm(i) * h / n;
    mechanical += ElectromagneticTorque(p, 0.2 + omega * t, i) * omega * h / n;
  }
  EXPECT_NEAR(e.input, input, 1e-6 * std::abs(input));
  EXPECT_NEAR(e.copper, copper, 1e-6 * copper);
  EXPECT_NEAR(e.mechanical, mechanical, 1e-6 * std::abs(input));
}

// A rotating voltage v(t) = v0·e^{jΩc·t} (the averaged voltage drive, SPEC §11): with Ωc = 0 it is
// AdvanceInterval's held voltage (to round-off); turning, it matches 10 000 held intervals of
// 0.1 µs at the voltage's midpoint values over 1 ms (the staircase's error, about (Ωc·dt)²/24 of
// the current: 1e-8 A, bounded at 1e-6 A), with the command at 1200 r/min and the rotor slower.
TEST(Winding, RotatingVoltageIsTheLimitOfHeldIntervals) {
  const MotorParams p = Tsui();
  const PhaseVector v0(2.0, 1.5), i0(1.0, -0.5), z0 = UnitPhasor(0.3);
  const double omega = RpmToRadPerSec(1000), wc = p.rotor_teeth * RpmToRadPerSec(1200);
  const double h = 1e-3;
  // Ωc = 0: the held voltage.
  IntervalEnergy held, rotating;
  const PhaseVector a = AdvanceInterval(p, WindingKernel(p, omega, h), i0, v0, z0, &held);
  const PhaseVector b = AdvanceRotatingVoltage(p, omega, i0, v0, 0.0, h, z0, &rotating);
  EXPECT_NEAR(std::abs(a - b), 0.0, 1e-12);
  EXPECT_NEAR(held.input, rotating.input, 1e-12);
  EXPECT_NEAR(held.copper, rotating.copper, 1e-12);
  EXPECT_NEAR(held.mechanical, rotating.mechanical, 1e-12);
  // Turning.
  const int n = 10000;
  const double dt = h / n;
  PhaseVector i = i0;
  for (int k = 0; k < n; ++k) {
    const PhaseVector v = v0 * UnitPhasor(wc * (k + 0.5) * dt);
    i = AdvanceInterval(p, WindingKernel(p, omega, dt), i, v,
                        z0 * UnitPhasor(p.rotor_teeth * omega * k * dt), nullptr);
  }
  const PhaseVector exact = AdvanceRotatingVoltage(p, omega, i0, v0, wc, h, z0, nullptr);
  EXPECT_NEAR(std::abs(exact - i), 0.0, 1e-6);
  EXPECT_GT(std::abs(exact - a), 0.1);  // A: the rotation matters here
}

// S-8 for the rotating voltage: the closed-form energies balance to round-off, and match a fine
// midpoint sum of the solution itself (1e-6: the sum's).
TEST(Winding, RotatingVoltageEnergyBalances) {
  const MotorParams p = Tsui();
  const PhaseVector v0(1.5, -2.0), i0(0.4, 1.2), z0 = UnitPhasor(-0.7);
  const double omega = RpmToRadPerSec(300), wc = p.rotor_teeth * RpmToRadPerSec(-150);
  const double h = 2e-3, theta0 = -0.7 / p.rotor_teeth;
  IntervalEnergy e;
  const PhaseVector i1 = AdvanceRotatingVoltage(p, omega, i0, v0, wc, h, z0, &e);
  const double stored = 0.5 * p.inductance * (std::norm(i1) - std::norm(i0));
  EXPECT_NEAR(e.input, e.copper + stored + e.mechanical, 1e-12 * std::abs(e.input));
  double input = 0, copper = 0, mechanical = 0;
  const int n = 20000;
  for (int k = 0; k < n; ++k) {
    const double t = (k + 0.5) * h / n;
    const PhaseVector i = AdvanceRotatingVoltage(p, omega, i0, v0, wc, t, z0, nullptr);
    const PhaseVector v = v0 * UnitPhasor(wc * t);
    input += (std::conj(v) * i).real() * h / n;
    copper += p.resistance * std::norm(i) * h / n;
    mechanical += ElectromagneticTorque(p, theta0 + omega * t, i) * omega * h / n;
  }
  EXPECT_NEAR(e.input, input, 1e-6 * std::abs(input));
  EXPECT_NEAR(e.copper, copper, 1e-6 * copper);
  EXPECT_NEAR(e.mechanical, mechanical, 1e-6 * std::abs(input));
  EXPECT_GT(std::abs(e.mechanical), 1e-3 * std::abs(e.input));  // the rotor's share is there
}

}  // namespace
}  // namespace mjstepper
