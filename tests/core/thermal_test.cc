// Heat (SPEC §8, core/thermal.h): the two-node network against its closed form, the catalogue
// presets' networks against the datasheet numbers they were fitted to, a held rotor on a chopper
// warming as the closed form says, a hot winding lowering the chopper's top speed as R(T) says,
// and S-8 still holding while R and Km change from step to step.
#include "core/thermal.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <numbers>
#include <utility>
#include <vector>

#include "core/controllers/registry.h"
#include "core/drive.h"
#include "core/presets.h"
#include "core/units.h"

namespace mjstepper {
namespace {

// The winding's rise θw(t) under a power P held from θ = 0, derived apart from the code (which
// works in a symmetrised eigenbasis): the characteristic polynomial of
//   C_w·θw' = P − (θw − θh)/R_wh,   C_h·θh' = (θw − θh)/R_wh − θh/R_ha
// is s² + s·(g/C_w + (g + k)/C_h) + g·k/(C_w·C_h) (g = 1/R_wh, k = 1/R_ha), with real roots
// s1 < s2 < 0; θw = θ∞ + a1·e^{s1·t} + a2·e^{s2·t}, θ∞ = P·(R_wh + R_ha), with θw(0) = 0 and
// θw'(0) = P/C_w fixing a1 and a2.
double WindingRiseClosedForm(const ThermalParams& p, double power, double t) {
  const double g = 1 / p.resistance_winding, k = 1 / p.resistance_housing;
  const double b = g / p.capacity_winding + (g + k) / p.capacity_housing;
  const double c = g * k / (p.capacity_winding * p.capacity_housing);
  const double root = std::sqrt(b * b - 4 * c);
  const double s1 = (-b - root) / 2, s2 = c / s1;  // (s1·s2 = c: no cancellation in s2)
  const double final_rise = power * (p.resistance_winding + p.resistance_housing);
  // a1 + a2 = −θ∞,  s1·a1 + s2·a2 = P/C_w
  const double a1 = (power / p.capacity_winding + s2 * final_rise) / (s1 - s2);
  const double a2 = -final_rise - a1;
  return final_rise + a1 * std::exp(s1 * t) + a2 * std::exp(s2 * t);
}

// The qsh4218_41's network (presets.cc): R_wh 0.619, R_ha 6.04 K/W, C_w 12.9, C_h 204 J/K.
ThermalParams Qsh4218_41() { return *FindPreset("qsh4218_41")->thermal; }

TEST(ThermalNetwork, ConstantPowerFollowsTheTwoNodeClosedFormAtAnyStep) {
  // 9 W (the qsh4218_41 at its rated 1 A in both phases, R20) for 2 h: the network's exact
  // solution is composed step by step, so steps of 2 h, 10 s, 0.1 s and 10 ms land on the closed
  // form to round-off: asserted to 1e-9 of the rise at every sample (the composition of 720 000
  // steps accumulates about 1e-12).
  const ThermalParams p = Qsh4218_41();
  const ThermalNetwork network(p);
  const double power = 9.0;        // W
  const double duration = 7200.0;  // s
  for (double h : {7200.0, 10.0, 0.1, 0.01}) {
    std::array<double, 2> rise = {0, 0};
    const long n = std::lround(duration / h);
    double worst = 0;
    for (long k = 1; k <= n; ++k) {
      rise = network.Step(rise, power, h);
      if (k % std::max(1L, n / 50) == 0 || k == n) {
        const double expected = WindingRiseClosedForm(p, power, k * h);
        worst = std::max(worst, std::abs(rise[0] - expected) / expected);
      }
    }
    std::printf("h = %g s: winding rise %.9f K after 2 h (closed form %.9f K), worst %.2e\n", h,
                rise[0], WindingRiseClosedForm(p, power, duration), worst);
    EXPECT_LT(worst, 1e-9) << "h = " << h;
  }
  // The time constants: a fast one (the winding against its housing) and a slow one (the whole
  // motor against the air), about C·R of each.
  const auto tau = network.TimeConstants();
  std::printf("time constants %.1f s, %.1f s\n", tau[0], tau[1]);
  EXPECT_LT(tau[0], 20.0);
  EXPECT_GT(tau[1], 1000.0);
  // Steady state: a step far longer than the slow time constant lands on P·(R_wh + R_ha), P·R_ha.
  const auto steady = network.Step({0, 0}, power, 1e6);
  EXPECT_NEAR(steady[0], power * (p.resistance_winding + p.resistance_housing), 1e-9 * steady[0]);
  EXPECT_NEAR(steady[1], power * p.resistance_housing, 1e-9 * steady[1]);
}

TEST(ThermalNetwork, TinyHousingCapacityIsTheFirstOrderResponse) {
  // C_h → 0 (1e-12 of C_w): the housing follows the winding at once and the winding is first
  // order, θw = P·R·(1 − e^{−t/τ}), R = R_wh + R_ha, τ = C_w·R. The two-node terms left are of
  // order C_h/C_w = 1e-12; and the stiff network (time constants 1e-12 apart) must not spoil the
  // slow rate, which the code takes from det A rather than from the solver: asserted to 1e-9.
  ThermalParams p = Qsh4218_41();
  p.capacity_housing = 1e-12 * p.capacity_winding;
  const ThermalNetwork network(p);
  const double power = 9.0, r = p.resistance_winding + p.resistance_housing;
  const double tau = p.capacity_winding * r;  // s
  std::array<double, 2> rise = {0, 0};
  const double h = 0.5;
  for (int k = 1; k <= 2000; ++k) {
    rise = network.Step(rise, power, h);
    const double expected = power * r * -std::expm1(-k * h / tau);
    ASSERT_NEAR(rise[0], expected, 1e-9 * expected) << "t = " << k * h;
    ASSERT_NEAR(rise[1], expected * p.resistance_housing / r, 1e-9 * expected);
  }
}

TEST(ThermalNetwork, RejectsNonPositiveConstants) {
  ThermalParams p = Qsh4218_41();
  p.capacity_housing = 0;
  EXPECT_THROW(ThermalNetwork{p}, std::invalid_argument);
  p = Qsh4218_41();
  p.resistance_winding = std::nan("");
  EXPECT_THROW(ThermalNetwork{p}, std::invalid_argument);
}

// The time at which a node's rise reaches 1 − 1/e of its final value under a held power, s
// (bisection on the closed-form network).
double TimeToOneOverE(const ThermalNetwork& network, int node, double power) {
  const double target = -std::expm1(-1.0) * network.SteadyRise(power)[node];
  double lo = 0, hi = 1e5;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (network.Step({0, 0}, power, mid)[node] < target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

TEST(CatalogueHeat, NetworksReproduceTheirSheets) {
  // Each catalogue preset's network, rounded to 3 digits in presets.cc, against what it was
  // fitted to (ThermalSheet): the winding's and the housing's time to 1 − 1/e of their rise (the
  // sheets' "thermal time constants"), to 0.5 % (the rounding moves them by up to 0.3 %); the
  // winding's steady rise at the rated current, both phases on, R(T) included, ambient 25 °C, to
  // 0.5 K; C_w from the copper estimate.
  int count = 0;
  for (const std::string& name : PresetNames()) {
    const Preset preset = *FindPreset(name);
    ASSERT_EQ(preset.thermal.has_value(), preset.datasheet.has_value()) << name;
    if (!preset.thermal) continue;
    ++count;
    const ThermalSheet& sheet = *preset.thermal_sheet;
    const ThermalNetwork network(*preset.thermal);
    const double power = 1.0;  // W: the times do not depend on it
    const double t_w = TimeToOneOverE(network, 0, power), t_h = TimeToOneOverE(network, 1, power);
    // Rated current I in both phases: P = 2·I²·R20·(1 + α·(T_w − 20)), θw = P·(R_wh + R_ha).
    const double alpha = HeatParams{}.resistance_coefficient;
    const double r_th = preset.thermal->resistance_winding + preset.thermal->resistance_housing;
    const double p20 = 2 * std::pow(preset.motor.rated_current, 2) * preset.motor.resistance;
    const double rise = r_th * p20 * (1 + alpha * (25 - 20)) / (1 - r_th * p20 * alpha);
    std::printf(
        "%-14s R_wh %.3g R_ha %.3g K/W, C_w %.3g C_h %.3g J/K: winding %.2f min (sheet %.0f), "
        "housing %.2f min (sheet %.0f), rated rise %.2f K (sheet %.0f)\n",
        name.c_str(), preset.thermal->resistance_winding, preset.thermal->resistance_housing,
        preset.thermal->capacity_winding, preset.thermal->capacity_housing, t_w / 60,
        sheet.winding_time_constant / 60, t_h / 60, sheet.surface_time_constant / 60, rise,
        sheet.rated_rise);
    EXPECT_NEAR(t_w, sheet.winding_time_constant, 0.005 * sheet.winding_time_constant) << name;
    EXPECT_NEAR(t_h, sheet.surface_time_constant, 0.005 * sheet.surface_time_constant) << name;
    EXPECT_NEAR(rise, sheet.rated_rise, 0.5) << name;
    EXPECT_NEAR(preset.thermal->capacity_winding, sheet.copper_fraction * sheet.mass * 385,
                0.005 * preset.thermal->capacity_winding)
        << name;
    EXPECT_GT(std::string(sheet.source).size(), 20u) << name;
  }
  EXPECT_EQ(count, 10);
}

// A chopper drive on a catalogue motor as a user gets it with drive = chopper (run_current = the
// rated current, 16 microsteps, 30 µs off-time, auto decay), input = steps.
DriveConfig ChopperOn(const std::string& motor, double bus_voltage) {
  DriveConfig c;
  const Preset preset = *FindPreset(motor);
  c.motor = preset.motor;
  const DriveConstants k{.rotor_teeth = c.motor.rotor_teeth,
                         .resistance = c.motor.resistance,
                         .inductance = c.motor.inductance,
                         .torque_constant = c.motor.torque_constant,
                         .isr_period = c.isr_period};
  c.controller =
      MakeController("chopper", AttributeSource([](const char*) { return ""; }), c.motor, k);
  c.input = InputMode::kSteps;
  c.bus_voltage = bus_voltage;
  c.isr_period = 50e-6;
  c.compute_delay = 0;
  c.encoder_counts = 0;
  c.heat = HeatParams{.network = *preset.thermal};
  return c;
}

TEST(Heat, HeldRotorFollowsTheFirstOrderResponse) {
  // The qsh4218_41 held at the full-step position (count 8 of 16 microsteps: both phases at the
  // rated 1 A) by the chopper at 24 V, 50 µs steps. Its capacities are scaled so that the rise
  // takes seconds: C_w × 1e-2 (0.129 J/K) and C_h × 1e-8 (the housing massless), a first-order
  // network, τ = C_w·(R_wh + R_ha) = 0.86 s.
  //  (a) α = 0: the copper power P is constant but for the chopper's ripple (at 20-40 kHz, which
  //      the network averages), so T_w = T_a + P·R·(1 − e^{−t/τ}) with P the run's mean copper
  //      power; asserted to 5e-5 of the rise at every 50 ms (measured: 5e-6, the ripple's
  //      residue; the massless housing's own term is 1e-8).
  //  (b) α = 0.00393: the chopper holds the current, so P = P_a·(1 + α'·θw) grows with the rise
  //      (P_a the power at ambient, α' = α/(1 + α·(T_a − 20))): still first order, with rate
  //      1/τ' = 1/τ − α'·P_a/C_w and final rise P_a·τ'/C_w. The drive holds R at each step's
  //      starting temperature (an error of h/τ' ≈ 6e-5 of the rise) and the chopper's mean current
  //      moves a little with R (its off-time decay rate is R/L): asserted to 2e-3.
  for (double alpha : {0.0, 0.00393}) {
    DriveConfig c = ChopperOn("qsh4218_41", 24.0);
    c.heat->network.capacity_winding *= 1e-2;
    c.heat->network.capacity_housing *= 1e-8;
    c.heat->resistance_coefficient = alpha;
    c.heat->ambient_temperature = c.heat->initial_temperature = 25.0;
    const Drive drive(c);
    const ThermalParams& net = c.heat->network;
    const double r_th = net.resistance_winding + net.resistance_housing;  // K/W
    const double tau = net.capacity_winding * r_th;                       // s
    const double count = 8;  // microsteps: the full-step position
    const double theta = count * drive.StepAngle();
    DriveState s = drive.Rest(0.0, theta, count);
    const double h = 50e-6;
    std::vector<std::pair<double, double>> samples;  // (t, T_w)
    const long n = std::lround(4.0 / h);
    for (long k = 0; k < n; ++k) {
      ASSERT_EQ(drive.Advance(&s, k * h, (k + 1) * h, theta, count), AdvanceStatus::kOk);
      if ((k + 1) % 1000 == 0) samples.emplace_back((k + 1) * h, s.winding_temperature);
    }
    const double duration = n * h;
    double worst = 0, final_rise = 0;
    if (alpha == 0) {
      const double power = s.energy_copper / duration;  // W, the run's mean
      final_rise = power * r_th;
      for (const auto& [t, temperature] : samples) {
        worst = std::max(worst, std::abs(temperature - 25.0 - final_rise * -std::expm1(-t / tau)));
      }
      std::printf(
          "α = 0: mean copper power %.5f W, T_w %.4f °C after %.0f s (closed form "
          "%.4f °C), worst %.2e of the rise\n",
          power, s.winding_temperature, duration, 25 + final_rise * -std::expm1(-4 / tau),
          worst / final_rise);
      // ≈ 2·I²·R = 9 W (1 A, 4.5 Ω), less the chopper's mean-current deficit (half its ripple).
      EXPECT_NEAR(power, 9.0, 0.04 * 9.0);
      EXPECT_LT(worst, 5e-5 * final_rise);
    } else {
      // P_a from the run itself: P/R(T) is the mean i² (constant), so P_a = (P/R)·R(T_a), from
      // the copper energy over ∫R(T_w) dt, with R(T_w(t)) of the samples (trapezoids over 50 ms,
      // a 1e-4 quadrature error on a smooth curve).
      const double r20 = 4.5;
      auto r_at = [&](double temperature) { return r20 * (1 + alpha * (temperature - 20)); };
      double r_integral = 0, t_prev = 0, r_prev = r_at(25.0);
      for (const auto& [t, temperature] : samples) {
        r_integral += 0.5 * (r_prev + r_at(temperature)) * (t - t_prev);
        t_prev = t;
        r_prev = r_at(temperature);
      }
      const double i2 = s.energy_copper / r_integral;  // A², mean ia² + ib²
      const double p_a = i2 * r_at(25.0);              // W
      const double alpha_a = alpha / (1 + alpha * 5);  // 1/K, per K above ambient
      const double rate = 1 / tau - alpha_a * p_a / net.capacity_winding;  // 1/s
      final_rise = p_a / (net.capacity_winding * rate);
      for (const auto& [t, temperature] : samples) {
        worst = std::max(worst, std::abs(temperature - 25.0 - final_rise * -std::expm1(-rate * t)));
      }
      std::printf(
          "α = %.5f: i² %.5f A², P at ambient %.4f W, τ' %.4f s (τ %.4f s), T_w %.4f °C "
          "(closed form %.4f °C), worst %.2e of the rise\n",
          alpha, i2, p_a, 1 / rate, tau, s.winding_temperature,
          25 + final_rise * -std::expm1(-rate * duration), worst / final_rise);
      EXPECT_LT(worst, 2e-3 * final_rise);
    }
    EXPECT_GT(s.winding_temperature, 25 + 0.9 * final_rise);  // it did rise, most of the way
  }
}

// The mean electromagnetic torque (N·m) of the drive on a rotor turned at ω (rad/s) with the
// command δ (electrical rad) ahead of it, over whole electrical cycles after 10 ms of settling;
// the winding held at its initial temperature (capacities so large it cannot move).
double MeanTorque(const Drive& drive, double omega, double delta) {
  const double step = drive.StepAngle();  // rad per microstep
  const int nr = drive.config().motor.rotor_teeth;
  const double h = drive.config().isr_period;
  auto count_at = [&](double t) { return std::round((omega * t + delta / nr) / step); };
  DriveState s = drive.Rest(0.0, 0.0, count_at(0));
  const double cycle = kTwoPi / (nr * omega);  // s, one electrical cycle
  const long settle = std::lround(10e-3 / h);
  const long measure = std::lround(std::ceil(4e-3 / cycle) * cycle / h);
  double sum = 0;
  for (long k = 0; k < settle + measure; ++k) {
    const double t1 = (k + 1) * h;
    drive.Advance(&s, k * h, t1, omega * t1, count_at(t1));
    if (k >= settle) sum += drive.Signals(s, omega * t1).torque_em;
  }
  return sum / measure;
}

// The largest mean torque over δ at speed ω: golden-section search over δ in [π/3, π] (the peak
// lies at 90° plus the current's lag, atan(Nr·ω·L/R) < 90°), to 0.01 rad.
double PullOutTorque(const Drive& drive, double omega) {
  const double phi = (std::sqrt(5.0) - 1) / 2;
  double a = std::numbers::pi / 3, b = std::numbers::pi;
  double x1 = b - phi * (b - a), x2 = a + phi * (b - a);
  double f1 = MeanTorque(drive, omega, x1), f2 = MeanTorque(drive, omega, x2);
  while (b - a > 0.01) {
    if (f1 > f2) {
      b = x2, x2 = x1, f2 = f1;
      x1 = b - phi * (b - a), f1 = MeanTorque(drive, omega, x1);
    } else {
      a = x1, x1 = x2, f1 = f2;
      x2 = a + phi * (b - a), f2 = MeanTorque(drive, omega, x2);
    }
  }
  return std::max(f1, f2);
}

// The speed (rad/s) at which the pull-out torque falls to `load` (N·m), by bisection in
// [lo, hi], to 0.2 %.
double TopSpeed(const Drive& drive, double load, double lo, double hi) {
  while (hi - lo > 0.002 * lo) {
    const double mid = 0.5 * (lo + hi);
    (PullOutTorque(drive, mid) > load ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// The same from the fundamental of a saturated chopper: each phase a ±Vbus square wave, whose
// fundamental V1 = 4·Vbus/π leads the rotor by δ; its current through Z = R + jNr·ω·L against the
// back-EMF gives the mean torque Km·(V1·sin(δ − φ)/|Z| − Km·ω·R/|Z|²), largest
//   τmax(ω) = Km·(V1/|Z| − Km·ω·R/|Z|²).
double ClosedFormTopSpeed(double r, double l, double km, int nr, double bus, double load) {
  const double v1 = 4 * bus / std::numbers::pi;
  auto torque = [&](double omega) {
    const double z2 = r * r + std::pow(nr * omega * l, 2);
    return km * (v1 / std::sqrt(z2) - km * omega * r / z2);
  };
  double lo = 1, hi = 1e4;
  while (hi - lo > 1e-9 * lo) {
    const double mid = 0.5 * (lo + hi);
    (torque(mid) > load ? lo : hi) = mid;
  }
  return lo;
}

TEST(Heat, HotWindingLowersTheChopperTopSpeed) {
  // The qsh4218_41 on the chopper at 12 V, loaded with half its holding torque (0.175 N·m): the
  // top speed is where the pull-out torque (the largest mean torque over the load angle, the
  // rotor turned at constant speed) falls to the load. At 20 °C and at 120 °C, the winding held
  // there (capacities × 1e9). At that speed the bridges are saturated: the current is set by
  // V1/|Z| less the back-EMF's, and the hot R (× 1.393) both lowers the current and damps it
  // more, so the top speed falls; the saturated closed form (ClosedFormTopSpeed) gives −11.9 %
  // with Km held (β = 0) and −19.5 % with Km(T) too.
  //   Asserted: the simulated hot/cold ratio within 2 points of the closed form's in each case
  // (the closed form keeps only the square waves' fundamental, and the chopper still regulates
  // in part of each cycle near the top speed), and the hot top speed lower by at least 8 % (R
  // alone) and 15 % (R and Km).
  const double load = 0.5 * 0.35;  // N·m, half the holding torque
  const Preset preset = *FindPreset("qsh4218_41");
  const MotorParams& m = preset.motor;
  for (double beta : {0.0, -0.0011}) {
    double top[2], closed[2];
    const double temperatures[2] = {20.0, 120.0};
    for (int i = 0; i < 2; ++i) {
      DriveConfig c = ChopperOn("qsh4218_41", 12.0);
      c.isr_period = 20e-6;
      c.heat->network.capacity_winding *= 1e9;
      c.heat->network.capacity_housing *= 1e9;
      c.heat->initial_temperature = temperatures[i];
      c.heat->torque_constant_coefficient = beta;
      const Drive drive(c);
      top[i] = TopSpeed(drive, load, RpmToRadPerSec(200), RpmToRadPerSec(800));
      // R(T) and Km(T) from SPEC §8's laws here, not from the drive.
      const double rise = temperatures[i] - 20;  // K above the datasheet's 20 °C
      closed[i] =
          ClosedFormTopSpeed(m.resistance * (1 + 0.00393 * rise), m.inductance,
                             m.torque_constant * (1 + beta * rise), m.rotor_teeth, 12.0, load);
    }
    const double ratio = top[1] / top[0], closed_ratio = closed[1] / closed[0];
    std::printf(
        "β = %g: top speed at 20 °C %.1f r/min, at 120 °C %.1f r/min (%+.2f %%); closed form "
        "%.1f, %.1f r/min (%+.2f %%)\n",
        beta, top[0] * 60 / kTwoPi, top[1] * 60 / kTwoPi, 100 * (ratio - 1),
        closed[0] * 60 / kTwoPi, closed[1] * 60 / kTwoPi, 100 * (closed_ratio - 1));
    EXPECT_NEAR(ratio, closed_ratio, 0.02) << "β = " << beta;
    EXPECT_LT(ratio, beta == 0 ? 0.92 : 0.85) << "β = " << beta;
  }
}

TEST(Heat, PowerBalanceHoldsWhileTheWindingWarms) {
  // S-8 over a run in which R and Km change every step: the qsh4218_41 on the chopper turned at
  // 300 r/min against the command (δ = 100° electrical), capacities × 1e-3 so that the winding
  // warms by tens of kelvin in 0.5 s. Each step's intervals are exact with that step's R and Km,
  // and L·|i|²/2 does not depend on R: E_in = E_cu + ΔL·|i|²/2 + E_mech to round-off, asserted
  // to 1e-9 of E_in; and the heat the network received is the copper energy: the winding and
  // housing's stored heat plus what left through R_ha, C_w·θw + C_h·θh + ∫θh/R_ha dt, to 1e-6
  // (the last integral by the trapezoid rule over 50 µs steps).
  DriveConfig c = ChopperOn("qsh4218_41", 24.0);
  c.heat->network.capacity_winding *= 1e-3;
  c.heat->network.capacity_housing *= 1e-3;
  const Drive drive(c);
  const ThermalParams& net = c.heat->network;
  const double omega = RpmToRadPerSec(300), delta = 100 * std::numbers::pi / 180;
  auto count_at = [&](double t) {
    return std::round((omega * t + delta / 50) / drive.StepAngle());
  };
  DriveState s = drive.Rest(0.0, 0.0, count_at(0));
  const PhaseVector i0 = s.current();
  const double h = 50e-6, ambient = c.heat->ambient_temperature;
  double leaving = 0;  // J, ∫θh/R_ha dt
  for (long k = 0; k < 10000; ++k) {
    const double before = s.housing_temperature - ambient;
    const double t1 = (k + 1) * h;
    ASSERT_EQ(drive.Advance(&s, k * h, t1, omega * t1, count_at(t1)), AdvanceStatus::kOk);
    leaving += 0.5 * (before + s.housing_temperature - ambient) / net.resistance_housing * h;
  }
  const double stored = 0.5 * 7.5e-3 * (std::norm(s.current()) - std::norm(i0));
  const double mismatch = s.energy_input - s.energy_copper - stored - s.energy_mechanical;
  const double heat = net.capacity_winding * (s.winding_temperature - ambient) +
                      net.capacity_housing * (s.housing_temperature - ambient) + leaving;
  std::printf("T_w %.2f °C, R %.4f Ω; E_in %.6f J, mismatch %.2e J; copper %.6f J, heat %.6f J\n",
              s.winding_temperature, drive.ResistanceAt(s.winding_temperature), s.energy_input,
              mismatch, s.energy_copper, heat);
  EXPECT_GT(s.winding_temperature, ambient + 10);        // R rose by 4 % or more along the way
  EXPECT_GT(s.energy_mechanical, 0.1 * s.energy_input);  // a motor, not a heater only
  EXPECT_LT(std::abs(mismatch), 1e-9 * s.energy_input);
  EXPECT_NEAR(heat, s.energy_copper, 1e-6 * s.energy_copper);
}

TEST(Heat, ZeroCoefficientsChangeNothingButTheTemperatures) {
  // With α = β = 0 the hot constants equal the cold ones bit for bit, so a drive with heat runs
  // exactly as one without (the no-heat path is the one the paper tests use), and only the two
  // temperatures differ.
  DriveConfig with = ChopperOn("qsh4218_41", 24.0);
  with.heat->resistance_coefficient = 0;
  with.heat->torque_constant_coefficient = 0;
  DriveConfig without = with;
  without.heat.reset();
  const Drive hot(with), cold(without);
  const double omega = RpmToRadPerSec(200);
  auto count_at = [&](double t) { return std::round(omega * t / hot.StepAngle()); };
  DriveState a = hot.Rest(0.0, 0.0, 0.0), b = cold.Rest(0.0, 0.0, 0.0);
  for (long k = 0; k < 2000; ++k) {
    const double t1 = (k + 1) * 50e-6;
    hot.Advance(&a, k * 50e-6, t1, 0.9 * omega * t1, count_at(t1));
    cold.Advance(&b, k * 50e-6, t1, 0.9 * omega * t1, count_at(t1));
  }
  EXPECT_GT(a.winding_temperature, 25.0);
  EXPECT_EQ(b.winding_temperature, kReferenceTemperature);
  a.winding_temperature = b.winding_temperature;
  a.housing_temperature = b.housing_temperature;
  EXPECT_EQ(std::memcmp(static_cast<const void*>(static_cast<const DriveCoreState*>(&a)),
                        static_cast<const void*>(static_cast<const DriveCoreState*>(&b)),
                        sizeof(DriveCoreState)),
            0);
  std::vector<double> stored_a(hot.layout().total()), stored_b(cold.layout().total());
  hot.Store(a, stored_a.data());
  cold.Store(b, stored_b.data());
  EXPECT_EQ(hot.StoredTorque(stored_a.data(), 0.1), cold.StoredTorque(stored_b.data(), 0.1));
}

TEST(Heat, RestStartsAtTheInitialTemperatureAndARestartKeepsTheHeat) {
  DriveConfig c = ChopperOn("qsh4218_41", 24.0);
  c.heat->initial_temperature = 80.0;
  const Drive drive(c);
  DriveState s = drive.Rest(0.0, 0.0, 0.0);
  EXPECT_EQ(s.winding_temperature, 80.0);
  EXPECT_EQ(s.housing_temperature, 80.0);
  const DriveSignals signals = drive.Signals(s, 0.0);
  EXPECT_DOUBLE_EQ(signals.winding_temperature, 80.0);
  EXPECT_DOUBLE_EQ(signals.resistance, 4.5 * (1 + 0.00393 * 60));
  EXPECT_DOUBLE_EQ(drive.TorqueConstantAt(80.0), 0.35 / std::sqrt(2.0) * (1 - 0.0011 * 60));
  // The stored torque uses Km at the stored winding temperature.
  std::vector<double> stored(drive.layout().total());
  drive.Store(s, stored.data());
  EXPECT_DOUBLE_EQ(drive.StoredTorque(stored.data(), -0.01), drive.Torque(s, -0.01));
  // A step too long to run (kEventBound) restarts the drive at rest but keeps its heat, as it
  // keeps its energies; a state that is not finite restarts it cold.
  s.winding_temperature = 95.0;
  s.housing_temperature = 60.0;
  EXPECT_EQ(drive.Advance(&s, 0.0, 10.0, 0.0, 0.0), AdvanceStatus::kEventBound);
  EXPECT_EQ(s.winding_temperature, 95.0);
  EXPECT_EQ(s.housing_temperature, 60.0);
  s.housing_temperature = std::nan("");
  EXPECT_EQ(drive.Advance(&s, 10.0, 10.0 + 50e-6, 0.0, 0.0), AdvanceStatus::kBadState);
  EXPECT_EQ(s.winding_temperature, 80.0);
  EXPECT_EQ(s.housing_temperature, 80.0);
}

TEST(Heat, ConfigChecks) {
  DriveConfig c = ChopperOn("qsh4218_41", 24.0);
  c.heat->ambient_temperature = 200;  // beyond [−50, 150]
  EXPECT_THROW(Drive{c}, std::invalid_argument);
  c = ChopperOn("qsh4218_41", 24.0);
  c.heat->network.capacity_winding = -1;
  EXPECT_THROW(Drive{c}, std::invalid_argument);
  c = ChopperOn("qsh4218_41", 24.0);
  c.solver = WindingSolver::kRk4;  // no energies, so no copper loss
  EXPECT_THROW(Drive{c}, std::invalid_argument);
}

// A duty cycle's heat carried over many cycles (mjstepper size): with R(T) the steady winding
// temperature is the fixed point θw = (R_wh + R_ha)·R20·(1 + α·(T_a + θw − 20))·i², the closed
// form of SteadyWindingTemperature, which RiseUnderCurrent reaches after many time constants.
TEST(ThermalNetwork, CurrentHeldForEverReachesTheSteadyTemperatureWithRofT) {
  HeatParams heat;
  heat.network = {.resistance_winding = 0.648,
                  .resistance_housing = 4.71,
                  .capacity_winding = 18.5,
                  .capacity_housing = 298};  // 17hs19_2004s1's
  heat.ambient_temperature = 25;
  const double r20 = 1.4, current_squared = 8.0;  // Ω, A²: √2·2 A in both phases
  const ThermalNetwork network(heat.network);
  const double steady = SteadyWindingTemperature(heat, r20, current_squared);
  // k = 5.358·1.4·8 = 60.0 K; θw = 60.0·(1 + 0.00393·5)/(1 − 60.0·0.00393) = 80.1 K.
  EXPECT_NEAR(steady, 25 + 60.0096 * (1 + 0.00393 * 5) / (1 - 60.0096 * 0.00393), 1e-9);
  const auto rise = RiseUnderCurrent(network, heat, r20, current_squared, {0, 0}, 20 * 3600, 20000);
  EXPECT_NEAR(heat.ambient_temperature + rise[0], steady, 0.01);
  // Without R(T) it would settle 18 K lower: the law matters.
  EXPECT_GT(steady - (25 + 60.0096), 15);
  heat.resistance_coefficient = 1.01 / 60.0096;  // k·α > 1: the loss outgrows the network
  EXPECT_TRUE(std::isinf(SteadyWindingTemperature(heat, r20, current_squared)));
}

}  // namespace
}  // namespace mjstepper
