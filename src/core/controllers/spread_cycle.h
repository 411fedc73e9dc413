// Trinamic's SpreadCycle chopper (TMC2209/2130/5160, SPEC §8): a hysteresis chopper with a fixed
// slow-decay time, fed by STEP/DIR through the microstep table (step_table.h).
//
// Each phase's bridge runs the four phases of a chopper cycle (TMC2209 datasheet Rev. 1.09 §7.1
// "SpreadCycle Chopper": "Each chopper cycle is comprised of an on phase, a slow decay phase, a
// fast decay phase and a second slow decay phase"):
//   on:    v = ±Vbus until |i| reaches |i*| + H(t)            (the comparator blind for t_BLANK)
//   slow:  v = 0 for t_OFF                                       di/dt = (−R·i − e)/L
//   fast:  v = ∓Vbus until |i| falls to |i*| − H(t)          (the comparator blind for t_BLANK)
//   slow:  v = 0 for t_OFF, then the next cycle's on phase.
// The timing, in clocks of f_CLK (datasheet §7.1, register CHOPCONF):
//   t_OFF   = (24 + 32·TOFF)/f_CLK        (TMC2130: 12 + 32·TOFF), TOFF 1..15
//   t_BLANK = TBL clocks: 16/24/32/40 (TMC2209), 16/24/36/54 (TMC2130/5160)
// The hysteresis H starts each cycle at HSTRT + HEND and falls by one unit every 16 clocks down
// to HEND (§7.1: "Hysteresis decrement is done each 16 clocks"), in effective values HSTRT 1..8
// (register 0..7) and HEND −3..12 (register 0..15), with HSTRT + HEND ≤ 16. "1/512 of this
// setting adds to current setting": one unit is 1/512 of the current scale's full range, whose
// sine peak is 248/256 of it (the MSLUT's amplitude), so one unit = I_peak/496 A here. That is
// our reading of the register description; the datasheet gives no formula in amperes. The
// staircase is modelled by its line (the level moves 1 unit per 16 clocks continuously), which
// is within one unit of it.
// A zero table entry idles the bridge as in constant_off_time.h. The bridge is ideal (no dead
// time, no MOSFET resistance) and the comparator exact.
#ifndef MJSTEPPER_CORE_CONTROLLERS_SPREAD_CYCLE_H_
#define MJSTEPPER_CORE_CONTROLLERS_SPREAD_CYCLE_H_

#include <array>
#include <cmath>
#include <string>

#include "core/controllers/controller.h"
#include "core/controllers/driver_chip.h"
#include "core/controllers/step_table.h"
#include "core/sensors/stallguard.h"
#include "core/switching.h"

namespace mjstepper {

inline constexpr AttributeSpec kAttrToff{
    "toff", "integer", "the chip's (Klipper: 3 on TMC2209/5160, 4 on TMC2130)", "—",
    "`spreadcycle`: TOFF, the slow-decay time t_OFF = (24 + 32·TOFF)/f_CLK (TMC2130: 12 + "
    "32·TOFF). In [1, 15]; 1 only with `tbl` ≥ 2."};
inline constexpr AttributeSpec kAttrTbl{
    "tbl", "integer", "the chip's (Klipper: 2; 1 on TMC2130)", "—",
    "`spreadcycle`: TBL, the comparator blank time: 16, 24, 32, 40 clocks (TMC2209) or 16, 24, "
    "36, 54 (TMC2130/5160) for 0..3. In [0, 3]."};
inline constexpr AttributeSpec kAttrHstrt{
    "hstrt", "integer", "the chip's (Klipper: 5; 0 on TMC2130)", "—",
    "`spreadcycle`: HSTRT register 0..7, adding 1..8 units to HEND at each cycle's start; the "
    "effective HSTRT + HEND ≤ 16. One unit is 1/512 of the current scale (I_peak/496)."};
inline constexpr AttributeSpec kAttrHend{
    "hend", "integer", "the chip's (Klipper: 0 on TMC2209, 7 on TMC2130, 2 on TMC5160)", "—",
    "`spreadcycle`: HEND register 0..15, the hysteresis −3..12 units the cycle ends at."};
struct SpreadCycle {
  static constexpr const char* kName = "spreadcycle";
  static constexpr const char* kSummary =
      "Trinamic SpreadCycle (TMC2209/2130/5160), SPEC §8: per phase on to the microstep table's "
      "target plus a decaying hysteresis, slow decay t_OFF, fast decay to the target minus it, "
      "slow decay t_OFF; switched event by event on the exact winding solution.";
  static constexpr SpeedFeedback kDefaultSpeedFeedback = SpeedFeedback::kExact;
  static constexpr const char* kStiffnessFormula = "Nr·Km·I, T(1), I = √2·run_current";
  static constexpr bool kCountsSlips = true;
  static constexpr bool kSwitching = true;

  // PhaseSwitch::mode: the phase of the chopper cycle; mode_start: the cycle's start (s), from
  // which the hysteresis decrements; aux: the cycle's polarity, the sign of its target (±1).
  static constexpr double kOn = 0, kSlow = 1, kFast = 2, kSlowAgain = 3;
  static constexpr double kIdle = 4;  // a zero target: the bridge lets the current decay to 0

  MicrostepTable table;
  double off_time = 0;          ///< t_OFF, s
  double blank_time = 0;        ///< t_BLANK, s
  double hysteresis_start = 0;  ///< HSTRT + HEND, units
  double hysteresis_end = 0;    ///< HEND, units
  double decrement_time = 0;    ///< s per hysteresis unit: 16/f_CLK
  StallGuard stallguard;        ///< StallGuard2 and CoolStep on TMC2130/5160; none on TMC2209

  struct State {
    std::array<PhaseSwitch, 2> phase;
    MicrostepTable::Counter counter;
  };
  using Input = Sample;

  static std::vector<const AttributeSpec*> Attributes() {
    std::vector<const AttributeSpec*> list = MicrostepTable::Attributes();
    list.insert(list.end(), {&kAttrToff, &kAttrTbl, &kAttrHstrt, &kAttrHend, &kAttrClockFrequency});
    for (const AttributeSpec* spec : StallGuard::Attributes()) list.push_back(spec);
    return list;
  }
  static SpreadCycle FromAttributes(const AttributeSource& a, const MotorParams& motor,
                                    const DriveConstants&) {
    const DriverChip* given = FindDriver(a);
    const DriverChip* chip = given != nullptr ? given : &DriverChips().front();  // TMC2209's
    if (chip->clock_frequency == 0) {
      ThrowBad(kAttrDriver, chip->name,
               "has no SpreadCycle (a constant-off-time chopper): use drive = chopper");
    }
    SpreadCycle c;
    const double f_clk = a.Real(kAttrClockFrequency, chip->clock_frequency, 4e6, 2e7);  // Hz
    c.table = MicrostepTable::FromAttributes(a, motor, chip->interpolate, f_clk);
    const int toff = a.Integer(kAttrToff, chip->toff, 1, 15);
    const int tbl = a.Integer(kAttrTbl, chip->tbl, 0, 3);
    // A pair that does not go together is blamed on the value the user wrote (issue 33: with
    // only hend set, the message named hstrt = 5, the chip's default), the other quoted with its
    // origin.
    auto origin = [&](const AttributeSpec& spec) {
      return a.Raw(spec) ? "" : fmt::format(", the {} default", chip->name);
    };
    if (toff == 1 && tbl < 2) {
      const bool blame_tbl = a.Raw(kAttrTbl) && !a.Raw(kAttrToff);
      ThrowBad(blame_tbl ? kAttrTbl : kAttrToff, std::to_string(blame_tbl ? tbl : toff),
               blame_tbl ? fmt::format("toff = 1{} needs tbl >= 2", origin(kAttrToff))
                         : fmt::format("needs tbl >= 2 (tbl = {}{})", tbl, origin(kAttrTbl)));
    }
    const int hstrt = a.Integer(kAttrHstrt, chip->hstrt, 0, 7) + 1;  // 1..8
    const int hend = a.Integer(kAttrHend, chip->hend, 0, 15) - 3;    // −3..12
    if (hstrt + hend > 16) {
      const bool blame_hend = a.Raw(kAttrHend) && !a.Raw(kAttrHstrt);
      ThrowBad(
          blame_hend ? kAttrHend : kAttrHstrt, std::to_string(blame_hend ? hend + 3 : hstrt - 1),
          fmt::format("the effective HSTRT + HEND = {} + {} must be <= 16 ({} = {}{}); "
                      "lower hstrt or hend",
                      hstrt, hend, blame_hend ? "hstrt" : "hend", blame_hend ? hstrt - 1 : hend + 3,
                      origin(blame_hend ? kAttrHstrt : kAttrHend)));
    }
    c.off_time = (chip->off_time_base + 32.0 * toff) / f_clk;
    c.blank_time = chip->blank_clocks[tbl] / f_clk;
    c.hysteresis_start = hstrt + hend;
    c.hysteresis_end = hend;
    c.decrement_time = 16 / f_clk;
    c.stallguard = StallGuard::FromAttributes(a, given != nullptr ? given->stallguard_spread : 0);
    return c;
  }

  /// One hysteresis unit, A: 1/512 of the full scale, whose sine peak is 248/256 of it.
  double HysteresisUnit() const { return table.peak_current / 496; }

  /// At each tick: the step count → the table's targets, scaled by CoolStep.
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

  /// At rest on the table's entry at θcmd.
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

  /// The bridges at rest at time t (s): each phase starts a cycle's on phase, its comparator
  /// armed at once (the current sits at the target).
  void Start(const PowerStage& stage, double t, State* s) const {
    for (PhaseSwitch& sw : s->phase) {
      StartCycle(t, stage.bus_voltage, &sw);
      if (sw.mode != kOn) continue;  // a zero target: the bridge idles, no comparator
      sw.armed_from = t;
      SetLevel(&sw);
    }
  }

  /// Phase `p`'s bridge decides again at time t (s) with the phase current `current` (A).
  void Switch(const PowerStage& stage, SwitchReason why, int p, double t, double current,
              State* s) const {
    PhaseSwitch& sw = s->phase[p];
    const double vbus = stage.bus_voltage;  // V
    switch (why) {
      case SwitchReason::kTarget:
        if (sw.target == 0) {
          if (sw.mode != kIdle) IdleBridge(kIdle, t, current, vbus, &sw);
        } else if (sw.mode == kIdle) {
          StartCycle(t, vbus, &sw);
        } else if ((sw.target > 0 ? 1.0 : -1.0) != sw.aux) {
          StartCycle(t, vbus, &sw);  // the target changed sign: a new cycle toward it at once
        } else if (sw.mode == kOn || sw.mode == kFast) {
          SetLevel(&sw);  // the comparator follows the new target
        }
        return;
      case SwitchReason::kLevel:
        if (sw.mode == kOn || sw.mode == kFast) {  // the comparator tripped: slow decay
          sw.mode = sw.mode == kOn ? kSlow : kSlowAgain;
          sw.voltage = 0;
          sw.has_level = 0;
          sw.has_until = 1;
          sw.until = t + off_time;
        } else {  // idle: the decay reached zero current
          sw.voltage = 0;
          sw.has_level = 0;
        }
        return;
      case SwitchReason::kTime:
        if (sw.mode == kSlow) {  // fast decay toward the target less the hysteresis
          sw.mode = kFast;
          sw.voltage = -sw.aux * vbus;
          sw.has_until = 0;
          sw.armed_from = t + blank_time;
          SetLevel(&sw);
        } else {  // the second slow decay is over: the next cycle
          StartCycle(t, vbus, &sw);
        }
        return;
    }
  }

  /// Called by the drive when a tick's targets reach the phases (before Switch(kTarget)).
  static void SetTarget(int p, double target, State* s) { s->phase[p].target = target; }

 private:
  // A new chopper cycle at t: on toward the target's sign, the hysteresis restarting.
  void StartCycle(double t, double vbus, PhaseSwitch* sw) const {
    if (sw->target == 0) return IdleBridge(kIdle, t, 0.0, vbus, sw);
    sw->mode = kOn;
    sw->mode_start = t;
    sw->aux = sw->target > 0 ? 1.0 : -1.0;
    sw->voltage = sw->aux * vbus;
    sw->has_until = 0;
    sw->armed_from = t + blank_time;
    SetLevel(sw);
  }

  // The comparator of the on or fast phase: |i*| ± H(t) in the target's sign, H falling one unit
  // per decrement_time from hysteresis_start at the cycle's start to hysteresis_end.
  void SetLevel(PhaseSwitch* sw) const {
    const double sign = sw->aux;
    const double side = sw->mode == kOn ? 1.0 : -1.0;  // above the target on, below it in fast
    const double unit = HysteresisUnit();              // A
    const double start = sw->mode_start;               // s, the cycle's
    const double ramp_end = start + (hysteresis_start - hysteresis_end) * decrement_time;  // s
    const double elapsed = std::clamp(sw->armed_from - start, 0.0, ramp_end - start);      // s
    const double h = hysteresis_start - elapsed / decrement_time;  // units at armed_from
    sw->has_level = 1;
    sw->direction = side * sign;
    sw->level = sw->target + side * sign * unit * h;
    sw->level_slope = -side * sign * unit / decrement_time;
    sw->level_stop = ramp_end;
  }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_SPREAD_CYCLE_H_
