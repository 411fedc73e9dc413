// Kim 2016's controllers in the core (no MuJoCo): the error dynamics of K(26) and K(35), the
// current-error decay of STMMS (K(17)) and FOC (K(33)), and H24's structural fact.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <type_traits>

#include "core/drive.h"
#include "core/presets.h"
#include "core/units.h"

namespace mjstepper {
namespace {

template <class T>
concept HasCurrent = requires(T t) {
  t.current;
};

// H24: the STMMS receives a MechanicalSample, which has no current field: it cannot read a current
// measurement (a compile-time fact). The same check holds for the FOC's input, which does read
// currents: the concept is not vacuous.
static_assert(std::is_same_v<Stmms::Input, MechanicalSample>);
static_assert(!HasCurrent<Stmms::Input>);
static_assert(HasCurrent<HighGainFoc::Input>);
// A MechanicalSample is the command and the position/speed feedback, and nothing else.
static_assert(sizeof(MechanicalSample) == sizeof(CommandSample) + sizeof(FeedbackSample));

TEST(Kim, H24_StmmsReadsNoCurrent) {
  EXPECT_FALSE(HasCurrent<Stmms::Input>);
  EXPECT_TRUE(HasCurrent<HighGainFoc::Input>);
}

KimMechanical Gains(double k1p) { return {.k1p = k1p, .k0 = 10, .k1 = 20, .k2 = 100}; }

// H17: A = [0 1 0; 0 −k1p 1; −k0 −k1 −k2] (K(26)) is Hurwitz with the poles of SPEC §5 for the
// three gain sets, ±0.1 %.
TEST(Kim, H17_ErrorDynamicsPoles) {
  struct Case {
    double k1p;
    double poles[3];
  };
  for (const Case& c : {Case{40000, {-40000, -100, -2.5e-6}}, Case{1000, {-1000, -100, -1e-4}},
                        Case{10000, {-10000, -100, -1e-5}}}) {
    Eigen::Matrix3d A;
    A << 0, 1, 0, 0, -c.k1p, 1, -10, -20, -100;
    Eigen::Vector3cd eig = A.eigenvalues();
    std::vector<double> re;
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(eig[i].imag(), 0.0, 1e-9 * std::abs(eig[i])) << "k1p " << c.k1p;
      re.push_back(eig[i].real());
    }
    std::sort(re.begin(), re.end());
    for (int i = 0; i < 3; ++i) {
      EXPECT_LT(re[i], 0.0);
      EXPECT_NEAR(re[i], c.poles[i], 1e-3 * std::abs(c.poles[i])) << "k1p " << c.k1p;
    }
    // The characteristic polynomial the code uses (K(35)) has these roots too.
    const auto [c2, c1, c0] = Gains(c.k1p).Characteristic();
    for (double p : re) {
      EXPECT_NEAR(p * p * p + c2 * p * p + c1 * p + c0, 0.0, 1e-9 * c1 * std::abs(p) + 1e-9);
    }
    std::printf("H17: k1p %g: poles %.6g %.6g %.6g\n", c.k1p, re[0], re[1], re[2]);
  }
}

// H18: J·|E1/T̃| at 50 Hz from K(35) equals SPEC's values ±2 %, and a simulation of the
// reduced-order error dynamics K(26) driven by a 50 Hz torque error (an ideal torque source)
// gives the same amplitude. RK4 at 1 µs (40000·1e-6 = 0.04: inside its stability region, error
// O((0.04)^4)); the amplitude is the projection on sin/cos over the last 5 periods after 0.2 s,
// when the fast transients have decayed; the slow e0 mode carries a residue O(k0/k1) ≈ 1e-6.
TEST(Kim, H18_SensitivityAt50Hz) {
  struct Case {
    double k1p, target;
  };
  const double J = 4.8e-5, f = 50;
  for (const Case& c : {Case{40000, 7.58e-8}, Case{1000, 2.894e-6}, Case{10000, 3.03e-7}}) {
    const KimMechanical k = Gains(c.k1p);
    EXPECT_NEAR(k.Sensitivity(f), c.target, 0.02 * c.target) << "k1p " << c.k1p;
    // ė = A·e + [0; 0; 1/J]·τ̃, τ̃ = sin(2πft) (N·m)
    auto rate = [&](double t, const Eigen::Vector3d& e) {
      Eigen::Vector3d de;
      de << e[1], -k.k1p * e[1] + e[2],
          -k.k0 * e[0] - k.k1 * e[1] - k.k2 * e[2] + std::sin(kTwoPi * f * t) / J;
      return de;
    };
    Eigen::Vector3d e = Eigen::Vector3d::Zero();
    const double dt = 1e-6;
    double s = 0, co = 0, t = 0;
    const long n = std::lround(0.3 / dt), window = std::lround(0.1 / dt);
    for (long i = 0; i < n; ++i) {
      const Eigen::Vector3d k1 = rate(t, e), k2 = rate(t + dt / 2, e + dt / 2 * k1),
                            k3 = rate(t + dt / 2, e + dt / 2 * k2), k4 = rate(t + dt, e + dt * k3);
      e += dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
      t += dt;
      if (i >= n - window) {
        s += e[1] * std::sin(kTwoPi * f * t);
        co += e[1] * std::cos(kTwoPi * f * t);
      }
    }
    const double amplitude = 2 * std::hypot(s, co) / window;  // rad per N·m
    EXPECT_NEAR(J * amplitude, k.Sensitivity(f), 0.02 * k.Sensitivity(f)) << "k1p " << c.k1p;
    std::printf("H18: k1p %g: K(35) %.4g, simulated %.4g rad/(N·m) (times J)\n", c.k1p,
                k.Sensitivity(f), J * amplitude);
  }
}

DriveConfig KimDrive(const Controller& controller) {
  DriveConfig c;
  c.motor = FindPreset("kim2016")->motor;
  c.controller = controller;
  c.bus_voltage = 24;
  c.isr_period = 1e-6;  // fast control, SPEC §3
  c.compute_delay = 0;
  c.encoder_counts = 0;
  return c;
}

// Holds the rotor still at θ = 0 (ω frozen), perturbs ia by 0.5 A from the drive's rest state
// and returns the decay rate of the current error |i − i_ref| fitted between 0.2 and 1.2 ms.
double CurrentErrorDecayRate(const Drive& drive) {
  DriveState s = drive.Rest(0.0, 0.0, 0.0);
  s.current_a += 0.5;
  const double h = 50e-6;
  auto error = [&] {
    return std::hypot(s.current_a - s.current_ref_a, s.current_b - s.current_ref_b);
  };
  double e1 = 0, e2 = 0;
  for (int k = 0; k < 24; ++k) {
    drive.Advance(&s, k * h, (k + 1) * h, 0.0, 0.0);
    if (k + 1 == 4) e1 = error();   // 0.2 ms
    if (k + 1 == 24) e2 = error();  // 1.2 ms
  }
  return std::log(e1 / e2) / 1e-3;
}

// H19: with no current feedback the STMMS's current error decays at R/L (K(17)), ±1 %: the
// voltage is R·id + ê whatever the current, so L·d(i − id)/dt = −R·(i − id) exactly.
TEST(Kim, H19_StmmsCurrentErrorDecaysAtROverL) {
  const Drive drive(KimDrive(Stmms{.mechanical = {.load_torque = 0.1}}));
  const double rate = CurrentErrorDecayRate(drive), expected = 2.3 / 9.0e-3;  // R/L, 1/s
  EXPECT_NEAR(rate, expected, 0.01 * expected);
  std::printf("H19: STMMS current error decays at %.4g 1/s (R/L = %.4g)\n", rate, expected);
}

// H20: the FOC's current error decays at ρ (K(33)), ±2 %: per 1 µs tick the held voltage removes
// ρ·T = 2.5 % (case 1) of the error, a discrete rate −ln(1 − ρT)/T = 1.013·ρ.
TEST(Kim, H20_FocCurrentErrorDecaysAtRho) {
  for (double rho : {25000.0, 10000.0}) {
    const Drive drive(
        KimDrive(HighGainFoc{.mechanical = {.k1p = 1000, .load_torque = 0.1}, .rho = rho}));
    const double rate = CurrentErrorDecayRate(drive);
    EXPECT_NEAR(rate, rho, 0.02 * rho);
    std::printf("H20: FOC rho %g: current error decays at %.5g 1/s\n", rho, rate);
  }
}

// The drive's trapezoid with Kim's limits (SPEC §4): 2π rad/s, 4π rad/s², from 0.5 s.
MotionProfile KimsTrapezoid() {
  return {.kind = ProfileKind::kTrapezoid,
          .max_speed = kTwoPi,
          .max_accel = 2 * kTwoPi,
          .start_time = 0.5};
}

// The trapezoid gives Kim's trajectory (SPEC §4) exactly: θd(1.0) = π/2, θd(3.0) = π/2 + 4π,
// at rest at 5π from 3.5 s, with θ̇d = 2π and θ̈d = ±4π in the ramps.
TEST(Kim, TrapezoidIsKimsTrajectory) {
  const MotionProfile p = KimsTrapezoid();
  MotionProfile::State s = MotionProfile::Rest(0.0, 0.0);
  p.Update(&s, 0.0, 5e-5, 5 * std::numbers::pi);  // before the start time: no plan yet
  EXPECT_EQ(s.target, 0.0);
  p.Update(&s, 0.49999, 0.50004, 5 * std::numbers::pi);  // the step holding 0.5 s plans from 0.5
  const double pi = std::numbers::pi;
  EXPECT_EQ(p.Evaluate(s, 0.3).theta, 0.0);
  EXPECT_NEAR(p.Evaluate(s, 0.75).accel, 4 * pi, 1e-12);
  EXPECT_NEAR(p.Evaluate(s, 1.0).theta, pi / 2, 1e-12);
  EXPECT_NEAR(p.Evaluate(s, 2.0).omega, 2 * pi, 1e-12);
  EXPECT_NEAR(p.Evaluate(s, 3.0).theta, pi / 2 + 4 * pi, 1e-12);
  EXPECT_NEAR(p.Evaluate(s, 3.25).accel, -4 * pi, 1e-12);
  EXPECT_NEAR(s.t_end, 3.5, 1e-12);
  EXPECT_EQ(p.Evaluate(s, 3.7).theta, 5 * pi);
}

// The plan's polynomial changes at its start, at each segment's end and at its end: the times an
// averaged Kim law cuts its steps at (averaged_feed_forward.h), here 0.5, 1.0, 3.0 and 3.5 s.
TEST(Kim, TheTrapezoidsBreaksAreItsSegmentsEnds) {
  const MotionProfile p = KimsTrapezoid();
  MotionProfile::State s = MotionProfile::Rest(0.0, 0.0);
  EXPECT_EQ(p.NextBreak(s, 0.0), std::numeric_limits<double>::infinity());  // at rest
  p.Update(&s, 0.49999, 0.50004, 5 * std::numbers::pi);
  EXPECT_NEAR(p.NextBreak(s, 0.2), 0.5, 1e-12);
  EXPECT_NEAR(p.NextBreak(s, 0.5), 1.0, 1e-12);
  EXPECT_NEAR(p.NextBreak(s, 1.0), 3.0, 1e-12);
  EXPECT_NEAR(p.NextBreak(s, 2.9), 3.0, 1e-12);
  EXPECT_NEAR(p.NextBreak(s, 3.0), 3.5, 1e-12);
  EXPECT_EQ(p.NextBreak(s, 3.5), std::numeric_limits<double>::infinity());
}

// The S-curve reaches the target at rest with |jerk| ≤ Jm, |θ̈| ≤ A, |θ̇| ≤ V, and its speed is
// continuous (checked by finite differences of θ at 1 µs).
TEST(Kim, SCurveRespectsLimits) {
  const MotionProfile p{
      .kind = ProfileKind::kSCurve, .max_speed = 10, .max_accel = 50, .max_jerk = 1000};
  for (double target : {3.0, 0.05, -1.0}) {
    MotionProfile::State s = MotionProfile::Rest(0.0, 0.0);
    p.Update(&s, 0.0, 1e-3, target);
    EXPECT_NEAR(p.Evaluate(s, s.t_end - 1e-12).theta, target, 1e-9);
    for (double t = 0; t < s.t_end; t += 1e-3) {
      const CommandSample c = p.Evaluate(s, t);
      EXPECT_LE(std::abs(c.omega), 10 + 1e-9);
      EXPECT_LE(std::abs(c.accel), 50 + 1e-9);
      EXPECT_LE(std::abs(c.jerk), 1000 + 1e-9);
      const double fd = (p.Evaluate(s, t + 1e-6).theta - p.Evaluate(s, t - 1e-6).theta) / 2e-6;
      EXPECT_NEAR(fd, c.omega, 1e-4) << "target " << target << " t " << t;
    }
  }
}

}  // namespace
}  // namespace mjstepper
