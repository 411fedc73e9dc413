// A peak-current chopper with a fixed off-time or a fixed PWM period and slow, fast or mixed decay:
// the A4988 / DRV8825 class of STEP/DIR drivers (SPEC §8).
//
// Each phase's full bridge, from its own comparator on the sense resistor:
//   on:    v = ±Vbus toward the target's sign until |i| reaches |i*| (the trip point); the
//          comparator is blind for t_blank after the bridge switches on (A4988: "t_BLANK ≈ 1 µs";
//          DRV8825: "fixed at 3.75 µs ... also sets the minimum on time")
//   decay: for t_off (A4988: "fixed off-time ... internally set to 30 µs"), or until the next PWM
//          period starts (DRV8825: "fixed-frequency PWM", f_PWM = 30 kHz), the bridge
//            slow: shorts the winding, v = 0                      di/dt = (−R·i − e)/L
//            fast: reverses, v = −sgn(i)·Vbus, until i reaches 0 ("the bridge is disabled to
//                  prevent any reverse current flow", DRV8825 §8.3.3; here: slow decay from then)
//            mixed: fast for the first part, slow for the rest (A4988: fast "for 31.25 % of the
//                   off-time"; DRV8825: fast until "75 % of the PWM cycle")
//            auto: mixed while the table's current is falling, slow while it rises (both chips'
//                  default: "mixed decay is only necessary when the current ... is going from a
//                  higher value to a lower value as determined by the state of the translator")
//   then on again.
// Sources: Allegro A4988 datasheet (A4988-DS Rev. 6), "Fixed Off-Time", "Blanking", "Mixed Decay
// Operation"; TI DRV8825 datasheet (SLVSA73F, July 2014) §8.3.2-8.3.4 and the electrical
// characteristics (f_PWM 30 kHz, t_BLANK 3.75 µs).
// The bridge is ideal (no dead time, no FET resistance) and the comparator exact; the target is
// the microstep table's entry (step_table.h), the drive's ticks reading the step count.
#ifndef MJSTEPPER_CORE_CONTROLLERS_CONSTANT_OFF_TIME_H_
#define MJSTEPPER_CORE_CONTROLLERS_CONSTANT_OFF_TIME_H_

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "core/controllers/controller.h"
#include "core/controllers/step_table.h"
#include "core/switching.h"

namespace mjstepper {

inline constexpr AttributeSpec kAttrOffTime{
    "off_time", "real", "30e-6 (A4988)", "s",
    "`chopper`: the fixed off-time t_off after each trip (A4988: 30 µs with ROSC tied high or "
    "low; t_off ≈ ROSC/825 µs with a resistor). Ignored when `pwm_frequency` > 0. In [1e-7, "
    "1e-3]."};
inline constexpr AttributeSpec kAttrPwmFrequency{
    "pwm_frequency", "real", "0; 30e3 with `driver` = `drv8825`", "Hz",
    "`chopper`: 0 for a fixed off-time; > 0 for a fixed-frequency chopper whose period restarts "
    "the on phase (DRV8825: 30 kHz). At most 1 MHz."};
inline constexpr AttributeSpec kAttrBlankTime{
    "blank_time", "real", "1e-6 (A4988); 3.75e-6 with `driver` = `drv8825`", "s",
    "`chopper`: the comparator is blind for this long after the bridge switches on, which is "
    "also the least on-time (A4988 ≈ 1 µs, DRV8825 3.75 µs). In [0, 1e-4]."};
inline constexpr AttributeSpec kAttrDecay{
    "decay", "name", "`auto`", "—",
    "`chopper`: `slow` (winding shorted), `fast` (bridge reversed until the current reaches 0), "
    "`mixed` (fast, then slow), or `auto` (mixed while the table's current falls, slow while it "
    "rises: both chips' default)."};
inline constexpr AttributeSpec kAttrFastFraction{
    "fast_fraction", "real", "0.3125 (A4988); 0.75 with `driver` = `drv8825`", "—",
    "`chopper`: the fast part of mixed decay, as a fraction of the off-time (A4988: 31.25 %) or "
    "of the PWM period (DRV8825: fast until 75 % of the period). In [0, 1]."};

struct ConstantOffTime {
  static constexpr const char* kName = "chopper";
  static constexpr const char* kSummary =
      "STEP/DIR chopper of the A4988/DRV8825 class, SPEC §8: each phase's bridge at ±Vbus until "
      "the current trips at the microstep table's target, then a fixed off-time (or the rest of a "
      "fixed PWM period) in slow, fast or mixed decay; switched event by event on the exact "
      "winding solution.";
  static constexpr SpeedFeedback kDefaultSpeedFeedback = SpeedFeedback::kExact;
  static constexpr const char* kStiffnessFormula = "Nr·Km·I, T(1), I = √2·run_current";
  static constexpr bool kCountsSlips = true;
  static constexpr bool kSwitching = true;

  // PhaseSwitch::mode: the phase of the chopper cycle.
  static constexpr double kOn = 0, kFast = 1, kSlow = 2;
  static constexpr double kIdle = 3;  // a zero target: the bridge lets the current decay to 0
  enum class Decay { kSlow, kFast, kMixed, kAuto };

  MicrostepTable table;
  double off_time = 30e-6;   ///< t_off, s
  double pwm_frequency = 0;  ///< Hz; 0: fixed off-time
  double blank_time = 1e-6;  ///< t_blank, s
  Decay decay = Decay::kAuto;
  double fast_fraction = 0.3125;  ///< of t_off (or of the PWM period)

  struct State {
    std::array<PhaseSwitch, 2> phase;
    MicrostepTable::Counter counter;
  };
  using Input = Sample;

  static std::vector<const AttributeSpec*> Attributes() {
    std::vector<const AttributeSpec*> list = MicrostepTable::Attributes();
    list.insert(list.end(), {&kAttrOffTime, &kAttrPwmFrequency, &kAttrBlankTime, &kAttrDecay,
                             &kAttrFastFraction});
    return list;
  }
  static ConstantOffTime FromAttributes(const AttributeSource& a, const MotorParams& motor,
                                        const DriveConstants&) {
    ConstantOffTime c;
    // An A4988 or DRV8825 (driver_chip.h) sets the timing defaults; none: the A4988's.
    const DriverChip* chip = FindDriver(a);
    if (chip != nullptr && chip->clock_frequency > 0) {
      ThrowBad(kAttrDriver, chip->name,
               "is a Trinamic chip: use drive = spreadcycle (or stealthchop)");
    }
    if (chip != nullptr) {
      c.off_time = chip->off_time > 0 ? chip->off_time : c.off_time;
      c.pwm_frequency = chip->pwm_frequency;
      c.blank_time = chip->blank_time;
      c.fast_fraction = chip->fast_fraction;
    }
    c.table = MicrostepTable::FromAttributes(a, motor, /*interpolate_by_default=*/false);
    c.off_time = a.Real(kAttrOffTime, c.off_time, 1e-7, 1e-3);
    c.pwm_frequency = a.Real(kAttrPwmFrequency, c.pwm_frequency, 0.0, 1e6);
    c.blank_time = a.Real(kAttrBlankTime, c.blank_time, 0.0, 1e-4);
    const std::string decay = a.Choice(kAttrDecay, "auto", {"slow", "fast", "mixed", "auto"});
    c.decay = decay == "slow"    ? Decay::kSlow
              : decay == "fast"  ? Decay::kFast
              : decay == "mixed" ? Decay::kMixed
                                 : Decay::kAuto;
    c.fast_fraction = a.Real(kAttrFastFraction, c.fast_fraction, 0.0, 1.0);
    return c;
  }

  /// At each tick: the step count → the table's targets (the comparators' trip points).
  /// A STEP edge (input = steps) at tick label `tick`, the count now `count`: the phases' new
  /// targets at once (step_table.h, EdgeTargets), A.
  TickOutput Edge(const DriveConstants& k, double count, double tick, double current_scale,
                  const PowerStage&, State* s) const {
    return {.bridge = {},
            .current_ref = table.EdgeTargets(k, count, tick, current_scale, &s->counter)};
  }

  TickOutput Tick(const DriveConstants& k, const Input& in, const PowerStage&, State* s) const {
    return {.bridge = {}, .current_ref = table.TickTargets(k, in, &s->counter)};
  }

  /// At rest on the table's entry at θcmd; each phase starts on, its comparator armed at once.
  PhaseVector Rest(const DriveConstants& k, const RestInput& in, State* s) const {
    *s = {};
    const PhaseVector target = table.RestTargets(k, in.theta_cmd, &s->counter);
    s->phase[0].target = target.real();
    s->phase[1].target = target.imag();
    return target;
  }
  double HoldingStiffness(const DriveConstants& k, PhaseVector rest_current) const {
    return OpenLoopStiffness(k, rest_current);
  }

  /// The bridges at rest at time t (s): each phase on, its comparator armed at once (the current
  /// is at its trip point), so the chopper cycle starts at t.
  void Start(const PowerStage& stage, double t, State* s) const {
    for (PhaseSwitch& sw : s->phase) {
      StartOn(t, /*restart=*/true, stage.bus_voltage, &sw);
      sw.armed_from = t;
    }
  }

  /// Phase `p`'s bridge decides again at time t (s) with the phase current `current` (A).
  void Switch(const PowerStage& stage, SwitchReason why, int p, double t, double current,
              State* s) const {
    PhaseSwitch& sw = s->phase[p];
    const double vbus = stage.bus_voltage;  // V
    switch (why) {
      case SwitchReason::kTarget:
        // A new trip point; in decay the off-time runs on (SetTarget noted whether the table's
        // current falls, for auto decay). An idle bridge starts again on a target that is not 0.
        if (sw.mode == kOn || (sw.mode == kIdle && sw.target != 0)) {
          StartOn(t, /*restart=*/sw.mode == kIdle, vbus, &sw);
        } else if (sw.target == 0 && sw.mode != kIdle) {
          IdleBridge(kIdle, t, current, vbus, &sw);
        }
        return;
      case SwitchReason::kLevel:
        if (sw.mode == kOn) {
          StartDecay(t, current, vbus, &sw);
        } else {  // fast decay reached zero current: the bridge stops reversing it
          sw.voltage = 0;
          sw.has_level = 0;
          if (sw.mode != kIdle) {
            sw.mode = kSlow;
            sw.until = DecayEnd(sw);
          }
        }
        return;
      case SwitchReason::kTime:
        if (sw.mode == kFast && sw.until < DecayEnd(sw)) {  // mixed: the fast part is over
          sw.mode = kSlow;
          sw.voltage = 0;
          sw.has_level = 0;
          sw.until = DecayEnd(sw);
        } else {  // the off-time (or the PWM period) is over; or a PWM period starts while on
          StartOn(t, /*restart=*/true, vbus, &sw);
        }
        return;
    }
  }

  /// Called by the drive when a tick's targets reach the phases (before Switch(kTarget)).
  static void SetTarget(int p, double target, State* s) {
    PhaseSwitch& sw = s->phase[p];
    sw.aux = std::abs(target) < std::abs(sw.target) ? 1.0 : 0.0;  // 1: falling
    sw.target = target;
  }

 private:
  // The end of the current decay: mode_start + t_off, or the end of the PWM period.
  double DecayEnd(const PhaseSwitch& sw) const {
    return pwm_frequency > 0 ? PeriodEnd(sw.mode_start) : sw.mode_start + off_time;
  }
  // The end of the fixed-frequency PWM period holding time t: the next multiple of 1/f_PWM.
  double PeriodEnd(double t) const {
    const double period = 1 / pwm_frequency;  // s
    return (std::floor(t * pwm_frequency + 1e-9) + 1) * period;
  }

  void StartOn(double t, bool restart, double vbus, PhaseSwitch* sw) const {
    if (sw->target == 0) return IdleBridge(kIdle, t, 0.0, vbus, sw);
    const double sign = sw->target >= 0 ? 1.0 : -1.0;
    sw->mode = kOn;
    sw->voltage = sign * vbus;
    sw->has_level = 1;
    sw->direction = sign;
    sw->level = sw->target;
    sw->level_slope = 0;
    if (restart) {
      sw->mode_start = t;
      sw->armed_from = t + blank_time;
    }
    // A fixed-frequency chopper starts each period on, whatever the comparator did.
    sw->has_until = pwm_frequency > 0 ? 1 : 0;
    if (pwm_frequency > 0) sw->until = PeriodEnd(sw->mode_start);
  }

  void StartDecay(double t, double current, double vbus, PhaseSwitch* sw) const {
    sw->mode_start = t;
    const double end = DecayEnd(*sw);  // s
    const bool mixed = decay == Decay::kMixed || (decay == Decay::kAuto && sw->aux != 0);
    double fast_end = t;  // s
    if (decay == Decay::kFast) {
      fast_end = end;
    } else if (mixed) {
      fast_end = pwm_frequency > 0 ? PeriodEnd(t) - (1 - fast_fraction) / pwm_frequency
                                   : t + fast_fraction * off_time;
    }
    sw->has_until = 1;
    if (fast_end > t && current != 0) {  // fast decay: reversed, until i = 0 or the fast part ends
      sw->mode = kFast;
      sw->voltage = current > 0 ? -vbus : vbus;
      sw->until = std::min(fast_end, end);
      sw->has_level = 1;
      sw->direction = current > 0 ? -1 : 1;
      sw->level = 0;
      sw->level_slope = 0;
      sw->armed_from = t;
    } else {
      sw->mode = kSlow;
      sw->voltage = 0;
      sw->until = end;
      sw->has_level = 0;
    }
  }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_CONSTANT_OFF_TIME_H_
