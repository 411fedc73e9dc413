// Trinamic's SpreadCycle (controllers/spread_cycle.h) against closed forms (SPEC §8): the chopper
// cycle of a held rotor (on, slow, fast, slow) and its frequency from TOFF, the switching
// independent of the interrupt period and of the simulation step, following the table at speed
// where slow decay alone cannot, and the driver chips' timing and current scaling
// (driver_chip.h).
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "chopper_trace.h"
#include "core/averaged_bridge.h"
#include "core/drive.h"
#include "core/presets.h"
#include "core/step_times.h"
#include "core/units.h"

namespace mjstepper {
namespace {

constexpr double kBus = 24.0;            // V
constexpr double kR = 0.9, kL = 2.2e-3;  // Ω, H: Tsui's motor (presets.cc)

AttributeSource Attributes(const std::map<std::string, std::string>& kv) {
  return AttributeSource([kv](const char* key) -> const char* {
    const auto it = kv.find(key);
    return it == kv.end() ? nullptr : it->second.c_str();
  });
}

MotorParams Motor() {
  MotorParams m = FindPreset("tsui2009")->motor;  // R 0.9 Ω, L 2.2 mH, Km 0.3 N·m/A, 3 A
  m.detent.clear();
  return m;
}

SpreadCycle Unit(const std::map<std::string, std::string>& kv) {
  return SpreadCycle::FromAttributes(Attributes(kv), Motor(), DriveConstants{});
}

DriveConfig Config(const Controller& unit, double isr_period = 10e-6) {
  DriveConfig c;
  c.motor = Motor();
  c.controller = unit;
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

// The held rotor's steady chopper cycle, solved here independently of the drive: at ω = 0 a
// phase's current under a held voltage v is i(t) = v/R + (i0 − v/R)·e^{−a·t}, a = R/L (S-3), and
// within the on and fast phases i and the comparator level move in opposite directions, so each
// trip is the one root of a monotone function, found by bisection.
struct Cycle {
  double period = 0;  // s
  double peak = 0;    // A, the on phase's trip
  double trough = 0;  // A, the end of the second slow decay
};
Cycle SolveHeldCycle(const SpreadCycle& u, double target) {
  const double a = kR / kL;
  auto current = [&](double i0, double v, double t) {
    return v / kR + (i0 - v / kR) * std::exp(-a * t);
  };
  // H(t) from the cycle's start, A.
  auto hysteresis = [&](double t) {
    return u.HysteresisUnit() *
           std::max(u.hysteresis_end, u.hysteresis_start - t / u.decrement_time);
  };
  // The first t >= from at which f(t) >= 0, f increasing.
  auto root = [](auto f, double from) {
    if (f(from) >= 0) return from;
    double lo = from, hi = from + 1e-6;
    while (f(hi) < 0) hi += 1e-6;
    for (int k = 0; k < 200; ++k) {
      const double mid = 0.5 * (lo + hi);
      (f(mid) >= 0 ? hi : lo) = mid;
    }
    return hi;
  };
  Cycle c;
  double i0 = target;
  for (int cycle = 0; cycle < 2000; ++cycle) {
    const double t_on = root(
        [&](double t) { return current(i0, kBus, t) - (target + hysteresis(t)); }, u.blank_time);
    const double peak = current(i0, kBus, t_on);
    const double t_fast0 = t_on + u.off_time;  // the first slow decay
    const double i_fast0 = current(peak, 0, u.off_time);
    const double t_fast = root(
        [&](double t) { return (target - hysteresis(t)) - current(i_fast0, -kBus, t - t_fast0); },
        t_fast0 + u.blank_time);
    const double i_slow = current(i_fast0, -kBus, t_fast - t_fast0);
    c = {.period = t_fast + u.off_time, .peak = peak, .trough = current(i_slow, 0, u.off_time)};
    i0 = c.trough;
  }
  return c;
}

TEST(SpreadCycle, HeldRotorCycleMatchesTheClosedForm) {
  // Phase A held at 2 A (ψ = 0); the cycle on → slow t_OFF → fast → slow t_OFF, its period and
  // its peak against SolveHeldCycle, for TOFF 3 (Klipper's TMC2209 default) and 6. 5 ns samples:
  // the peak is missed by at most its slope·5 ns (5e-5 A); the rising edges over ~40 periods
  // give the mean period to 1e-3.
  for (const char* toff : {"3", "6"}) {
    const SpreadCycle u = Unit({{"run_current", "1.41421356237"}, {"toff", toff}});
    const double t_off_expected = (24 + 32 * std::stod(toff)) / 12e6;
    EXPECT_DOUBLE_EQ(u.off_time, t_off_expected);
    EXPECT_DOUBLE_EQ(u.blank_time, 32 / 12e6);  // TBL 2 on a TMC2209: 32 clocks
    const Cycle expected = SolveHeldCycle(u, 2.0);
    const Drive drive(Config(u));
    const Trace tr = RunAtSpeed(drive, 0.0, 5e-9, 2e-3, 1e-3);
    std::vector<double> rising;
    double hi = -1e9;
    // The voltage sequence within each cycle: +V (on), 0, −V (fast), 0.
    std::vector<double> sequence;
    for (size_t k = 0; k < tr.t.size(); ++k) {
      hi = std::max(hi, tr.ia[k]);
      if (k > 0 && tr.va[k] != tr.va[k - 1]) sequence.push_back(tr.va[k]);
      if (k > 0 && tr.va[k] > 0 && tr.va[k - 1] <= 0) rising.push_back(tr.t[k]);
    }
    ASSERT_GT(rising.size(), 20u);
    for (size_t k = 0; k + 4 < sequence.size(); ++k) {
      if (sequence[k] != kBus) continue;
      EXPECT_EQ(sequence[k + 1], 0);
      EXPECT_EQ(sequence[k + 2], -kBus);
      EXPECT_EQ(sequence[k + 3], 0);
      EXPECT_EQ(sequence[k + 4], kBus);
    }
    const double period = (rising.back() - rising.front()) / (rising.size() - 1);
    std::printf(
        "TOFF %s: t_OFF %.3f µs, period %.4f µs (closed form %.4f µs, %.1f kHz), peak %.5f A "
        "(closed form %.5f A), trough %.5f A\n",
        toff, u.off_time * 1e6, period * 1e6, expected.period * 1e6, 1e-3 / expected.period, hi,
        expected.peak, expected.trough);
    EXPECT_NEAR(period, expected.period, 1e-3 * expected.period);
    EXPECT_NEAR(hi, expected.peak, 1e-4);
  }
}

// The steady cycle the averaged drive and the timestep note read (averaged_bridge.h's SteadyCycle:
// the unit's own rules on a current that moves at constant slopes (v − R·i* − e)/L) against the
// held rotor's exact cycle: its period within 1 % (the linear slopes' error, about a·period/2 of
// the exponential's curvature: 0.5 %). FastestCycle, over a tenth to all of the peak and drops
// within ±Vbus/2, is at least that cycle's rate: the rate a step must resolve not to fold it.
TEST(SpreadCycle, SteadyCycleIsTheHeldRotorsCycle) {
  for (const char* toff : {"3", "6"}) {
    const SpreadCycle u = Unit({{"run_current", "1.41421356237"}, {"toff", toff}});
    const Cycle expected = SolveHeldCycle(u, 2.0);
    const CycleStats linear = SteadyCycle(u, kBus, kL, 2.0, kR * 2.0);
    const double fastest = FastestCycle(u, kBus, kL, u.table.peak_current);
    std::printf("TOFF %s: period %.4f µs (exact %.4f µs); fastest cycle %.2f kHz\n", toff,
                linear.period * 1e6, expected.period * 1e6, fastest / 1e3);
    EXPECT_NEAR(linear.period / expected.period, 1.0, 0.01) << toff;
    EXPECT_GE(fastest, 1 / linear.period) << toff;
    EXPECT_LT(fastest, 2 / linear.period) << toff;  // the same chopper, not a different one
  }
}

TEST(SpreadCycle, SwitchingIsIndependentOfTheInterruptPeriodAndTheStep) {
  const SpreadCycle u = Unit({{"run_current", "1.41421356237"}});
  std::vector<double> currents;
  for (double isr : {10e-6, 50e-6}) {
    const Drive drive(Config(u, isr));
    for (double h : {1e-6, 50e-6, 1e-3}) {
      DriveState s = drive.Rest(0.0, 0.0, 0.0);
      for (long k = 0; k < std::lround(5e-3 / h); ++k) {
        ASSERT_EQ(drive.Advance(&s, k * h, (k + 1) * h, 0.0, 0.0), AdvanceStatus::kOk);
      }
      currents.push_back(s.current_a);
    }
  }
  for (double i : currents) EXPECT_NEAR(i, currents[0], 1e-9);
  EXPECT_GT(std::abs(currents[0] - 2.0), 1e-4);  // it chops
}

// Where the step does not resolve the chopper's cycle, the currents handed over for the torque
// are the switching currents less their ripple (PhaseSwitch::Ripple): held half a full step off
// the table's axes, both phases chop, and sampled at the end of each 50 µs step the instantaneous
// current scatters over the ripple (a 24 kHz cycle folded by 20 kHz sampling) while the handed
// one stays on the cycle's mean. The mean is the time average of a 1 µs run's exact charge, and
// at 1 µs nothing is taken out.
TEST(SpreadCycle, HandedCurrentIsTheCyclesMeanWhereTheStepWouldFoldIt) {
  const SpreadCycle u = Unit({{"run_current", "1.41421356237"}});
  const Drive drive(Config(u));
  const double theta = std::numbers::pi / 4 / 50;  // rad: half a full step, both phases at 0.71·I
  auto run = [&](double h, double settle, double span, std::vector<double>* now,
                 std::vector<double>* handed, double* charge_mean) {
    DriveState s = drive.Rest(0.0, theta, 0.0);
    const long settled = std::lround(settle / h), n = settled + std::lround(span / h);
    double charge = 0;  // A·s over the span, trapezoid of the 1 µs samples
    for (long k = 0; k < n; ++k) {
      const double before = s.current_a;
      ASSERT_EQ(drive.Advance(&s, k * h, (k + 1) * h, theta, 0.0), AdvanceStatus::kOk);
      if (k < settled) continue;
      charge += 0.5 * (before + s.current_a) * h;
      now->push_back(s.current_a);
      handed->push_back(s.handed_current().real());
    }
    *charge_mean = charge / span;
  };
  auto spread = [](const std::vector<double>& x, double about) {
    double sum = 0;
    for (double v : x) sum += (v - about) * (v - about);
    return std::sqrt(sum / x.size());
  };
  std::vector<double> fine_now, fine_handed, now, handed;
  double mean = 0, unused = 0;
  run(1e-6, 5e-3, 20e-3, &fine_now, &fine_handed, &mean);
  run(50e-6, 5e-3, 20e-3, &now, &handed, &unused);
  const double scatter = spread(now, mean), held = spread(handed, mean);  // A, RMS about the mean
  std::printf(
      "phase a's mean %.5f A; at 50 µs the current scatters %.5f A RMS about it, the "
      "handed one %.6f A\n",
      mean, scatter, held);
  EXPECT_GT(scatter, 0.005);         // A: the ripple the step would fold
  EXPECT_LT(held, scatter / 100);    // measured 1/2400: the linear pieces. error
  EXPECT_EQ(fine_handed, fine_now);  // at 1 µs the step resolves the cycle
}

// STEP/DIR pulses from a list (DriveConfig::step_times, the `step_times` attribute) move the
// table at their own times whatever the simulation step: 40 pulses at irregular times, forward
// and back, give the same currents and count after 5 ms at steps of 1 µs, 50 µs and 1 ms (to
// 1e-9 A, the switching's own independence of the step above). The same pulses through ctrl, the
// count at each step's end with its pulses spread evenly over the step, do not: at 1 ms they move
// up to a millisecond late.
TEST(SpreadCycle, ListedPulsesMoveTheTableAtTheirOwnTimesWhateverTheStep) {
  std::string text;
  for (int k = 0; k < 40; ++k) {
    const double t = 0.3e-3 + 0.0917e-3 * k + 0.03e-3 * std::sin(1.7 * k);  // s, irregular
    text += std::to_string(t) + (k < 30 ? "\n" : " -1\n");
  }
  std::istringstream in(text);
  const auto list = std::make_shared<const StepTimes>(StepTimes::Parse(in, "pulses"));
  DriveConfig listed = Config(Unit({{"run_current", "1.41421356237"}}));
  listed.input = InputMode::kSteps;
  listed.step_times = list;
  DriveConfig counted = listed;
  counted.step_times = nullptr;
  struct End {
    double ia, ib, theta_cmd;
  };
  auto run = [&](const DriveConfig& c, double h) {
    const Drive drive(c);
    DriveState s = drive.Rest(0.0, 0.0, 0.0);
    for (long k = 0; k < std::lround(5e-3 / h); ++k) {
      const double count = list->Count((k + 1) * h);  // ctrl: the count at the step's end
      EXPECT_EQ(drive.Advance(&s, k * h, (k + 1) * h, 0.0, count), AdvanceStatus::kOk);
    }
    return End{s.current_a, s.current_b, s.theta_cmd / drive.StepAngle()};
  };
  const End fine = run(listed, 1e-6);
  EXPECT_NEAR(fine.theta_cmd, 20, 1e-9);  // 30 forward, 10 back
  for (double h : {50e-6, 1e-3}) {
    const End coarse = run(listed, h);
    EXPECT_NEAR(coarse.ia, fine.ia, 1e-9) << h;
    EXPECT_NEAR(coarse.ib, fine.ib, 1e-9) << h;
    EXPECT_NEAR(coarse.theta_cmd, fine.theta_cmd, 1e-9) << h;
  }
  const End spread_fine = run(counted, 1e-6), spread_coarse = run(counted, 1e-3);
  EXPECT_GT(std::abs(spread_coarse.ib - spread_fine.ib), 1e-4);  // ctrl's spread moves them
}

TEST(SpreadCycle, FastDecayPhaseFollowsTheTableAtSpeedWhereSlowDecayCannot) {
  // At 300 r/min (Ω = 1571 rad/s electrical) the back-EMF (Km·ω = 9.4 V) holds the current up
  // where the table falls: the A4988-class chopper in slow decay only lags it by amperes, while
  // SpreadCycle's fast-decay phase drives it down every cycle.
  const double omega = RpmToRadPerSec(300);
  const double cycle = 2 * std::numbers::pi / (50 * omega);  // s, one electrical cycle
  auto error = [&](const Controller& unit) {
    const Drive drive(Config(unit));
    return TrackingError(RunAtSpeed(drive, omega, 1e-6, 1e-3 + 4 * cycle, 1e-3 + 2 * cycle));
  };
  ConstantOffTime slow = ConstantOffTime::FromAttributes(
      Attributes({{"run_current", "1.41421356237"}, {"decay", "slow"}}), Motor(), {});
  const double slow_error = error(slow);
  const double spread_error = error(Unit({{"run_current", "1.41421356237"}}));
  std::printf("RMS tracking error at 300 r/min: spreadcycle %.4f A, chopper slow decay %.4f A\n",
              spread_error, slow_error);
  EXPECT_LT(spread_error, slow_error / 3);
  EXPECT_LT(spread_error, 0.15);  // A, 7.5 % of the 2 A peak
}

TEST(DriverChip, TimingComesFromTheChipsDatasheet) {
  // TMC2130: t_OFF = (12 + 32·TOFF)/f_CLK at 13.2 MHz, TBL 1 = 24 clocks; Klipper's TOFF 4,
  // HSTRT 0 (1), HEND 7 (4).
  const SpreadCycle u = Unit({{"driver", "tmc2130"}, {"run_current", "1"}});
  EXPECT_DOUBLE_EQ(u.off_time, (12 + 32 * 4) / 13.2e6);
  EXPECT_DOUBLE_EQ(u.blank_time, 24 / 13.2e6);
  EXPECT_EQ(u.hysteresis_start, 1 + 4);
  EXPECT_EQ(u.hysteresis_end, 4);
  // TMC5160: TBL 2 = 36 clocks, HEND 2 → −1.
  const SpreadCycle v = Unit({{"driver", "tmc5160"}, {"run_current", "1"}});
  EXPECT_DOUBLE_EQ(v.blank_time, 36 / 12e6);
  EXPECT_EQ(v.hysteresis_end, -1);
  // DRV8825 on the constant-off-time chopper: 30 kHz PWM, 3.75 µs blank, fast until 75 %.
  const ConstantOffTime d = ConstantOffTime::FromAttributes(
      Attributes({{"driver", "drv8825"}, {"run_current", "1"}}), Motor(), {});
  EXPECT_EQ(d.pwm_frequency, 30e3);
  EXPECT_EQ(d.blank_time, 3.75e-6);
  EXPECT_EQ(d.fast_fraction, 0.75);
  EXPECT_FALSE(d.table.interpolate);
}

TEST(DriverChip, RunCurrentIsRoundedToTheChipsSteps) {
  // TMC2209, R_S 0.110 Ω: I = (CS+1)/32·V_FS/(R_S + 0.02)/√2. For 0.8 A RMS: vsense = 1
  // (0.180 V) gives CS 25 → 0.7955 A; vsense = 0 (0.325 V) gives CS 13 → 0.7734 A; the nearer.
  const SpreadCycle u = Unit({{"driver", "tmc2209"}, {"run_current", "0.8"}});
  const double expected = 26.0 / 32 * 0.180 / 0.130 / std::sqrt(2.0);  // A RMS
  EXPECT_NEAR(u.table.peak_current, std::sqrt(2.0) * expected, 1e-12);
  EXPECT_TRUE(u.table.interpolate);  // MicroPlyer on, as on the chip
  // A 3 A motor by default: the most the 0.110 Ω allow, CS 31 at 0.325 V = 1.768 A.
  const SpreadCycle d = Unit({{"driver", "tmc2209"}});
  EXPECT_NEAR(d.table.peak_current, std::sqrt(2.0) * 0.325 / 0.130 / std::sqrt(2.0), 1e-12);
  // TMC5160, R_S 0.075 Ω: GLOBALSCALER = round(256·I·√2·R_S/0.325) for 1.5 A = 125, CS 31.
  const SpreadCycle f = Unit({{"driver", "tmc5160"}, {"run_current", "1.5"}});
  EXPECT_NEAR(f.table.peak_current, 125.0 / 256 * 0.325 / 0.075, 1e-12);
  // Beyond the chip, and below its least step: refused, naming the attribute and value.
  for (const auto& [driver, current, words] :
       std::vector<std::tuple<std::string, std::string, std::string>>{
           {"tmc2209", "2", "run_current = \"2\""},
           {"tmc2209", "2", "at most 1.77 A RMS"},
           {"tmc2209", "0.01", "more than 10 %"},
           {"a4988", "1.6", "at most 1.41 A RMS"}}) {
    try {
      if (driver == "a4988") {
        ConstantOffTime::FromAttributes(Attributes({{"driver", driver}, {"run_current", current}}),
                                        Motor(), {});
      } else {
        Unit({{"driver", driver}, {"run_current", current}});
      }
      ADD_FAILURE() << driver << " accepted run_current " << current;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  }
}

TEST(DriverChip, RegisterRangesAreChecked) {
  auto message = [](const std::map<std::string, std::string>& kv) -> std::string {
    try {
      Unit(kv);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(message({{"toff", "0"}}).find("toff"), std::string::npos);
  EXPECT_NE(message({{"toff", "1"}, {"tbl", "1"}}).find("needs tbl >= 2"), std::string::npos);
  EXPECT_NE(message({{"hstrt", "7"}, {"hend", "15"}}).find("HSTRT + HEND = 8 + 12"),
            std::string::npos);
  EXPECT_NE(message({{"clock_frequency", "1e9"}}).find("clock_frequency"), std::string::npos);
  EXPECT_NE(message({{"driver", "a4988"}}).find("use drive = chopper"), std::string::npos);
  EXPECT_NE(message({{"driver", "l298"}}).find("must be one of"), std::string::npos);
  EXPECT_EQ(message({{"hstrt", "7"}, {"hend", "11"}}), "");  // 8 + 8 = 16: allowed
  // Issue 33: only hend written, so hend is named, and hstrt shown as the chip's default (the
  // message named hstrt = "5", which the user never wrote).
  const std::string hend_only = message({{"hend", "15"}});
  EXPECT_EQ(hend_only.rfind("hend = \"15\"", 0), 0u) << hend_only;
  EXPECT_NE(hend_only.find("(hstrt = 5, the tmc2209 default)"), std::string::npos) << hend_only;
  // Issue 33: a current table that is no quarter wave (all zero: the rotor never moved).
  const std::map<std::string, std::string> quarter = {{"microsteps", "4"}};
  auto table = [&](const std::string& entries) {
    auto kv = quarter;
    kv["current_table"] = entries;
    return message(kv);
  };
  EXPECT_EQ(table("0 0.38 0.71 0.92 1"), "");
  EXPECT_NE(table("0 0 0 0 0").find("starts at 0 and ends at 1 (this one: 0 to 0)"),
            std::string::npos);
  EXPECT_NE(table("0.1 0.38 0.71 0.92 1").find("starts at 0"), std::string::npos);
  EXPECT_NE(table("0 0.71 0.38 0.92 1").find("entry 2 (0.38) is below entry 1 (0.71)"),
            std::string::npos);
}

}  // namespace
}  // namespace mjstepper
