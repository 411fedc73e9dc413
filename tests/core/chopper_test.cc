// The constant-off-time chopper (controllers/constant_off_time.h) against closed forms (SPEC §8):
// the on and decay slopes, the ripple and the chopper frequency of a held rotor, the switching
// independent of the interrupt period and of the simulation step, and slow against fast decay
// following a falling current at speed.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <numbers>
#include <utility>
#include <vector>

#include "chopper_trace.h"
#include "core/drive.h"
#include "core/presets.h"
#include "core/units.h"

namespace mjstepper {
namespace {

constexpr double kBus = 24.0;   // V
constexpr double kPeak = 2.0;   // A, the table's peak (run_current √2 A)
constexpr double kOff = 30e-6;  // s, A4988

ConstantOffTime Chopper(ConstantOffTime::Decay decay) {
  ConstantOffTime c;
  c.table.peak_current = kPeak;
  c.table.microsteps = 16;
  c.table.interpolate = false;
  c.off_time = kOff;
  c.blank_time = 1e-6;
  c.decay = decay;
  return c;
}

DriveConfig Config(const ConstantOffTime& chopper, double isr_period = 10e-6) {
  DriveConfig c;
  c.motor = FindPreset("tsui2009")->motor;  // R 0.9 Ω, L 2.2 mH, Km 0.3 N·m/A
  c.motor.detent.clear();
  c.controller = chopper;
  c.input = InputMode::kVelocity;
  c.bus_voltage = kBus;
  c.isr_period = isr_period;
  c.compute_delay = 0;
  c.encoder_counts = 0;
  return c;
}

using testing::RunAtSpeed;
using testing::Trace;
using testing::TrackingError;

TEST(Chopper, HeldRotorRippleAndFrequencyMatchTheClosedForm) {
  // ω = 0, slow decay: the off-time decays i from the trip point I to I·e^{−a·t_off} (a = R/L),
  // the on-time climbs back along i(t) = V/R + (i_lo − V/R)·e^{−a·t}:
  //   Δi = I·(1 − e^{−a·t_off})  (≈ t_off·R·I/L, SPEC §8),   t_on = ln((V/R − i_lo)/(V/R − I))/a.
  const Drive drive(Config(Chopper(ConstantOffTime::Decay::kSlow)));
  const double R = 0.9, L = 2.2e-3, a = R / L;
  const double low = kPeak * std::exp(-a * kOff);
  const double ripple = kPeak - low;
  const double t_on = std::log((kBus / R - low) / (kBus / R - kPeak)) / a;
  const double frequency = 1 / (kOff + t_on);  // Hz
  // 5 ns samples over 2 ms after 1 ms: the peak is missed by at most its slope·5 ns (5e-5 A, 0.2 %
  // of Δi); the rising edges are counted exactly.
  const Trace tr = RunAtSpeed(drive, 0.0, 5e-9, 3e-3, 1e-3);
  double hi = -1e9, lo = 1e9;
  std::vector<double> rising;  // s, the samples at which the bridge switched on
  for (size_t k = 0; k < tr.t.size(); ++k) {
    hi = std::max(hi, tr.ia[k]);
    lo = std::min(lo, tr.ia[k]);
    if (k > 0 && tr.va[k] > 0 && tr.va[k - 1] <= 0) rising.push_back(tr.t[k]);
  }
  ASSERT_GT(rising.size(), 10u);
  const double measured = (rising.size() - 1) / (rising.back() - rising.front());  // Hz
  std::printf(
      "ripple %.6f A (closed form %.6f, SPEC's t_off·R·I/L %.6f), frequency %.1f Hz "
      "(closed form %.1f Hz)\n",
      hi - lo, ripple, kOff * R * kPeak / L, measured, frequency);
  EXPECT_NEAR(hi, kPeak, 1e-9 + 5e-9 * 11000);  // the trip point, within one sample's rise
  EXPECT_NEAR(hi - lo, ripple, 0.005 * ripple);
  // The edges are sampled to 5 ns over ~60 periods: the mean period to 1e-4.
  EXPECT_NEAR(measured, frequency, 1e-3 * frequency);
}

TEST(Chopper, SlopesFollowTheWindingEquationAtSpeed) {
  // On: L·di/dt = ±Vbus − R·i − e; slow decay: L·di/dt = −R·i − e; fast: −sgn(i)·Vbus − R·i − e,
  // e = −Km·ω·sin(Nr·θ) (S-2, S-3). Checked on every pair of 10 ns samples that share a voltage.
  for (auto decay : {ConstantOffTime::Decay::kSlow, ConstantOffTime::Decay::kFast}) {
    const Drive drive(Config(Chopper(decay)));
    const double omega = RpmToRadPerSec(60);  // rad/s
    const double h = 10e-9;
    const Trace tr = RunAtSpeed(drive, omega, h, 1.5e-3, 1e-3);
    int checked[3] = {0, 0, 0};
    for (size_t k = 1; k < tr.t.size(); ++k) {
      if (tr.va[k] != tr.va[k - 1]) continue;  // a switch between the samples
      const double t_mid = tr.t[k] - h / 2;
      const double i_mid = 0.5 * (tr.ia[k] + tr.ia[k - 1]);
      const double emf = -0.3 * omega * std::sin(50 * omega * t_mid);   // ea, V
      const double expected = (tr.va[k] - 0.9 * i_mid - emf) / 2.2e-3;  // A/s
      const double measured = (tr.ia[k] - tr.ia[k - 1]) / h;
      ASSERT_NEAR(measured, expected, 1e-4 * std::abs(expected) + 1.0) << "at t = " << tr.t[k];
      ++checked[tr.va[k] > 0 ? 0 : tr.va[k] < 0 ? 1 : 2];
    }
    EXPECT_GT(checked[0], 100);  // on
    // Slow decay; or fast (at 2 A it does not reach 0 within t_off).
    EXPECT_GT(checked[decay == ConstantOffTime::Decay::kFast ? 1 : 2], 100);
  }
}

TEST(Chopper, SwitchingIsIndependentOfTheInterruptPeriodAndTheStep) {
  // A held rotor: the chopper's cycle is the comparator's and the off-timer's alone. Run with
  // ticks every 10 µs and 50 µs, and simulation steps of 1 µs, 50 µs and 1 ms: the current at 5 ms
  // is the same to round-off.
  const ConstantOffTime chopper = Chopper(ConstantOffTime::Decay::kMixed);
  std::vector<double> currents;
  for (double isr : {10e-6, 50e-6}) {
    const Drive drive(Config(chopper, isr));
    for (double h : {1e-6, 50e-6, 1e-3}) {
      DriveState s = drive.Rest(0.0, 0.0, 0.0);
      for (long k = 0; k < std::lround(5e-3 / h); ++k) {
        ASSERT_EQ(drive.Advance(&s, k * h, (k + 1) * h, 0.0, 0.0), AdvanceStatus::kOk);
      }
      currents.push_back(s.current_a);
    }
  }
  for (double i : currents) EXPECT_NEAR(i, currents[0], 1e-9);
  // And it does chop: not the averaged current.
  EXPECT_GT(std::abs(currents[0] - kPeak), 1e-4);
}

TEST(Chopper, FastDecayFollowsAFallingCurrentThatSlowDecayCannot) {
  // At speed the back-EMF opposes the falling half of each table cycle: slow decay (v = 0)
  // discharges the winding only at (R·i + e)/L, fast decay at (Vbus + R·i + e)/L, so slow decay
  // lags the table where the current falls. At low speed both follow within their ripple.
  auto error = [](ConstantOffTime::Decay decay, double rpm) {
    const Drive drive(Config(Chopper(decay)));
    const double omega = RpmToRadPerSec(rpm);
    const double cycle = 2 * std::numbers::pi / (50 * omega);  // s, one electrical cycle
    return TrackingError(RunAtSpeed(drive, omega, 1e-6, 1e-3 + 4 * cycle, 1e-3 + 2 * cycle));
  };
  const double slow_fast = error(ConstantOffTime::Decay::kSlow, 300);
  const double fast_fast = error(ConstantOffTime::Decay::kFast, 300);
  const double mixed_fast = error(ConstantOffTime::Decay::kMixed, 300);
  std::printf("RMS tracking error at 300 r/min: slow %.4f A, mixed %.4f A, fast %.4f A\n",
              slow_fast, mixed_fast, fast_fast);
  EXPECT_GT(slow_fast, 3 * fast_fast);
  EXPECT_GT(slow_fast, 2 * mixed_fast);
}

// Found by the drive fuzzer: at an absurd rotor speed (1e9 rad/s here) the crossing search's
// 0.5-rad pieces fell below the round-off of the time and it never moved on. Now at most
// kMaxCrossingPieces pieces per search: the step returns (a hang fails this test by ctest's
// timeout) with a finite state.
TEST(Chopper, AnAbsurdSpeedStepReturns) {
  const Drive drive(Config(Chopper(ConstantOffTime::Decay::kMixed)));
  DriveState s = drive.Rest(0.0, 0.0, 0.0);
  drive.Advance(&s, 0.0, 1e-3, 1e6, 1e9);
  EXPECT_TRUE(std::isfinite(s.current_a) && std::isfinite(s.current_b));
  EXPECT_EQ(s.theta, 1e6);
  // 1e19 rad/s: half a radian of electrical rotation is 1e-21 s, below the round-off of t = 1 s.
  DriveState t = drive.Rest(1.0, 0.0, 0.0);
  drive.Advance(&t, 1.0, 1.0 + 1e-9, 1e10, 0.0);
  EXPECT_TRUE(std::isfinite(t.current_a) && std::isfinite(t.current_b));
}

TEST(Chopper, LeastOnTimeSetsTheLeastCurrentSlowDecayRegulates) {
  // A4988 datasheet, "Low Current Microstepping": "the minimum on-time prevents the output current
  // from regulating to the programmed current level at low current steps", which mixed decay
  // cures. At ω = 0 in slow decay a phase whose target is below the cycle of one blank time on
  // (V/R·(1 − e^{−a·t_b})) and t_off shorted settles on that cycle, whose low point is
  //   i_lo = V/R·(1 − e^{−a·t_b})·e^{−a·t_off} / (1 − e^{−a·(t_b + t_off)})
  // (about Vbus·t_b/(R·t_off) = 0.89 A); mixed decay holds the 0.196 A target.
  const double R = 0.9, L = 2.2e-3, a = R / L, tb = 1e-6;
  const double i_lo =
      kBus / R * (1 - std::exp(-a * tb)) * std::exp(-a * kOff) / (1 - std::exp(-a * (tb + kOff)));
  const double theta = 2 * std::numbers::pi / (4 * 50 * 16);  // one microstep: ib* = 2·sin(π/32)
  // Phase B's lowest and highest current over 1 ms after 59 ms (5 ns samples then).
  auto extremes = [&](ConstantOffTime::Decay decay) {
    DriveConfig c = Config(Chopper(decay));
    c.input = InputMode::kPosition;
    const Drive held(c);
    DriveState s = held.Rest(0.0, theta, theta);
    double t = 0, lo = 1e9, hi = -1e9;
    while (t < 60e-3 - 1e-12) {
      const double h = t < 59e-3 - 1e-12 ? 1e-6 : 5e-9;
      held.Advance(&s, t, t + h, theta, theta);
      t += h;
      if (h < 1e-6) {
        lo = std::min(lo, s.current_b);
        hi = std::max(hi, s.current_b);
      }
    }
    return std::pair(lo, hi);
  };
  const double target = kPeak * std::sin(std::numbers::pi / 32);  // A
  const auto [slow_lo, slow_hi] = extremes(ConstantOffTime::Decay::kSlow);
  const auto [mixed_lo, mixed_hi] = extremes(ConstantOffTime::Decay::kMixed);
  std::printf(
      "phase B, target %.4f A: slow %.4f-%.4f A (closed-form low point %.4f A), mixed "
      "%.4f-%.4f A\n",
      target, slow_lo, slow_hi, i_lo, mixed_lo, mixed_hi);
  EXPECT_NEAR(slow_lo, i_lo, 0.002 * i_lo);
  EXPECT_NEAR(mixed_hi, target, 1e-3);  // mixed decay trips at the target
}

}  // namespace
}  // namespace mjstepper

namespace mjstepper {
namespace {

TEST(StepDir, CountSetsTheCommandedAngleAndTheTableEntry) {
  // input = steps: ctrl n → θcmd = n·2π/(4·Nr·M) at the step's end; the targets are the sine table
  // at ψ = n·(π/2)/M (step_table.h), here M = 16.
  DriveConfig c = Config(Chopper(ConstantOffTime::Decay::kMixed));
  c.input = InputMode::kSteps;
  const Drive drive(c);
  const double step = 2 * std::numbers::pi / (4 * 50 * 16);
  EXPECT_DOUBLE_EQ(drive.StepAngle(), step);
  DriveState s = drive.Rest(0.0, 0.0, 0.0);
  for (int k = 0; k < 100; ++k) {  // 5 ms, counting up to 5 then holding
    const double count = std::min(k, 5);
    ASSERT_EQ(drive.Advance(&s, k * 50e-6, (k + 1) * 50e-6, 0.0, count), AdvanceStatus::kOk);
  }
  EXPECT_DOUBLE_EQ(s.theta_cmd, 5 * step);
  const double psi = 5 * (std::numbers::pi / 2) / 16;
  EXPECT_NEAR(s.current_ref_a, kPeak * std::cos(psi), 1e-12);
  EXPECT_NEAR(s.current_ref_b, kPeak * std::sin(psi), 1e-12);
  // A count that is no command (NaN) keeps the count the drive holds.
  EXPECT_EQ(drive.CommandFrom(std::nan(""), &s, 0.0), 5.0);
  // A drive without a microstep table cannot count steps.
  DriveConfig continuous;
  continuous.input = InputMode::kSteps;  // current_microstep with microsteps = 0
  EXPECT_THROW(Drive{continuous}, std::invalid_argument);
}

TEST(StepDir, PulsesAreSpreadOverTheStep) {
  // Four pulses in one 100 µs step (count 0 → 4), ticks every 10 µs: the drive moves θcmd along
  // the count's line, so the run is the same as ten 10 µs steps whose counts lie on that line
  // (0.4, 0.8, ...), to round-off; four pulses at the step's start (ten steps at count 4) is not.
  DriveConfig c = Config(Chopper(ConstantOffTime::Decay::kMixed));
  c.input = InputMode::kSteps;
  const Drive drive(c);
  auto run = [&](int pieces, const std::function<double(int)>& count) {
    DriveState s = drive.Rest(0.0, 0.0, 0.0);
    const double h = 100e-6 / pieces;
    for (int k = 0; k < pieces; ++k) {
      EXPECT_EQ(drive.Advance(&s, k * h, (k + 1) * h, 0.0, count(k)), AdvanceStatus::kOk);
    }
    return s.current();
  };
  const PhaseVector one_step = run(1, [](int) { return 4.0; });
  const PhaseVector on_the_line = run(10, [](int k) { return 0.4 * (k + 1); });
  const PhaseVector at_once = run(10, [](int) { return 4.0; });
  EXPECT_NEAR(std::abs(one_step - on_the_line), 0.0, 1e-9);
  EXPECT_GT(std::abs(one_step - at_once), 1e-3);
}

TEST(StepDir, MicroPlyerLagsByOneStepInterval) {
  // TMC2209 datasheet, MicroPlyer: each step is spread over the interval measured between the
  // last two steps, in 1/256 full steps. At an even rate of one microstep (M = 16) every 10 ticks,
  // the position is the count one interval ago plus the elapsed fraction: it lags by exactly one
  // step interval, and equals the count only when interpolation is off.
  MicrostepTable table;
  table.microsteps = 16;
  const DriveConstants k{.isr_period = 10e-6};
  for (bool interpolate : {true, false}) {
    table.interpolate = interpolate;
    MicrostepTable::Counter counter;
    double worst_lag = 0;
    for (long tick = 0; tick < 400; ++tick) {
      const double count = static_cast<double>(tick / 10);
      const double position = table.Position(k, count, tick, &counter);
      if (tick >= 30) {
        const double expected = interpolate ? count - 1 + (tick % 10) / 10.0 : count;
        // 1/256 full step is 1/16 microstep at M = 16: the position's grid.
        EXPECT_NEAR(position, expected, 1.0 / 32 + 1e-12) << "tick " << tick;
        worst_lag = std::max(worst_lag, count - position);
      }
    }
    EXPECT_NEAR(worst_lag, interpolate ? 1.0 : 0.0, 1.0 / 16 + 1e-12);
  }
}

}  // namespace
}  // namespace mjstepper
