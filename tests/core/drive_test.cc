// The multi-rate drive (drive.h): interrupt clock, delay and hold, bridges, controllers, and the
// paper targets that need only the electrical side: H6, H8, H14's loop on a prescribed rotor.
#include "core/drive.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <numbers>
#include <vector>

#include "core/analysis.h"
#include "core/presets.h"
#include "core/signals.h"
#include "core/units.h"

namespace mjstepper {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

// The drives these tests were written for: voltage microstepping at 24 V (the K(5) amplitude of
// Kim's open-loop example), Tsui's PI loop and servo with their SPEC §3 defaults.
const Controller kVoltage = VoltageMicrostep{.voltage_amplitude = 24.0};
const Controller kCurrent = CurrentMicrostep{};
const Controller kServo = Servo{};
const Controller kIdeal = IdealCurrent{};

DriveConfig TsuiConfig(const Controller& controller, InputMode input) {
  DriveConfig c;
  c.motor = FindPreset("tsui2009")->motor;
  c.controller = controller;
  c.input = input;
  return c;
}

// The PI integrator of a current_microstep drive's state (controller state).
CurrentMicrostep::State PiState(const DriveState& s) {
  CurrentMicrostep::State pi;
  std::memcpy(static_cast<void*>(&pi), s.unit.data(), sizeof(pi));
  return pi;
}

// Runs a drive on a prescribed rotor path θ(t) with the command cmd(t) held over each step of
// length h, as a simulator would; calls `observe` after each step with the state at its end.
void RunPrescribed(const Drive& drive, DriveState* s, double t_end, double h,
                   const std::function<double(double)>& theta,
                   const std::function<double(double)>& command,
                   const std::function<void(double, const DriveState&)>& observe = {}) {
  const long n = std::lround(t_end / h);
  for (long k = 0; k < n; ++k) {
    const double t0 = k * h, t1 = (k + 1) * h;
    drive.Advance(s, t0, t1, theta(t1), command(t0));
    if (observe) observe(t1, *s);
  }
}

// At rest on the command (SPEC §6) nothing moves: no transient in currents, voltages, integrator.
TEST(Drive, RestStateHasNoTransient) {
  for (const Controller& kind : {kVoltage, kCurrent}) {
    const Drive drive(TsuiConfig(kind, InputMode::kPosition));
    const double theta = 0.004;  // rad, anywhere
    DriveState s = drive.Rest(0.0, theta, theta);
    const DriveState start = s;
    RunPrescribed(
        drive, &s, 0.01, 5e-5, [&](double) { return theta; }, [&](double) { return theta; });
    // Round-off of 200 intervals on currents of order 1 A.
    EXPECT_NEAR(s.current_a, start.current_a, 1e-12);
    EXPECT_NEAR(s.current_b, start.current_b, 1e-12);
    EXPECT_NEAR(PiState(s).integral_d, PiState(start).integral_d, 1e-12);
  }
}

// Open-loop voltage microstepping, K(5): after a command step the current settles, at the motor's
// own rate R/L, to Vmax/R along the new commanded electrical angle. 50 ms = 20 time constants:
// the transient left is e^-20 = 2e-9 of the step.
TEST(Drive, VoltageMicrostepSettlesToVmaxOverR) {
  DriveConfig c = TsuiConfig(VoltageMicrostep{.voltage_amplitude = 1.71},  // V: Vmax/R = 1.9 A
                             InputMode::kPosition);
  const Drive drive(c);
  DriveState s = drive.Rest(0.0, 0.0, 0.0);
  const double theta_cmd = 0.01;  // rad, half an electrical turn
  RunPrescribed(
      drive, &s, 0.05, 5e-5, [](double) { return 0.0; }, [&](double) { return theta_cmd; });
  const PhaseVector expected = 1.71 / 0.9 * UnitPhasor(50 * theta_cmd);
  EXPECT_NEAR(std::abs(s.current() - expected), 0.0, 1e-7);
}

// The PI loop of T(9)-(12) at rest settles to id = I_hold, iq = 0 in the commanded frame after a
// command step. Its slow pole is Ki/(Kp + R)·20 kHz ≈ 24 rad/s: after 0.5 s (12 time constants)
// the error left is about 1e-5 of the 1.9 A step; the bound 1e-3 A leaves margin.
TEST(Drive, CurrentLoopSettlesToHoldCurrent) {
  const Drive drive(TsuiConfig(kCurrent, InputMode::kPosition));
  DriveState s = drive.Rest(0.0, 0.0, 0.0);
  const double theta_cmd = 0.0123;
  RunPrescribed(
      drive, &s, 0.5, 5e-5, [](double) { return 0.0; }, [&](double) { return theta_cmd; });
  const DriveSignals sig = drive.Signals(s, 0.0);
  EXPECT_NEAR(sig.current_d, 1.9, 1e-3);
  EXPECT_NEAR(sig.current_q, 0.0, 1e-3);
}

// S-15: the interrupt samples at t_k = k·T and the new voltage applies at t_k + D. A command step
// taken in the step that starts at 1.000 ms is sampled by the tick at 1.000 ms; the new voltage
// applies from 1.025 ms (D = 25 µs). Events are taken on [t0, t1): the state at 1.025 ms is the
// one just before the switch; from the step after it the new voltage is held. 5 µs steps.
TEST(Drive, VoltageAppliesAfterComputeDelayAndHolds) {
  const Drive drive(TsuiConfig(kVoltage, InputMode::kPosition));
  DriveState s = drive.Rest(0.0, 0.0, 0.0);
  const double jump = 0.005;                  // rad: electrical angle 0.25 rad
  std::vector<std::pair<double, double>> vb;  // (t, vb)
  RunPrescribed(
      drive, &s, 1.2e-3, 5e-6, [](double) { return 0.0; },
      [&](double t) { return t >= 1e-3 - 1e-12 ? jump : 0.0; },
      [&](double t, const DriveState& st) { vb.emplace_back(t, st.voltage_b); });
  const double v_new = 24.0 * std::sin(50 * jump);
  for (const auto& [t, v] : vb) {
    if (t < 1.025e-3 + 1e-9) {
      EXPECT_EQ(v, 0.0) << "at t = " << t;
    } else {
      EXPECT_NEAR(v, v_new, 1e-12) << "at t = " << t;
    }
  }
}

// The interrupt clock is independent of the simulator's step: with the rotor on the same linear
// path, steps of 10 µs (5 per tick), 50 µs (one) and 130 µs (2.6 ticks per step) give the same
// currents at the common instants k·1.3 ms, to round-off (1e-10 A), for both drives.
TEST(Drive, TicksAreIndependentOfTheSimulationStep) {
  for (const Controller& kind : {kVoltage, kCurrent}) {
    const Drive drive(TsuiConfig(kind, InputMode::kVelocity));
    const double omega = RpmToRadPerSec(150);
    std::vector<std::vector<PhaseVector>> at_common(3);
    const double steps[3] = {10e-6, 50e-6, 130e-6};
    for (int r = 0; r < 3; ++r) {
      DriveState s = drive.Rest(0.0, -1e-3, omega);  // on the path θ(t) = ω·t − 1e-3 below
      const double h = steps[r];
      const long per_common = std::lround(1.3e-3 / h);
      long k = 0;
      RunPrescribed(
          drive, &s, 13e-3, h, [&](double t) { return omega * t - 1e-3; },
          [&](double) { return omega; },
          [&](double, const DriveState& st) {
            if (++k % per_common == 0) at_common[r].push_back(st.current());
          });
    }
    ASSERT_EQ(at_common[0].size(), 10u);
    for (int r = 1; r < 3; ++r) {
      ASSERT_EQ(at_common[r].size(), at_common[0].size());
      for (size_t i = 0; i < at_common[0].size(); ++i) {
        EXPECT_NEAR(std::abs(at_common[r][i] - at_common[0][i]), 0.0, 1e-10)
            << "step " << steps[r] << " s, instant " << i;
      }
    }
  }
}

// The interrupt clock stays on MuJoCo's accumulated step times however long the run, with the
// step equal to T or 50·T: it re-anchors at step starts, never accumulates round-off of its own,
// and counts exactly one tick per period. (The absolute grid k·T drifts from the accumulated time,
// by 1e-11 s after 10 s here.)
TEST(Drive, ClockStaysOnAccumulatedStepTimes) {
  for (const double ticks_per_step : {1.0, 50.0}) {
    DriveConfig c = TsuiConfig(kCurrent, InputMode::kVelocity);
    c.isr_period = 50e-6 / ticks_per_step;
    c.compute_delay = c.isr_period / 2;
    const Drive drive(c);
    const double h = 50e-6, omega = RpmToRadPerSec(60);
    const long steps = ticks_per_step == 1 ? 200000 : 20000;
    DriveState s = drive.Rest(0.0, 0.0, omega);
    double t = 0;
    for (long k = 0; k < steps; ++k) {
      const double t1 = t + h;  // as mj_step: time += timestep
      drive.Advance(&s, t, t1, omega * t1, omega);
      t = t1;
    }
    EXPECT_EQ(Drive::NextTickIndex(s), steps * ticks_per_step);
    EXPECT_NEAR(drive.NextTickTime(s), t, 4 * std::numeric_limits<double>::epsilon() * t);
    if (ticks_per_step == 1) {
      EXPECT_EQ(drive.NextTickTime(s), t);                          // bit for bit
      EXPECT_GT(std::abs(Drive::NextTickIndex(s) * h - t), 1e-12);  // while k·T has drifted
    }
  }
}

// Time set back under a running drive (a user rewinding d->time without a reset): the clock
// restarts at the new time instead of waiting for its old tick.
TEST(Drive, ClockResynchronisesWhenTimeMovesBack) {
  const Drive drive(TsuiConfig(kCurrent, InputMode::kVelocity));
  const double h = drive.config().isr_period;
  DriveState s = drive.Rest(0.0, 0.0, 0.0);
  for (int k = 0; k < 200; ++k) drive.Advance(&s, k * h, (k + 1) * h, 0.0, 0.0);
  ASSERT_EQ(Drive::NextTickIndex(s), 200);
  drive.Advance(&s, 0.0, h, 0.0, 0.0);
  EXPECT_EQ(Drive::NextTickIndex(s), 1);  // the tick at t = 0 ran; the next is at h
  EXPECT_EQ(drive.NextTickTime(s), h);
}

// Issue 16: at t = 1e13 s a 20 kHz clock's tick index is past 2^53 (k + 1 == k: the event loop
// never ended) and times are 2^-9 s ≈ 2 ms apart, 39 periods. The drive now counts ticks from its
// anchor and works such a step in its own frame t − t0: over 0.1 s of steps 2^-9 s long (the
// spacing of times there, so every step time is exact), its currents and tick count equal those
// of the same run at t = 0. Tolerance 1e-12 A (they agree to 6e-15 A): both runs place the same
// ticks (offsets n·T from the same anchor; none within 1 % of T of a step boundary without being on
// it, as offsets fall on sixteenths of T) and differ only by the round-off of offsets taken from
// different origins, ~1e-19 s, and of the currents' arithmetic; one tick misplaced by the 2 ms
// spacing of absolute times, or a stalled clock, would miss it by ~0.1 A. Each Advance says the
// time is coarse.
TEST(Drive, TicksCorrectlyAtAHugeTime) {
  const Drive drive(TsuiConfig(kCurrent, InputMode::kVelocity));
  const double h = std::ldexp(1.0, -9);  // s: ulp(1e13)
  const double omega = RpmToRadPerSec(60);
  ASSERT_EQ(1e13 + h - 1e13, h);
  std::vector<PhaseVector> currents[2];
  double ticks[2] = {0, 0};
  for (int run = 0; run < 2; ++run) {
    const double start = run == 0 ? 0.0 : 1e13;
    DriveState s = drive.Rest(start, 0.0, omega);
    const double k0 = Drive::NextTickIndex(s);
    for (int k = 0; k < 51; ++k) {
      const double t0 = start + k * h, t1 = start + (k + 1) * h;
      const AdvanceStatus status = drive.Advance(&s, t0, t1, omega * (k + 1) * h, omega);
      EXPECT_EQ(status, run == 0 ? AdvanceStatus::kOk : AdvanceStatus::kCoarseTime) << k;
      currents[run].push_back(s.current());
    }
    ticks[run] = Drive::NextTickIndex(s) - k0;
  }
  EXPECT_EQ(ticks[0], 1993);  // ticks at 0, T, ..., 1992·T < 51·h = 1992.2·T
  EXPECT_EQ(ticks[1], ticks[0]);
  for (size_t i = 0; i < currents[0].size(); ++i) {
    EXPECT_NEAR(std::abs(currents[1][i] - currents[0][i]), 0.0, 1e-12) << "step " << i;
  }
}

// Issue 16: whatever the input, Advance returns, says what was wrong, and leaves the state finite:
// unchanged for a bad time or input, restarted at rest for a stored NaN or a step too long to run.
TEST(Drive, BadInputIsReportedAndStateStaysFinite) {
  const Drive drive(TsuiConfig(kCurrent, InputMode::kVelocity));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const double h = 50e-6;
  DriveState s = drive.Rest(0.0, 0.0, 1.0);
  for (int k = 0; k < 10; ++k) drive.Advance(&s, k * h, (k + 1) * h, 0.0, 1.0);
  const DriveState good = s;
  auto same = [&](const DriveState& a) {
    return std::memcmp(static_cast<const void*>(&a), static_cast<const void*>(&good),
                       sizeof(DriveCoreState)) == 0;
  };
  for (auto [t0, t1] : {std::pair{nan, 1.0}, {0.0, nan}, {-inf, 0.0}, {0.0, inf}, {1.0, 0.5}}) {
    EXPECT_EQ(drive.Advance(&s, t0, t1, 0.0, 1.0), AdvanceStatus::kBadTime) << t0 << " " << t1;
    EXPECT_TRUE(same(s));
  }
  for (auto [theta1, command] : {std::pair{nan, 1.0}, {0.0, inf}, {1e11, 1.0}, {0.0, -1e300}}) {
    EXPECT_EQ(drive.Advance(&s, 10 * h, 11 * h, theta1, command), AdvanceStatus::kBadInput);
    EXPECT_TRUE(same(s));
  }
  // A NaN in the stored state (a user's write, a corrupt file): restarted at rest.
  s.current_a = nan;
  EXPECT_EQ(drive.Advance(&s, 10 * h, 11 * h, 0.0, 1.0), AdvanceStatus::kBadState);
  EXPECT_TRUE(std::isfinite(s.current_a));
  // A step of 1e300 s, or of more than kMaxTicksPerAdvance periods: not run, restarted at rest.
  s = good;
  EXPECT_EQ(drive.Advance(&s, 10 * h, 1e300, 0.0, 1.0), AdvanceStatus::kEventBound);
  EXPECT_EQ(s.energy_input, good.energy_input);  // kept
  EXPECT_NEAR(drive.NextTickTime(s), 1e300, 1e284);
  s = good;
  EXPECT_EQ(drive.Advance(&s, 10 * h, (10 + kMaxTicksPerAdvance + 1) * h, 0.0, 1.0),
            AdvanceStatus::kEventBound);
  // ... and the energies it keeps are only finite ones (drive_fuzz found a stored −inf kept).
  s = good;
  s.energy_input = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(drive.Advance(&s, 0.0, 1e180, 0.0, 0.0), AdvanceStatus::kEventBound);
  EXPECT_TRUE(std::isfinite(s.energy_input));
  s = good;
  EXPECT_EQ(drive.Advance(&s, 10 * h, (10 + kMaxTicksPerAdvance - 1) * h, 0.0, 1.0),
            AdvanceStatus::kOk);
}

// S-13: each phase is clamped to ±Vbus, and the PI integrator holds while the bridges saturate
// (conditional integration), so it cannot wind up during a long saturation.
TEST(Drive, BridgesClampAndIntegratorDoesNotWindUp) {
  DriveConfig c = TsuiConfig(kCurrent, InputMode::kVelocity);
  c.bus_voltage = 12.0;  // V: 1200 r/min needs ~38 V of back-EMF alone
  for (PowerStageKind stage : {PowerStageKind::kTwoHBridges, PowerStageKind::kThreeLegSvpwm}) {
    c.power_stage = stage;
    const Drive drive(c);
    const double omega = RpmToRadPerSec(1200);
    DriveState s = drive.Rest(0.0, 0.0, omega);
    const double integral0 = std::hypot(PiState(s).integral_d, PiState(s).integral_q);
    double max_v = 0;
    RunPrescribed(
        drive, &s, 0.05, 5e-5, [&](double t) { return omega * t; }, [&](double) { return omega; },
        [&](double, const DriveState& st) {
          max_v = std::max({max_v, std::abs(st.voltage_a), std::abs(st.voltage_b)});
        });
    EXPECT_LE(max_v, 12.0 + 1e-12);  // SVPWM scaling by Vbus/span: round-off
    // It did saturate: the H-bridges reach ±Vbus per phase, SVPWM a span of Vbus (±Vbus/2 at 45°).
    EXPECT_GT(max_v, stage == PowerStageKind::kTwoHBridges ? 11.9 : 5.9);
    // Without anti-windup the integrator would grow by Ki·|e| ≈ 0.01 V per tick for 1000 ticks.
    EXPECT_LT(std::hypot(PiState(s).integral_d, PiState(s).integral_q), integral0 + 12.0);
  }
}

// H6: S-8 over a whole run — 0.2 s ramp of a lagging rotor to 1200 r/min with the PI loop and
// bridge saturation on the way. The energies are integrated in closed form per interval, so the
// mismatch is round-off; H6 asks < 1e-4 of the input energy, asserted with that bound.
TEST(Drive, H6_PowerBalanceOverARun) {
  for (const Controller& kind : {kVoltage, kCurrent, kServo}) {
    const Drive drive(TsuiConfig(kind, InputMode::kVelocity));
    DriveState s = drive.Rest(0.0, 0.0, 0.0);
    const PhaseVector i0 = s.current();
    const double accel = RpmToRadPerSec(1200) / 0.2;  // rad/s²
    auto theta = [&](double t) { return 0.5 * accel * t * t - 0.002 * std::sin(200 * t); };
    RunPrescribed(drive, &s, 0.2, 5e-5, theta, [&](double t) { return accel * (t + 2.5e-5); });
    const double stored = 0.5 * 2.2e-3 * (std::norm(s.current()) - std::norm(i0));
    const double mismatch = s.energy_input - s.energy_copper - stored - s.energy_mechanical;
    // The prescribed rotor may drive the motor as a generator (E_in < 0): scale by |E_in|.
    const double scale = std::abs(s.energy_input);
    ASSERT_GT(scale, 0.1);
    EXPECT_LT(std::abs(mismatch), 1e-4 * scale)
        << ControllerName(kind) << ": mismatch " << mismatch << " J";
    EXPECT_LT(std::abs(mismatch), 1e-9 * scale);  // what the closed form achieves
  }
}

// H8: currents against a reference that runs the same drive with RK4 at 1 µs instead of the exact
// solution, rotor at 1200 r/min, for each drive: error < 0.1 % of the 3 A rated current.
TEST(Drive, H8_CurrentsMatchRk4Reference) {
  for (const Controller& kind : {kVoltage, kCurrent, kServo}) {
    DriveConfig exact_config = TsuiConfig(kind, InputMode::kVelocity);
    DriveConfig reference_config = exact_config;
    reference_config.solver = WindingSolver::kRk4;
    reference_config.rk4_step = 1e-6;
    const Drive exact(exact_config), reference(reference_config);
    const double omega = RpmToRadPerSec(1200);
    DriveState a = exact.Rest(0.0, 0.0, omega), b = reference.Rest(0.0, 0.0, omega);
    auto theta = [&](double t) { return omega * t - 0.01 * (1 - std::exp(-t / 2e-3)); };
    double max_error = 0;
    const double h = 5e-5;
    for (int k = 0; k < 400; ++k) {  // 20 ms = 20 electrical periods
      exact.Advance(&a, k * h, (k + 1) * h, theta((k + 1) * h), omega);
      reference.Advance(&b, k * h, (k + 1) * h, theta((k + 1) * h), omega);
      max_error = std::max(max_error, std::abs(a.current() - b.current()));
    }
    EXPECT_LT(max_error, 1e-3 * 3.0) << ControllerName(kind);
    std::printf("H8: %s: max |i - i_rk4| = %.3g A\n", ControllerName(kind), max_error);
  }
}

// H14 on the electrical side: the PI loop at 240 r/min, open loop (ψ = Nr·θcmd), id* = 1.9 A, the
// rotor following the command with a constant lag. The phase-A current's fundamental (200 Hz) is
// 1.9 A ± 5 % and lags cos(Nr·θcmd) by less than 5°. The plugin test repeats this on MuJoCo.
TEST(Drive, H14_PiLoopFundamentalOnPrescribedRotor) {
  const Drive drive(TsuiConfig(kCurrent, InputMode::kVelocity));
  const double omega = RpmToRadPerSec(240);
  DriveState s = drive.Rest(0.0, 0.0, omega);
  std::vector<double> t, ia, reference;
  RunPrescribed(
      drive, &s, 0.6, 5e-5, [&](double tt) { return omega * tt - 0.002; },
      [&](double) { return omega; },
      [&](double tt, const DriveState& st) {
        if (tt < 0.5) return;
        t.push_back(tt);
        ia.push_back(st.current_a);
        reference.push_back(std::cos(50 * st.theta_cmd));
      });
  const Tone got = FitTone(t, ia, 200.0), want = FitTone(t, reference, 200.0);
  EXPECT_NEAR(got.amplitude, 1.9, 0.05 * 1.9);
  const double lag_deg = std::remainder(want.phase - got.phase, kTwoPi) * 180 / std::numbers::pi;
  EXPECT_LT(std::abs(lag_deg), 5.0) << "lag " << lag_deg << "°";
}

// The slip counter: a rotor dragged back three electrical cycles behind its command, then one
// forward, has lost 12 then 8 full steps, each counted once, at the step where δ passed 2π·k ±
// 5π/4; a start away from the command is where the rotor is, not a slip; a closed-loop drive
// reports its error as position_error and no lost steps.
TEST(Drive, LostStepsCountWholeElectricalCycles) {
  const double cycle = kTwoPi / 50;  // rad, one electrical cycle of the rotor
  {
    const Drive drive(TsuiConfig(kIdeal, InputMode::kPosition));
    DriveState s = drive.Rest(0.0, 0.0, 2 * cycle);  // the command two cycles ahead: no slip
    EXPECT_EQ(drive.Signals(s, 0.0).lost_steps, 0.0);
    // θ(t): back 3 cycles over 0.3 s, then forward 1 over 0.1 s (1 ms steps; δ moves 0.5 rad
    // per step at most, so each crossing is seen).
    auto theta = [&](double t) {
      return t < 0.3 ? -3 * cycle * t / 0.3 : -3 * cycle + cycle * (t - 0.3) / 0.1;
    };
    std::vector<double> lost;
    RunPrescribed(
        drive, &s, 0.4, 1e-3, theta, [&](double) { return 2 * cycle; },
        [&](double, const DriveState& st) {
          lost.push_back(drive.Signals(st, st.theta).lost_steps);
        });
    EXPECT_EQ(lost[299], 12.0);
    EXPECT_EQ(lost.back(), 8.0);
    // Each change is one cycle (4 full steps), never back and forth: 3 + 1 changes in all.
    int changes = 0;
    for (size_t k = 1; k < lost.size(); ++k) {
      if (lost[k] != lost[k - 1]) {
        ++changes;
        EXPECT_EQ(std::abs(lost[k] - lost[k - 1]), 4.0) << "step " << k;
      }
    }
    EXPECT_EQ(changes, 4);
    // The last slip: going forward, δ/2π falls from 5 and passes 5 − 5/8 (cell 5 to 4) when the
    // rotor has moved 5/8 of a cycle, 62.5 ms into the forward move (counted at that step's end).
    EXPECT_NEAR(drive.Signals(s, s.theta).last_slip_time, 0.3 + 0.0625, 1e-3 + 1e-12);
  }
  {
    const Drive drive(TsuiConfig(kServo, InputMode::kPosition));
    DriveState s = drive.Rest(0.0, 0.0, 0.0);
    drive.Advance(&s, 0.0, 5e-5, -3 * cycle, 0.0);  // whatever the servo does, θ is prescribed
    const DriveSignals out = drive.Signals(s, s.theta);
    EXPECT_EQ(out.lost_steps, 0.0);
    EXPECT_EQ(out.last_slip_time, -1.0);
    EXPECT_DOUBLE_EQ(out.position_error, -3 * cycle);
  }
}

// The slip counter in closed form: hysteresis of 5π/4 either way, any number of cycles in one
// call, and an absurd (1e12 rad: the cycle-by-cycle count took minutes) or non-finite load
// angle answered at once, the latter keeping the count.
TEST(Drive, SlipCellIsClosedFormAndKeepsItsCountOnNonFiniteAngles) {
  constexpr double kPi = std::numbers::pi;
  EXPECT_EQ(SlipCell(1.2 * kPi, 0), 0);    // inside the margin
  EXPECT_EQ(SlipCell(1.3 * kPi, 0), 1);    // past 5π/4: the next cycle
  EXPECT_EQ(SlipCell(0.8 * kPi, 1), 1);    // back within 5π/4 of 2π: stays
  EXPECT_EQ(SlipCell(-1.3 * kPi, 0), -1);  // and the other way
  EXPECT_EQ(SlipCell(2 * kPi * 7 + 0.1, 0), 7);
  EXPECT_EQ(SlipCell(2 * kPi * 1e11, 0), 1e11);
  EXPECT_EQ(SlipCell(std::nan(""), 3), 3);
  EXPECT_EQ(SlipCell(HUGE_VAL, 3), 3);
  EXPECT_EQ(SlipCell(-HUGE_VAL, 3), 3);
}

TEST(Drive, ValidateNamesFieldAndValue) {
  DriveConfig c = TsuiConfig(kCurrent, InputMode::kPosition);
  c.compute_delay = 60e-6;
  try {
    Drive d(c);
    FAIL() << "delay >= period accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("compute_delay"), HasSubstr("6e-05")));
  }
}

// Each controller states its own holding stiffness: T' = Nr·Km·I for the open-loop drives (T(1)),
// Kp for the servo, J·(k1 + k1p·k2) for Kim's (K(26)), none in identification.
TEST(Drive, HoldingStiffnessIsEachControllersOwn) {
  const double nr_km = 50 * 0.3;  // Tsui: Nr·Km, N·m/A
  EXPECT_DOUBLE_EQ(Drive(TsuiConfig(kCurrent, InputMode::kPosition)).HoldingStiffness(),
                   nr_km * 1.9);
  EXPECT_DOUBLE_EQ(Drive(TsuiConfig(kIdeal, InputMode::kPosition)).HoldingStiffness(), nr_km * 1.9);
  EXPECT_DOUBLE_EQ(Drive(TsuiConfig(kVoltage, InputMode::kPosition)).HoldingStiffness(),
                   nr_km * 24.0 / 0.9);
  Servo servo;
  servo.kp = 2.5;
  EXPECT_DOUBLE_EQ(Drive(TsuiConfig(servo, InputMode::kPosition)).HoldingStiffness(), 2.5);
  EXPECT_EQ(Drive(TsuiConfig(Identification{}, InputMode::kVelocity)).HoldingStiffness(), 0.0);
  Stmms stmms;
  stmms.mechanical.k1p = 400;
  stmms.mechanical.k1 = 20;
  stmms.mechanical.k2 = 100;
  stmms.mechanical.inertia = 4.8e-5;
  EXPECT_DOUBLE_EQ(Drive(TsuiConfig(stmms, InputMode::kPosition)).HoldingStiffness(),
                   4.8e-5 * (20 + 400 * 100));
}

// microsteps: the commanded current vector moves on a grid of (π/2)/microsteps electrical rad,
// as a real driver's resolution setting; 0 keeps the ideal sine.
TEST(Drive, MicrostepsQuantizeTheCommandedCurrentVector) {
  const double full_step = kTwoPi / (4 * 50);  // rad, rotor side
  for (int microsteps : {0, 1, 2}) {
    CurrentMicrostep unit;
    unit.setpoint.microsteps = microsteps;
    const Drive drive(TsuiConfig(unit, InputMode::kPosition));
    for (double fraction : {0.3, 0.6, 1.2}) {
      const PhaseVector i = drive.Rest(0.0, 0.0, fraction * full_step).current();
      const double steps = std::arg(i) / (std::numbers::pi / 2);  // in full steps
      const double expected =
          microsteps == 0 ? fraction : std::round(fraction * microsteps) / microsteps;
      EXPECT_NEAR(steps, expected, 1e-12) << microsteps << " microsteps, " << fraction;
      EXPECT_NEAR(std::abs(i), 1.9, 1e-12);
    }
  }
}

TEST(Drive, StateRoundTripsThroughDoubles) {
  const Drive drive(TsuiConfig(kCurrent, InputMode::kPosition));
  DriveState s = drive.Rest(0.1, 0.2, 0.3);
  EXPECT_EQ(drive.layout().total(), 40 + 2);  // core + the PI integrators; no profile
  std::vector<double> buffer(drive.layout().total());
  drive.Store(s, buffer.data());
  const DriveState back = drive.Load(buffer.data());
  EXPECT_EQ(std::memcmp(&back, &s, sizeof(DriveCoreState)), 0);
  EXPECT_EQ(std::memcmp(back.unit.data(), s.unit.data(), 2 * sizeof(double)), 0);
  EXPECT_EQ(SignalTable().size(), static_cast<size_t>(kNumSignals));
}

}  // namespace
}  // namespace mjstepper
