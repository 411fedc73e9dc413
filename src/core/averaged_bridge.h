// Averaged bridges: a chopper drive's current regulation replaced by its cycle average (SPEC §11).
//
// A switching bridge (switching.h) holds each phase's current within a ripple of a few tens of mA
// about its target, switching at 20-40 kHz; what the rotor feels is the cycle's mean current.
// The averaged bridge keeps that mean and drops the cycles:
//   - a phase whose current is on its target stays there: over an interval of length Δ the bridge
//     applies the one constant voltage that brings the exact winding solution (S-3, winding.h)
//     back to the target at the interval's end (deadbeat), v = (i* − i_free(Δ))·R/(1 − e^{−aΔ}),
//     a = R/L, i_free the current the interval would end at with v = 0;
//   - the bus limits it (S-13: |va|, |vb| <= Vbus): a phase whose target needs more than the bus
//     can give against R·i and the back-EMF e = j·Km·ω·e^{jx} (S-2) lags, at ±Vbus, as the
//     switching bridge does when its on-time never reaches the comparator;
//   - a new target (a STEP edge, a tick's table) is reached at the rate the bus allows: the first
//     interval after it lasts the slew time L·|i* − i|/(Vbus − |R·i* + e|) (SlewTime), so the
//     current moves at nearly the full bus, as the on-time of a chopper moves it, and not over the
//     whole interval.
// The intervals are bounded by kAveragedRotation of electrical rotation, over which the back-EMF
// is nearly constant, so that the deadbeat voltage holds the current close to its target within
// the interval too (the deviation is at most Km·Δx²/(8·Nr·L): 0.04 A on a 17HS19 at 0.5 rad).
// Cost: a few intervals per step at low speed, and per 0.5 rad of electrical rotation at speed,
// whatever the drive's clock or chopper frequency.
//
// The mean of a chopper's cycle is not its target: a peak-current chopper trips at the target and
// decays below it; SpreadCycle's blank times, off-times and decaying hysteresis leave its mean
// 1-2 % below. RippleOffsets measures that offset once at load by running the unit's own Switch
// rules (the same code the switching mode runs) on one phase whose current moves at the constant
// slopes (v − R·i* − e)/L of a chopper cycle (tens of µs, ≪ L/R), for a grid of targets and
// voltage drops, until the cycle has settled (near a zero drop the current drifts for hundreds of
// cycles first); the averaged target is the table's plus the offset there.
//
// A chopper regulates within a band, not onto a point (OffsetBand, RippleOffsets::BandAt): its
// blank times give every on and fast-decay phase a least length, so after a step down its mean
// lands on the band's top and comes down only through the slow decays, at (R·i* + e)/L, which
// near a zero crossing takes milliseconds; a step up lands on the band's bottom, the steady cycle,
// at once. The averaged phase carries the mean nearest the one it has within the band, and within
// it follows the slow decay's v = 0 course. That is also the phase's memory where the drop crosses
// 0 (a ringing rotor's back-EMF): the steady offset jumps there (−0.0085 to +0.0175 A on a
// TMC2209), the chopper's mean does not.
//
// What the average leaves out: the ripple itself (its RMS, ΔI/√12, a small part of the copper
// loss).
#ifndef MJSTEPPER_CORE_AVERAGED_BRIDGE_H_
#define MJSTEPPER_CORE_AVERAGED_BRIDGE_H_

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/motor.h"
#include "core/power_stage.h"
#include "core/switching.h"

namespace mjstepper {

/// An averaged phase's mode (PhaseSwitch::mode, which the unit's own rules do not use in averaged
/// mode): regulating a target, or, with a zero target, driving its current back to 0 through the
/// reversed bridge and then shorted (v = 0), as the switching units' IdleBridge does: a shorted
/// phase carries what the back-EMF drives through R and L, the idle phase's damping.
inline constexpr double kAveragedRegulating = 0, kAveragedDecaying = 1, kAveragedShorted = 2;

/// Electrical rotation (rad) an averaged interval spans at most.
inline constexpr double kAveragedRotation = 0.5;

/// The most intervals one step spends following a command that moves more than this many
/// microsteps in it (a jump, not a motion): it is read in that many.
inline constexpr double kMaxAveragedReads = 1000;

/// A phase counts as on its target within this fraction of the bus's current scale (Vbus/R): 1.7 mA
/// on a 17HS19 at 24 V, a tenth of its SpreadCycle ripple. The interval's deadbeat voltage takes it
/// there; only a phase further off slews in an interval of its own. (At 1e-9 the targets' own
/// drift with the back-EMF, through the cycle-mean offsets, started a slew interval before nearly
/// every interval: 7.8 intervals per 50 µs step on `bench_step spreadcycle_averaged` instead
/// of 3.3, 30 % more instructions, and no measure of docs/coupling.md moved by more than 0.1 %.)
inline constexpr double kOnTargetFraction = 1e-4;

/// The headroom below which a phase is taken as saturated (fraction of Vbus): it then lags at the
/// bus for a whole interval rather than for a slew time.
inline constexpr double kSaturatedHeadroom = 0.05;

/// The time (s) the bus needs to move phase current `current` to `target` (A) through inductance
/// L (H) against the voltage that holds the target, R·target + emf (V); +infinity when the headroom
/// is under kSaturatedHeadroom·Vbus (saturated: the phase lags at the bus).
inline double SlewTime(double current, double target, double hold_voltage, double inductance,
                       double vbus) {
  const double need = target - current;                                      // A
  const double headroom = vbus - (need > 0 ? hold_voltage : -hold_voltage);  // V
  if (!(headroom > kSaturatedHeadroom * vbus)) return std::numeric_limits<double>::infinity();
  return inductance * std::abs(need) / headroom;
}

/// The deadbeat voltage of one phase over an interval whose decay is e^{−aΔ}: the voltage that
/// takes the free end current `free_end` (A, the interval's end with v = 0) to `target`.
inline double DeadbeatVoltage(double target, double free_end, double decay, double resistance) {
  const double gain = (1 - decay) / resistance;  // A/V: d i(Δ)/dv
  return gain > 0 ? (target - free_end) / gain : 0.0;
}

/// A chopper's steady cycle on one phase (SteadyCycle).
struct CycleStats {
  double mean_offset = 0;  ///< A: the cycle's mean current less its target
  double period = 0;       ///< s: one cycle, from an on-phase's start to the next; 0: no cycle
};

/// The steady cycle of one phase of `unit` with target `target` >= 0 (A) and voltage drop `drop` =
/// R·i* + e (V, in the target's sign): the unit's own Switch rules run from its Start on a current
/// that moves at (v − drop)/L between its events, measured over whole cycles (from one on-phase
/// start to a later one) after the first few. No cycle ({0, 0}) for a zero target or a bus that
/// cannot reach the target (saturated).
template <class C>
CycleStats SteadyCycle(const C& unit, double vbus, double inductance, double target, double drop) {
  if (!(target > 0)) return {};
  typename C::State state{};
  const PowerStage stage{.kind = PowerStageKind::kTwoHBridges, .bus_voltage = vbus};
  C::SetTarget(0, target, &state);
  unit.Start(stage, 0.0, &state);
  const PhaseSwitch& sw = state.phase[0];
  // Blocks of kBlockCycles after the first kWarmCycles, until two blocks' means agree within
  // kSettled: near a zero drop the current drifts for hundreds of cycles before it settles (the
  // back-EMF's push, |drop|/L, against the off-time's share of the cycle).
  constexpr int kWarmCycles = 4, kBlockCycles = 8, kMaxEvents = 40000;
  constexpr double kSettled = 1e-6;  // A
  double t = 0, x = target;          // s, A
  double area = 0, from = -1;        // A·s since the block's first cycle's start, at s
  double last_mean = std::numeric_limits<double>::quiet_NaN();  // A, the block before
  int cycles = 0;
  for (int events = 0; events < kMaxEvents; ++events) {
    const double slope = (sw.voltage - drop) / inductance;  // A/s
    double dt = std::numeric_limits<double>::infinity();
    SwitchReason why = SwitchReason::kTime;
    if (sw.has_until != 0) dt = std::max(0.0, sw.until - t);
    if (sw.has_level != 0) {
      // The first τ >= armed_from − t at which direction·(x + slope·τ − level(t + τ)) >= 0, the
      // level moving at level_slope until level_stop.
      const double armed = std::max(0.0, sw.armed_from - t);
      const double stop = std::max(armed, sw.level_stop - t);
      auto gap = [&](double tau) { return sw.direction * (x + slope * tau - sw.LevelAt(t + tau)); };
      double cross = std::numeric_limits<double>::infinity();
      if (gap(armed) >= 0) {
        cross = armed;
      } else {
        const double rate_ramp = sw.direction * (slope - sw.level_slope);  // on [armed, stop]
        const double rate_flat = sw.direction * slope;                     // beyond stop
        const double at_stop = gap(armed) + rate_ramp * (stop - armed);
        if (rate_ramp > 0 && at_stop >= 0) {
          cross = armed - gap(armed) / rate_ramp;
        } else if (rate_flat > 0) {
          cross = stop - std::min(at_stop, 0.0) / rate_flat;
        }
      }
      if (cross < dt) {
        dt = cross;
        why = SwitchReason::kLevel;
      }
    }
    if (!std::isfinite(dt)) return {};  // the current never reaches its comparator: saturated
    if (from >= 0) area += (x + 0.5 * slope * dt) * dt;
    x += slope * dt;
    t += dt;
    const bool was_on = sw.mode == C::kOn;
    unit.Switch(stage, why, 0, t, x, &state);
    if (!was_on && sw.mode == C::kOn) {  // a cycle starts
      ++cycles;
      if (cycles == kWarmCycles) {
        from = t;
        area = 0;
      } else if (cycles > kWarmCycles && (cycles - kWarmCycles) % kBlockCycles == 0) {
        const double mean = area / (t - from);
        const CycleStats stats{.mean_offset = mean - target, .period = (t - from) / kBlockCycles};
        if (std::abs(mean - last_mean) <= kSettled || events + 64 > kMaxEvents) return stats;
        last_mean = mean;
        from = t;
        area = 0;
      }
    }
  }
  return {};  // no steady cycle found within the bound
}

/// The mean of a chopper's steady cycle less its target, A (SteadyCycle's mean_offset): 0 when
/// there is no cycle.
template <class C>
double CycleMeanOffset(const C& unit, double vbus, double inductance, double target, double drop) {
  return SteadyCycle(unit, vbus, inductance, target, drop).mean_offset;
}

/// The fastest steady cycle (Hz) of one phase of `unit` holding a target from a tenth of `peak`
/// to `peak` (A) against a drop within ±Vbus/2, or 0 when none cycles: what a switching drive's
/// torque carries at the chopper's rate, which one torque sample per simulation step folds down
/// unless the step resolves it (h <= 1/(2·f)).
template <class C>
double FastestCycle(const C& unit, double vbus, double inductance, double peak) {
  double fastest = 0;  // Hz
  for (int i = 1; i <= 10; ++i) {
    for (int j = -4; j <= 4; ++j) {
      const CycleStats c = SteadyCycle(unit, vbus, inductance, peak * i / 10, vbus * j / 8);
      if (c.period > 0) fastest = std::max(fastest, 1 / c.period);
    }
  }
  return fastest;
}

/// Where a chopper's cycle mean may sit, less its target (A, in the target's sign):
/// RippleOffsets::BandAt.
struct OffsetBand {
  double low = 0, high = 0;
  /// The nearest point of the band to `current` (A, signed) about table entry `table` (A,
  /// signed): the mean a phase carries that arrives with `current` (0 for a zero entry).
  double Nearest(double table, double current) const {
    if (table == 0) return 0.0;
    const double sign = table > 0 ? 1.0 : -1.0;
    return table + sign * std::clamp(sign * current - std::abs(table), low, high);
  }
};

/// CycleMeanOffset on a grid, computed once at load and read by bilinear interpolation: targets
/// 0..peak (A) and drops −Vbus..Vbus (V). The drop's nodes are fine about 0, where the offset
/// turns over: a drop above 0 decays the current through the off-time, below the target, and a
/// drop below 0 (the back-EMF driving the current up) holds it above, where only the fast decays
/// pull it down. On a TMC2209 at 24 V the offset is −0.0085 A at +0.01 V, −0.009 A at +0.1 V,
/// then falls by 0.006 A per volt; +0.0175 A at −0.01 V and +0.019 A at −0.4 V. A uniform grid of
/// Vbus/16 read −0.0056 A at 0.08 V for the chopper's −0.0088 A, and left the phases near a zero
/// crossing 0.003 A short of it (`Averaged.ThePhasesNearAZeroCrossingCarryTheirChoppersMean`).
class RippleOffsets {
 public:
  RippleOffsets() = default;
  template <class C>
  RippleOffsets(const C& unit, double vbus, double inductance, double peak)
      : vbus_(vbus), peak_(peak) {
    // Vbus/768 within ±Vbus/16, Vbus/16 beyond.
    for (int m = -16; m <= 16; ++m) {
      if (std::abs(m) > 1) drops_.push_back(vbus * m / 16);
    }
    for (int k = -kFineSteps; k <= kFineSteps; ++k) {
      drops_.push_back(vbus / 16 * k / kFineSteps);
    }
    std::sort(drops_.begin(), drops_.end());
    const int n = static_cast<int>(drops_.size());
    offsets_.resize(kTargets * n);
    for (int i = 0; i < kTargets; ++i) {
      for (int j = 0; j < n; ++j) {
        // (The grid's first row, target 0, is a chopper cycling about a target just above 0, as
        // a table entry of 1e-16 A is: a zero target idles the bridge, handled apart.)
        const double target = peak * std::max(static_cast<double>(i), 1e-9) / (kTargets - 1);
        offsets_[i * n + j] = CycleMeanOffset(unit, vbus, inductance, target, drops_[j]);
      }
    }
  }
  /// The offset for a target (signed, A) and the voltage that holds it, R·i* + e (V): in the
  /// target's sign, 0 for a zero target.
  double At(double target, double hold_voltage) const {
    if (offsets_.empty() || target == 0) return 0.0;
    const double sign = target > 0 ? 1.0 : -1.0;
    const double u = std::clamp(std::abs(target) / peak_, 0.0, 1.0) * (kTargets - 1);
    const int i = std::min(static_cast<int>(u), kTargets - 2);
    const int n = static_cast<int>(drops_.size());
    const double drop = std::clamp(sign * hold_voltage, -vbus_, vbus_);  // V
    // The node below the drop: 15 coarse from −Vbus, 2·kFineSteps + 1 fine from −Vbus/16, 15
    // coarse.
    const double band = vbus_ / 16;  // V
    const int j =
        drop < -band ? std::clamp(static_cast<int>((drop + vbus_) / band), 0, kCoarse - 1)
        : drop <= band
            ? kCoarse + std::clamp(static_cast<int>((drop + band) / band * kFineSteps), 0,
                                   2 * kFineSteps - 1)
            : std::min(kCoarse + 2 * kFineSteps + static_cast<int>((drop - band) / band), n - 2);
    const double fu = u - i, fw = (drop - drops_[j]) / (drops_[j + 1] - drops_[j]);
    auto at = [&](int a, int b) { return offsets_[a * n + b]; };
    const double value = (1 - fu) * ((1 - fw) * at(i, j) + fw * at(i, j + 1)) +
                         fu * ((1 - fw) * at(i + 1, j) + fw * at(i + 1, j + 1));
    return sign * value;
  }
  /// The band a phase's cycle mean may sit in, less its target (A, in the target's sign; {0, 0}
  /// for a zero target): from the steady offset at a small positive drop, where the slow decay
  /// brings the current down onto the chopper's cycle, to the one at a small negative drop, where
  /// the fast decays hold it down against the back-EMF; widened to the steady offset at `drop`
  /// itself. Within the band the chopper's actions balance over a cycle and the mean follows the
  /// slow decay's v = 0 course; at its edges they hold it (docs/coupling.md, "The CoreXY after a
  /// move": SpreadCycle's mean lands 0.026 A above its steady cycle after a step down on the
  /// CoreXY's TMC2209 and comes down at (R·i* + e)/L).
  OffsetBand BandAt(double target, double hold_voltage) const {
    if (offsets_.empty() || target == 0) return {};
    const double sign = target > 0 ? 1.0 : -1.0;
    const double steady = sign * At(target, hold_voltage);
    // The drop's nodes beside 0 (±Vbus/768), read on the target's axis alone.
    const double u = std::clamp(std::abs(target) / peak_, 0.0, 1.0) * (kTargets - 1);
    const int i = std::min(static_cast<int>(u), kTargets - 2);
    const int n = static_cast<int>(drops_.size()), zero = kCoarse + kFineSteps;
    auto column = [&](int j) {
      return (1 - (u - i)) * offsets_[i * n + j] + (u - i) * offsets_[(i + 1) * n + j];
    };
    return {.low = std::min(steady, column(zero + 1)), .high = std::max(steady, column(zero - 1))};
  }

 private:
  static constexpr int kTargets = 17;
  static constexpr int kFineSteps = 48;  // per side of the fine band
  static constexpr int kCoarse = 15;  // coarse nodes each side, −Vbus..−Vbus/8 and Vbus/8..Vbus
  double vbus_ = 1, peak_ = 1;
  std::vector<double> drops_;  // V, ascending
  std::vector<double> offsets_;
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_AVERAGED_BRIDGE_H_
