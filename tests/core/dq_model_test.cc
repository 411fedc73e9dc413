// H7: the phase-frame model (S-3, S-4) and the DQ-frame model (S-11) from the same state and the
// same inputs give the same motion.
#include "core/dq_model.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "core/presets.h"

namespace mjstepper {
namespace {

// State: θ, ω, and the currents (ia + j·ib in the phase frame, id + j·iq in the DQ frame).
struct State {
  double theta = 0, omega = 0;
  PhaseVector current;
};

// The rotor: J·dω/dt = τm + τdet − B·ω − τl with the Tsui J, B, detent and a 0.05 N·m load.
constexpr double kJ = 0.36e-4, kB = 1e-3, kLoad = 0.05;

// Phase voltages: a 6 V vector turning at 40 Hz electrical (an open-loop voltage drive).
PhaseVector PhaseVoltage(double t) { return std::polar(6.0, 2 * std::numbers::pi * 40 * t); }

State PhaseDerivative(const MotorParams& p, double t, const State& s) {
  const PhaseVector di =
      (PhaseVoltage(t) - p.resistance * s.current - BackEmf(p, s.theta, s.omega)) / p.inductance;
  const double torque = ElectromagneticTorque(p, s.theta, s.current) + DetentTorque(p, s.theta);
  return {s.omega, (torque - kB * s.omega - kLoad) / kJ, di};
}

State DqDerivative(const MotorParams& p, double t, const State& s) {
  const double x = ElectricalAngle(p, s.theta);
  const PhaseVector di = DqCurrentDerivative(p, s.current, ToDq(PhaseVoltage(t), x), s.omega);
  const double torque = DqTorque(p, s.current) + DetentTorque(p, s.theta);
  return {s.omega, (torque - kB * s.omega - kLoad) / kJ, di};
}

template <typename F>
State Rk4(const F& f, double t, const State& s, double h) {
  auto add = [](const State& a, const State& k, double c) {
    return State{a.theta + c * k.theta, a.omega + c * k.omega, a.current + c * k.current};
  };
  const State k1 = f(t, s), k2 = f(t + h / 2, add(s, k1, h / 2)),
              k3 = f(t + h / 2, add(s, k2, h / 2)), k4 = f(t + h, add(s, k3, h));
  State out = s;
  out.theta += h / 6 * (k1.theta + 2 * k2.theta + 2 * k3.theta + k4.theta);
  out.omega += h / 6 * (k1.omega + 2 * k2.omega + 2 * k3.omega + k4.omega);
  out.current += h / 6 * (k1.current + 2.0 * k2.current + 2.0 * k3.current + k4.current);
  return out;
}

// 0.2 s from rest with 1 A in phase A (both frames' initial currents describe the same vector),
// RK4 at 1 µs in each frame. The two integrations differ only by the frames' round-off and RK4's
// O(h⁴) error in each, so θ and ω agree to 1e-6 relative (1e-9 rad or rad/s floor near zero).
TEST(DqModel, H7_PhaseAndDqFramesGiveTheSameMotion) {
  const MotorParams p = FindPreset("tsui2009")->motor;
  State phase{0.0, 0.0, {1.0, 0.0}};
  State dq{0.0, 0.0, ToDq({1.0, 0.0}, 0.0)};
  const auto f_phase = [&](double t, const State& s) { return PhaseDerivative(p, t, s); };
  const auto f_dq = [&](double t, const State& s) { return DqDerivative(p, t, s); };
  const double h = 1e-6;
  double worst = 0;
  for (int k = 0; k < 200000; ++k) {
    phase = Rk4(f_phase, k * h, phase, h);
    dq = Rk4(f_dq, k * h, dq, h);
    if (k % 1000 == 999) {
      const double dt = std::abs(dq.theta - phase.theta) / std::max(std::abs(phase.theta), 1e-3);
      const double dw = std::abs(dq.omega - phase.omega) / std::max(std::abs(phase.omega), 1e-3);
      ASSERT_LT(dt, 1e-6) << "θ at t = " << (k + 1) * h;
      ASSERT_LT(dw, 1e-6) << "ω at t = " << (k + 1) * h;
      worst = std::max({worst, dt, dw});
    }
  }
  EXPECT_GT(std::abs(phase.theta), 0.1);  // it moved: 40 Hz electrical ≈ 0.8 rev/s
  std::printf("H7: largest relative difference %.2g over 0.2 s\n", worst);
}

}  // namespace
}  // namespace mjstepper
