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
// What the average leaves out: the ripple itself (its RMS, ΔI/√12, a few % of the copper loss at
// standstill) and the mean offset of a peak-current chopper's ripple (its decay after the peak).
#ifndef MJSTEPPER_CORE_AVERAGED_BRIDGE_H_
#define MJSTEPPER_CORE_AVERAGED_BRIDGE_H_

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/motor.h"
#include "core/power_stage.h"

namespace mjstepper {

/// Electrical rotation (rad) an averaged interval spans at most.
inline constexpr double kAveragedRotation = 0.5;

/// The most intervals one step spends following a command that moves more than this many
/// microsteps in it (a jump, not a motion): it is read in that many.
inline constexpr double kMaxAveragedReads = 1000;

/// A phase counts as on its target within this fraction of the bus's current scale (Vbus/R).
inline constexpr double kOnTargetFraction = 1e-9;

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

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_AVERAGED_BRIDGE_H_
