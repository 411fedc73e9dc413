// The microstep table of a STEP/DIR driver (SPEC §8): the current target of each phase at the
// driver's step position, shared by the chopper drives (constant_off_time.h, spread_cycle.h) and
// StealthChop (stealth_chop.h).
//
// The driver's position is an integer count of microsteps at `microsteps` per full step; one
// electrical cycle is 4 full steps (S-1), so count n points the current vector at the electrical
// angle ψ = n·(π/2)/microsteps, and the drive's θcmd at n·2π/(4·Nr·microsteps) (input = steps).
// The vector's components are the table's entries at ψ (the MSLUT of Trinamic's drivers: by
// default a sine, 1024 entries per electrical cycle; a custom quarter wave as an attribute):
//   ia* = I_peak·T(ψ + π/2),   ib* = I_peak·T(ψ),   T(ψ) = sin ψ by default          (S-10 at id)
// With interpolation (Trinamic's MicroPlyer, TMC2209 datasheet §"MicroPlyer"), a step arriving
// after an interval Δ since the one before is spread over the next Δ in 1/256 full steps: the
// vector lags the count by up to one step interval and follows it exactly only at an even rate.
//
// Standstill current (SPEC §12; TMC2209 datasheet Rev. 1.09 §5.1 IHOLD_IRUN and TPOWERDOWN, the
// same fields on TMC2130 and TMC5160; DRV_STATUS.stst): a Trinamic chip detects standstill 2^20
// clocks after the last step, waits TPOWERDOWN·2^18 clocks more, then lowers the current scale
// CS from IRUN to IHOLD one step every IHOLDDELAY·2^18 clocks (0: at once); the next step
// restores IRUN at once (no power-up ramp on these chips). The current is (CS+1)/32 of the full
// scale, so (CS+1)/(IRUN+1) of run_current. Our reading of "delay per current reduction step":
// each step waits its delay, the first IHOLDDELAY·2^18 clocks after TPOWERDOWN expired.
#ifndef MJSTEPPER_CORE_CONTROLLERS_STEP_TABLE_H_
#define MJSTEPPER_CORE_CONTROLLERS_STEP_TABLE_H_

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "core/controllers/controller.h"
#include "core/controllers/driver_chip.h"

namespace mjstepper {

inline constexpr AttributeSpec kAttrMicrosteps{
    "microsteps", "integer",
    "0 (`current_microstep`, `ideal_current`); 16 (chopper drives; every `driver` chip: the MS "
    "pins' 1/16 of printer boards, Klipper's usual `microsteps: 16`)",
    "per full step",
    "The resolution of the commanded current vector, as a real driver's setting (MRES): 1 full "
    "step, 2 half step, ... 256; ψ is rounded to multiples of (π/2)/microsteps. With `input` = "
    "`steps`, ctrl counts these. 0 (Tsui's drives only): continuous, the ideal sine of T(12)."};

inline constexpr AttributeSpec kAttrRunCurrent{
    "run_current", "real", "the motor's rated current", "A (RMS)",
    "Phase current of the chopper and StealthChop drives as Klipper and Trinamic state it: the "
    "RMS of the sine, so the table's peak is √2·run_current. The default, the datasheet's rated "
    "current I_r, gives the rated holding torque √2·Km·I_r and the rated copper loss 2·R·I_r² "
    "(both phases at I_r, full step), or, with a `driver` chip, the most the chip's sense resistor "
    "regulates if that is less. A chip rounds it to its own steps (TMC: CS and vsense, or "
    "GLOBALSCALER), and refuses a request beyond its most or more than 10 % from any step; > 0."};

inline constexpr AttributeSpec kAttrInterpolate{
    "interpolate", "name", "`on` (TMC drives), `off` (A4988/DRV8825 class)", "—",
    "`on`: MicroPlyer, each step spread over the interval since the step before in 1/256 full "
    "steps (lags by up to one step interval); `off`: the table entry of the count itself."};

inline constexpr AttributeSpec kAttrCurrentTable{
    "current_table", "list", "sine", "— (fraction of peak)",
    "A custom microstep table: one quarter wave, `microsteps` + 1 entries from 0 (at a phase's "
    "zero) to 1 (at its peak), each in [0, 1], blanks or commas between them; the other quarters "
    "mirror it. Unset: an exact sine."};

inline constexpr AttributeSpec kAttrIhold{
    "ihold", "integer", "IRUN (no reduction: Klipper's default)", "— (current scale CS)",
    "Trinamic drives (`spreadcycle`, `stealthchop`): IHOLD, the current scale at standstill, "
    "(IHOLD+1)/(IRUN+1) of `run_current`; IRUN is the scale the chip sets `run_current` with "
    "(31 on TMC5160, whose GLOBALSCALER does the rest; TMC2209/2130 by their sense resistor). "
    "PAROL6's firmware: IHOLD = IRUN·0.7-0.88. The current falls to it after standstill (2^20 "
    "clocks without a step), `tpowerdown` and the `iholddelay` ramp; the next step restores "
    "IRUN. In [0, IRUN]."};
inline constexpr AttributeSpec kAttrIholddelay{
    "iholddelay", "integer", "the chip's (Klipper: 8 on TMC2209/2130, 6 on TMC5160)",
    "— (2^18 clocks)",
    "Trinamic drives: IHOLDDELAY, the power-down ramp's time per current-scale step, "
    "IHOLDDELAY·2^18/f_CLK (21.8 ms each at 12 MHz); 0: at once. In [0, 15]."};
inline constexpr AttributeSpec kAttrTpowerdown{
    "tpowerdown", "integer", "the chip's (Klipper: 20 on TMC2209, 0 on TMC2130, 10 on TMC5160)",
    "— (2^18 clocks)",
    "Trinamic drives: TPOWERDOWN, the delay from standstill detection to the power-down ramp, "
    "TPOWERDOWN·2^18/f_CLK (0-5.6 s at 12 MHz). In [0, 255]."};

/// The standstill current reduction of a Trinamic chip (see the file comment). Timings in s.
struct PowerDown {
  int irun = 31;        ///< IRUN, the run current's scale
  int ihold = 31;       ///< IHOLD; >= irun: no reduction
  double detect = 0;    ///< s from the last step to standstill detection: 2^20/f_CLK
  double delay = 0;     ///< s from then to the ramp: TPOWERDOWN·2^18/f_CLK
  double per_step = 0;  ///< s per current-scale step of the ramp: IHOLDDELAY·2^18/f_CLK

  bool Reduces() const { return ihold < irun; }
  /// The fraction of run_current after `idle` s without a step.
  double Scale(double idle) const {
    if (!Reduces()) return 1.0;
    const double ramp = idle - detect - delay;  // s into the ramp
    if (!(ramp >= 0)) return 1.0;
    const double down = per_step > 0 ? std::floor(ramp / per_step) : irun;  // steps taken
    const double cs = std::max<double>(ihold, irun - down);
    return (cs + 1) / (irun + 1);
  }
  /// The fraction after a standstill for ever (a drive at rest from its start).
  double HoldScale() const { return Reduces() ? (ihold + 1.0) / (irun + 1.0) : 1.0; }
};

/// The table and the step counter of a STEP/DIR driver.
struct MicrostepTable {
  double peak_current = 2.0;    ///< A, √2·run_current
  int microsteps = 16;          ///< per full step (MRES), 1..256
  bool interpolate = true;      ///< MicroPlyer to 256
  std::vector<double> quarter;  ///< custom quarter wave (microsteps + 1 entries); empty: sine
  PowerDown power_down;         ///< standstill current (Trinamic chips); none by default

  /// What the table keeps between ticks (plain doubles, in the unit's state).
  struct Counter {
    double count = 0;        ///< the count at the last tick (microsteps)
    double from = 0;         ///< the count the interpolation starts from (microsteps)
    double change_tick = 0;  ///< the tick at which `count` last changed (kLongAgo at rest)
    double interval = 0;     ///< ticks between the last two changes (≥ 1); 0: none yet
  };

  /// The count n of a commanded angle θcmd (rad): round(Nr·θcmd/(π/2)·microsteps) (S-1).
  double Count(const DriveConstants& k, double theta_cmd) const {
    return std::round(k.rotor_teeth * theta_cmd / (std::numbers::pi / 2) * microsteps);
  }

  /// MicroPlyer measures the step interval with a 2^20-clock counter (TMC2209 datasheet,
  /// "MicroPlyer"): a longer interval (a start from standstill) is not spread. 2^20/f_CLK of the
  /// chip's clock (12 MHz; 13.2 MHz on a TMC2130), s.
  double max_interpolated_interval = 1048576.0 / 12e6;

  /// The position (in microsteps, fractional with interpolation: multiples of microsteps/256)
  /// at tick `tick` (every T = k.isr_period; fractional at a STEP edge between two ticks), given
  /// the count there; updates the counter.
  double Position(const DriveConstants& dk, double count, double tick, Counter* c) const {
    const double k = tick;
    if (!interpolate || microsteps >= 256) {
      if (count != c->count) c->change_tick = k;  // for the standstill current
      c->count = c->from = count;
      return count;
    }
    if (count != c->count) {  // a step (or several) since the last tick: MicroPlyer restarts
      // The first step, and one after a standstill longer than the counter, is not spread.
      const double since = k - c->change_tick;  // ticks
      // (Between STEP edges, which are events of their own, the interval may be a fraction of a
      // tick; between ticks it is a whole number of them.)
      c->interval =
          c->interval > 0 && since > 0 && since * dk.isr_period <= max_interpolated_interval ? since
                                                                                             : 1.0;
      c->from = c->count;
      c->count = count;
      c->change_tick = k;
    }
    // Clamped below too: a tick label that went back (time moved back under the drive) must
    // not extrapolate the position the wrong way.
    const double progress =
        c->interval > 0 ? std::clamp((k - c->change_tick) / c->interval, 0.0, 1.0) : 1.0;
    const double position = c->from + (c->count - c->from) * progress;  // microsteps
    const double fine = 256.0 / microsteps;                             // 1/256 per microstep
    return std::round(position * fine) / fine;
  }

  /// A STEP/DIR unit's tick: the count of θcmd → the (interpolated) position → the phase targets,
  /// scaled by CoolStep (Sample::current_scale), A.
  PhaseVector TickTargets(const DriveConstants& k, const Sample& in, Counter* c) const {
    const double count = Count(k, in.command.theta);
    const double position = Position(k, count, in.tick, c);
    return in.current_scale * StandstillScale(k, in.tick, *c) * Targets(position);
  }

  /// The standstill current's fraction of run_current at tick `tick` (PowerDown), 1 while moving.
  double StandstillScale(const DriveConstants& k, double tick, const Counter& c) const {
    if (!power_down.Reduces()) return 1.0;
    return power_down.Scale((tick - c.change_tick) * k.isr_period);
  }

  /// A STEP edge at tick label `tick` (fractional: between two interrupts) that brings the count
  /// to `count`: the chip's microstep counter moves on the edge itself (TMC2209 datasheet Rev. 1.09
  /// §13.3, "for each active edge on STEP"; the A4988's and DRV8825's translators likewise), so
  /// the targets follow at once, scaled by CoolStep (`current_scale`) and the standstill current.
  PhaseVector EdgeTargets(const DriveConstants& k, double count, double tick, double current_scale,
                          Counter* c) const {
    const double position = Position(k, count, tick, c);
    return current_scale * StandstillScale(k, tick, *c) * Targets(position);
  }

  /// At rest at θcmd (rad), stood still for ever: the counter on its count; the phase targets
  /// there, at the standstill current, A.
  PhaseVector RestTargets(const DriveConstants& k, double theta_cmd, Counter* c) const {
    c->count = c->from = Count(k, theta_cmd);
    c->change_tick = kLongAgo;
    return power_down.HoldScale() * Targets(c->count);
  }

  /// The tick of a drive's last step when it has stood still for ever (finite: stored states are
  /// checked finite): 2^52 ticks back, 7 000 years at 50 µs.
  static constexpr double kLongAgo = -4503599627370496.0;

  /// T(ψ) for position p in microsteps: the quarter wave mirrored (sine by default), as a chip's
  /// quarter-wave table is, so that its zeros are exact zeros at every half cycle (sin π in
  /// doubles is 1.2e-16: a phase "at 0" there would regulate 3e-16 A instead of idling).
  double Entry(double position) const {
    const double quarter_steps = static_cast<double>(microsteps);
    double r = std::fmod(position, 4 * quarter_steps);
    // A position that is not finite comes only from a stored state that is not (a user's write):
    // NaN on, for the drive's check after the step to find, not an int cast of NaN (undefined;
    // found by drive_fuzz, issue 33).
    if (!std::isfinite(r)) return r;
    if (r < 0) r += 4 * quarter_steps;
    const int quadrant = std::min(static_cast<int>(r / quarter_steps), 3);
    double q = r - quadrant * quarter_steps;  // 0 .. microsteps
    if (quadrant % 2 == 1) q = quarter_steps - q;
    double value;
    if (quarter.empty()) {
      value = std::sin(q * (std::numbers::pi / 2) / quarter_steps);
    } else {
      const int i = std::min(static_cast<int>(q), microsteps - 1);
      value = quarter[i] + (quarter[i + 1] - quarter[i]) * (q - i);
    }
    return quadrant >= 2 ? -value : value;
  }

  /// The phase targets ia* + j·ib* at position p (microsteps), A.
  PhaseVector Targets(double position) const {
    return peak_current * PhaseVector(Entry(position + microsteps), Entry(position));
  }

  /// From the attributes; a `driver` chip (driver_chip.h) sets the interpolation default and
  /// rounds `run_current` to the current its sense resistor can set.
  /// `clock_frequency` (Hz): a Trinamic drive's f_CLK, which times its standstill current
  /// (ihold, iholddelay, tpowerdown); 0 for a drive without one, which refuses them.
  static MicrostepTable FromAttributes(const AttributeSource& a, const MotorParams& motor,
                                       bool interpolate_by_default, double clock_frequency = 0) {
    MicrostepTable t;
    const DriverChip* chip = FindDriver(a);
    int irun = 31;  // the run current's scale: a chip's, else the full 31
    double run_current =
        a.Real(kAttrRunCurrent, motor.rated_current, AttributeSource::Rule::kPositive);  // A RMS
    if (chip != nullptr) {
      const double r_sense = a.Real(kAttrSenseResistor, chip->sense_resistor, 0.01, 1.0);  // Ω
      // Unset, the rated current, or the chip's most if that is less (a 2 A motor on a TMC2209
      // module, whose 0.110 Ω allow 1.77 A RMS, runs at 1.77 A as Klipper would clamp it).
      if (!a.Raw(kAttrRunCurrent)) {
        run_current = std::min(run_current, chip->Regulate(run_current, r_sense).most);
      }
      const DriverChip::Regulation r = chip->Regulate(run_current, r_sense);
      const std::string raw =
          a.Raw(kAttrRunCurrent)
              .value_or(fmt::format("{:g} (the motor's rated current)", run_current));
      if (run_current > r.most * 1.001) {
        ThrowBad(kAttrRunCurrent, raw,
                 fmt::format("{} with sense_resistor {:g} Ω regulates at most {:.3g} A RMS",
                             chip->name, r_sense, r.most));
      }
      // Below the chip's least step the request cannot be followed: say so, do not round by 2×.
      if (std::abs(r.current - run_current) > 0.1 * run_current) {
        ThrowBad(kAttrRunCurrent, raw,
                 fmt::format("{} with sense_resistor {:g} Ω sets {:.3g} A RMS, more than 10 % "
                             "away; choose a larger sense_resistor",
                             chip->name, r_sense, r.current));
      }
      run_current = r.current;
      irun = r.cs;
      interpolate_by_default = chip->interpolate;
      if (chip->clock_frequency > 0)
        t.max_interpolated_interval = 1048576.0 / chip->clock_frequency;
    }
    t.peak_current = std::sqrt(2.0) * run_current;
    t.microsteps = a.Integer(kAttrMicrosteps, chip != nullptr ? chip->microsteps : 16, 1, 256);
    // A chip makes powers of two up to its finest (its MRES register or MS pins; issue 33).
    if (chip != nullptr &&
        (t.microsteps > chip->max_microsteps || (t.microsteps & (t.microsteps - 1)) != 0)) {
      ThrowBad(kAttrMicrosteps, std::to_string(t.microsteps),
               fmt::format("{} makes 1, 2, 4, … {} microsteps (powers of two)", chip->name,
                           chip->max_microsteps));
    }
    t.interpolate =
        a.Choice(kAttrInterpolate, interpolate_by_default ? "on" : "off", {"on", "off"}) == "on";
    if (auto q = a.Reals(kAttrCurrentTable, 0.0, 1.0, t.microsteps + 1, t.microsteps + 1)) {
      // A quarter wave as its documentation has it (issue 33: an all-zero table was accepted and
      // the rotor never moved): 0 at the phase's zero, 1 at its peak, never falling between.
      const std::string raw = *a.Raw(kAttrCurrentTable);
      if (q->front() != 0 || q->back() != 1) {
        ThrowBad(kAttrCurrentTable, raw,
                 fmt::format("a quarter wave starts at 0 and ends at 1 (this one: {:g} to {:g}); "
                             "scale it to its peak",
                             q->front(), q->back()));
      }
      for (size_t k = 1; k < q->size(); ++k) {
        if ((*q)[k] < (*q)[k - 1]) {
          ThrowBad(kAttrCurrentTable, raw,
                   fmt::format("entry {} ({:g}) is below entry {} ({:g}): a quarter wave rises "
                               "from 0 to 1",
                               k, (*q)[k], k - 1, (*q)[k - 1]));
        }
      }
      t.quarter = *q;
    }
    t.power_down = ReadPowerDown(a, chip, irun, clock_frequency);
    return t;
  }
  static std::vector<const AttributeSpec*> Attributes() {
    return {&kAttrDriver,     &kAttrRunCurrent,  &kAttrSenseResistor,
            &kAttrMicrosteps, &kAttrInterpolate, &kAttrCurrentTable,
            &kAttrIhold,      &kAttrIholddelay,  &kAttrTpowerdown};
  }

 private:
  // The standstill current of a Trinamic drive (f_CLK > 0) from its attributes and the chip's
  // defaults (Klipper's: TMC2209 without a chip); a drive without f_CLK refuses the attributes.
  static PowerDown ReadPowerDown(const AttributeSource& a, const DriverChip* chip, int irun,
                                 double clock_frequency) {
    if (clock_frequency <= 0) {
      for (const AttributeSpec* spec : {&kAttrIhold, &kAttrIholddelay, &kAttrTpowerdown}) {
        if (const auto raw = a.Raw(*spec)) {
          ThrowBad(*spec, *raw,
                   "is a Trinamic chip's standstill current: it needs drive = spreadcycle or "
                   "stealthchop (an A4988 or DRV8825 holds at its run current)");
        }
      }
      return {};
    }
    const DriverChip& row = chip != nullptr ? *chip : DriverChips().front();  // TMC2209's
    constexpr double kDetectClocks = 1048576.0;  // 2^20: DRV_STATUS.stst
    constexpr double kDelayClocks = 262144.0;    // 2^18: TPOWERDOWN's and IHOLDDELAY's unit
    PowerDown p;
    p.irun = irun;
    p.ihold = a.Integer(kAttrIhold, irun, 0, irun);
    p.detect = kDetectClocks / clock_frequency;
    p.delay = a.Integer(kAttrTpowerdown, row.tpowerdown, 0, 255) * kDelayClocks / clock_frequency;
    p.per_step = a.Integer(kAttrIholddelay, row.iholddelay, 0, 15) * kDelayClocks / clock_frequency;
    return p;
  }

 public:
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_STEP_TABLE_H_
