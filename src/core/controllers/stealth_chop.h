// StealthChop: Trinamic's voltage-mode PWM (TMC2209 class), averaged over the PWM period (S-15),
// fed by STEP/DIR through the microstep table (step_table.h), SPEC §8.
//
// The bridges apply a voltage, not a current: each phase's duty is the table entry scaled by one
// amplitude, PWM_SCALE_SUM (0..255), so that the phase voltage vector is
//   v = Vbus·(PWM_SCALE_SUM/256)·(248/256)·[T(ψ + π/2), T(ψ)]
// at the table's (interpolated) position ψ. 248 is the peak of Trinamic's sine table: "The
// effective PWM voltage U_PWM (1/SQRT(2) x peak value) results considering the 8 bit resolution
// and 248 sine wave peak for the actual PWM amplitude shown as PWM_SCALE: U_PWM = V_M·PWM_SCALE/
// 256·248/256·1/√2" (TMC2209 datasheet Rev. 1.03, §6 "StealthChop", p. 40; the same text in the
// TMC5160A datasheet Rev. 1.14, §7.4, p. 63, with PWM_OFS = 374·R_COIL·I_COIL/V_M for an RMS
// current I_COIL, which is this formula solved for the amplitude).
//
// The amplitude (TMC2209 datasheet, register 0x70 PWMCONF, fields PWM_OFS, PWM_GRAD,
// pwm_autoscale):
//   pwm_autoscale = 0:  PWM_SCALE_SUM = PWM_OFS·(CS+1)/32 + PWM_GRAD·256/TSTEP, limited to 0..255
//   pwm_autoscale = 1:  PWM_SCALE_SUM = PWM_OFS_AUTO·(CS+1)/32 + PWM_GRAD_AUTO·256/TSTEP
//                                       + PWM_SCALE_AUTO
// TSTEP is the time between two 1/256 microsteps in f_CLK clocks, 2^20 − 1 at standstill ("Measured
// value is (2^20)-1 in case of overflow or stand still", TSTEP register), measured here from the
// times at which the ticks see the step count change, over spans of at least 32 ticks (a tick
// quantises each step's time; the chip sees the pulses' own times). CS, the current scale, is IRUN
// = 31 (the reset default) in this model: run_current is the full-scale current and there is no
// hold current or CoolStep, so (CS+1)/32 = 1 and, without autoscale, run_current does not change
// the voltage at all (the datasheet: IRUN and IHOLD "are not enforced by regulation but scale the
// PWM amplitude, only").
//
// The current regulator (pwm_autoscale = 1), TMC5160A datasheet Rev. 1.14 §7.3 "StealthChop
// Current Regulator" (the TMC2209's §6.3 is the same design): "The driver measures the motor
// current during the chopper on time and uses a proportional regulator to regulate PWM_SCALE_AUTO
// in order match the motor current to the target current. PWM_REG is the proportionality
// coefficient", with PWM_REG the "User defined maximum PWM amplitude change per half wave when
// using pwm_autoscale=1 (1...15): 1: 0.5 increments (slowest regulation) ... 15: 7.5 increments"
// (PWMCONF). Modelled as: at the end of each electrical half wave of the table (2 full steps), the
// mean magnitude of the current vector since the last update, Ī, is compared with the target I*
// (the table's peak, √2·run_current); PWM_SCALE_AUTO moves by the amplitude that would close that
// error at standstill, (I* − Ī)·R per volt of one amplitude unit, limited to ±PWM_REG/2. (The
// chip's gain is not published; this one is exact at standstill and under-corrects by R/|R + jNrωL|
// at speed, which still converges.) No half wave ends at standstill: there the regulator steps
// every kStandstillRegulationClocks (a modelling choice: the datasheet gives AT#1 as a whole, "≤
// 2^20 + 2·2^18 t_CLK" including the 2^20 clocks of standstill detection, and asks for "at least
// 128 chopper periods" at standstill; 2^14 clocks fits 32 steps of PWM_REG/2 into the 2^19 clocks
// left). Automatic tuning (TMC5160A §7.1, table "Automatic tuning timing and border conditions";
// PWMCONF pwm_autograd):
//   AT#1, at standstill (DRV_STATUS stst: "This occurs 2^20 clocks after the last step pulse"):
//         PWM_OFS_AUTO takes over PWM_SCALE_AUTO ("regulate PWM_OFS_AUTO so that -1 <
//         PWM_SCALE_AUTO < 1", PWMCONF pwm_autograd);
//   AT#2, moving with 1.5·PWM_OFS_AUTO < PWM_SCALE_SUM < 4·PWM_OFS_AUTO and PWM_SCALE_SUM < 255:
//         PWM_GRAD_AUTO moves by ±1 toward a PWM_SCALE_AUTO of 0, "8 fullsteps are required for a
//         change of +/-1"; here PWM_SCALE_AUTO gives back what the change adds (256/TSTEP), so that
//         the amplitude stays continuous.
// Not modelled: the PWM ripple (S-15), the amplitude's integer quantisation, the lower current
// limit of autoscale (t_BLANK·f_PWM·V_M/R, §6.3.1), PWM_LIM (it limits PWM_SCALE_AUTO only when
// switching back from SpreadCycle, which this drive never runs), freewheeling.
#ifndef MJSTEPPER_CORE_CONTROLLERS_STEALTH_CHOP_H_
#define MJSTEPPER_CORE_CONTROLLERS_STEALTH_CHOP_H_

#include <algorithm>
#include <cmath>
#include <string>

#include "core/controllers/controller.h"
#include "core/controllers/driver_chip.h"
#include "core/controllers/step_table.h"
#include "core/sensors/stallguard.h"

namespace mjstepper {

inline constexpr AttributeSpec kAttrPwmOfs{
    "pwm_ofs", "integer", "36", "— (of 256)",
    "`stealthchop`: PWM_OFS, the amplitude offset \"related to full motor current (CS_ACTUAL=31) "
    "in stand still\" (TMC2209 PWMCONF, reset default 36; Klipper's default 36). Without "
    "autoscale it is the standstill amplitude, holding PWM_OFS/256·248/256·Vbus/R; with autoscale "
    "only the start of PWM_OFS_AUTO, which a drive at rest has already tuned. Integer in [0, "
    "255]."};
inline constexpr AttributeSpec kAttrPwmGrad{
    "pwm_grad", "integer", "14 (Klipper)", "— (of 256)",
    "`stealthchop`: PWM_GRAD, the velocity term PWM_GRAD·256/TSTEP added to the amplitude against "
    "the back-EMF (TSTEP: f_CLK clocks per 1/256 microstep); with autograd only the start of "
    "PWM_GRAD_AUTO. Klipper writes 14 for a TMC2209 (the register's reset value is 0, the chip's "
    "OTP sets the power-up value). Integer in [0, 255]."};
inline constexpr AttributeSpec kAttrPwmAutoscale{
    "pwm_autoscale", "name", "`on`", "—",
    "`stealthchop`: `on` regulates the amplitude toward the target current √2·run_current "
    "(PWM_SCALE_AUTO, at most PWM_REG/2 per electrical half wave) and tunes PWM_OFS_AUTO at "
    "standstill (AT#1); `off` is the feed-forward amplitude PWM_OFS + PWM_GRAD·256/TSTEP alone "
    "(reset default and Klipper: on)."};
inline constexpr AttributeSpec kAttrPwmAutograd{
    "pwm_autograd", "name", "`on`", "—",
    "`stealthchop` with autoscale: `on` tunes PWM_GRAD_AUTO while moving (AT#2, ±1 per 8 full "
    "steps); `off` keeps PWM_GRAD (reset default and Klipper: on)."};
inline constexpr AttributeSpec kAttrPwmReg{
    "pwm_reg", "integer", "8 (TMC2209 OTP default, Klipper)", "—",
    "`stealthchop`: PWM_REG, the autoscale regulator's largest amplitude change per electrical "
    "half wave, PWM_REG/2 units (1: 0.5, slowest; 15: 7.5, fastest). The TMC2209's OTP default "
    "is 8 (\"max. 4 increments\"), as Klipper's. Integer in [1, 15]."};
inline constexpr AttributeSpec kAttrPwmFreq{
    "pwm_freq", "integer", "1", "—",
    "`stealthchop`: PWM_FREQ, the PWM frequency f_PWM = 2/1024, 2/683, 2/512 or 2/410 of f_CLK "
    "for 0..3 (35.1 kHz for 1 at 12 MHz; reset default and Klipper: 1). Informational: the PWM is "
    "averaged (S-15). Integer in [0, 3]."};
struct StealthChop {
  static constexpr const char* kName = "stealthchop";
  static constexpr const char* kSummary =
      "Trinamic StealthChop (TMC2209 class), SPEC §8: voltage-mode PWM averaged over its period, "
      "the phase voltages the microstep table's entries times one amplitude PWM_OFS + "
      "PWM_GRAD·256/TSTEP, regulated toward √2·run_current per electrical half wave "
      "(pwm_autoscale, PWM_REG) with the automatic tuning AT#1/AT#2.";
  static constexpr SpeedFeedback kDefaultSpeedFeedback = SpeedFeedback::kExact;
  static constexpr const char* kStiffnessFormula =
      "Nr·Km·I, T(1), I = √2·run_current (autoscale) or PWM_OFS·248·Vbus/(256²·R)";
  static constexpr bool kCountsSlips = true;

  /// 248/256: the sine table's peak over the PWM's full scale (datasheet, U_PWM above).
  static constexpr double kTablePeak = 248.0 / 256.0;
  /// PWM_SCALE_SUM's full scale.
  static constexpr double kFullScale = 255.0;
  /// TSTEP's ceiling, clocks: "(2^20)-1 in case of overflow or stand still"; also the standstill
  /// detection, 2^20 clocks after the last step (DRV_STATUS stst).
  static constexpr double kStandstillClocks = 1048576.0;
  /// The regulator's step period at standstill, clocks (a modelling choice, see the file comment).
  static constexpr double kStandstillRegulationClocks = 16384.0;
  /// AT#2: full steps per change of PWM_GRAD_AUTO by ±1.
  static constexpr double kFullStepsPerGradChange = 8.0;

  MicrostepTable table;           ///< run_current (I* = its peak), microsteps, interpolation
  int pwm_ofs = 36;               ///< PWM_OFS
  int pwm_grad = 14;              ///< PWM_GRAD
  bool pwm_autoscale = true;      ///< regulation toward I*
  bool pwm_autograd = true;       ///< AT#2
  int pwm_reg = 8;                ///< PWM_REG: at most PWM_REG/2 units per half wave
  int pwm_freq = 1;               ///< PWM_FREQ 0..3
  double clock_frequency = 12e6;  ///< f_CLK, Hz
  StallGuard stallguard;          ///< StallGuard4 and CoolStep on TMC2209; none on TMC2130/5160

  struct State {
    MicrostepTable::Counter counter;
    double ofs_auto = 0;          ///< PWM_OFS_AUTO, amplitude units (of 256)
    double grad_auto = 0;         ///< PWM_GRAD_AUTO
    double scale_auto = 0;        ///< PWM_SCALE_AUTO, the regulator's output
    double step_count = 0;        ///< the count at the last step seen
    double idle_ticks = 0;        ///< ticks since the count last changed (capped)
    double span_count = 0;        ///< the count where the step-rate measurement started
    double span_ticks = 0;        ///< ticks since then (capped)
    double tstep = 0;             ///< TSTEP measured over the last span, clocks
    double half_wave = 0;         ///< index of the electrical half wave the table is in
    double since_regulation = 0;  ///< ticks since the regulator's last step (capped)
    double current_sum = 0;       ///< Σ|i| over those ticks, A
    double samples = 0;           ///< how many
    double full_steps = 0;        ///< full steps moved toward the next AT#2 change
    double last_position = 0;     ///< the table position at the last tick, microsteps
  };
  using Input = Sample;

  /// f_PWM, Hz: 2/1024, 2/683, 2/512, 2/410 of f_CLK for PWM_FREQ = 0..3 (PWMCONF).
  double PwmFrequency() const {
    constexpr double kDivider[4] = {1024, 683, 512, 410};
    return 2 * clock_frequency / kDivider[std::clamp(pwm_freq, 0, 3)];
  }

  /// The phase voltage of one amplitude unit at the table's peak, V: Vbus/256·248/256.
  static double VoltsPerUnit(double bus_voltage) { return bus_voltage / 256 * kTablePeak; }

  /// TSTEP's measurement at one tick (the count is read at the ticks): when the count changes
  /// after a span of at least kMinSpanTicks, TSTEP = the span's clocks over the 1/256 microsteps it
  /// moved (a whole span, so that the ±1 tick of its ends is at most 1/kMinSpanTicks of it), at
  /// most 2^20 − 1 (the first step after standstill: the counter overflowed). Between measurements
  /// it is at least the clocks since the last step per 1/256 microstep, so that it reaches 2^20 − 1
  /// at standstill as the chip's does. Returns TSTEP.
  /// Over `ticks` interrupts' worth of time (1 at a tick; a fraction or several in a span of the
  /// averaged fidelity, Span).
  double MeasureTstep(const DriveConstants& k, double count, double ticks, State* s) const {
    const double clocks_per_tick = k.isr_period * clock_frequency;
    const double fine = 256.0 / table.microsteps;  // 1/256 microsteps per microstep
    s->span_ticks = std::min(s->span_ticks + ticks, kTickCap);
    if (count != s->step_count) {
      s->step_count = count;
      s->idle_ticks = 0;
      if (s->span_ticks >= kMinSpanTicks) {
        const double moved = std::abs(count - s->span_count) * fine;
        s->tstep = moved > 0 ? s->span_ticks * clocks_per_tick / moved : kStandstillClocks;
        s->span_count = count;
        s->span_ticks = 0;
      }
    } else {
      s->idle_ticks = std::min(s->idle_ticks + ticks, kTickCap);
    }
    const double idle = s->idle_ticks * clocks_per_tick / fine;
    return std::min(std::max(s->tstep, idle), kStandstillClocks - 1);
  }

  /// The averaged fidelity's span bound (Span), ticks: while moving or before standstill one tick
  /// (the table, MicroPlyer, TSTEP and the power-down move tick by tick); at standstill the ticks
  /// to the regulator's next step there (at least one).
  double SpanTicks(const DriveConstants& k, const State& s) const {
    const double ticks_per_clock = 1 / (k.isr_period * clock_frequency);
    if (!pwm_autoscale || s.idle_ticks < kStandstillClocks * ticks_per_clock) return 1.0;
    return std::max(1.0, kStandstillRegulationClocks * ticks_per_clock - s.since_regulation);
  }

  /// The most ticks SpanTicks returns (rounded up), plus one.
  double LongestSpan(const DriveConstants& k) const {
    return std::ceil(kStandstillRegulationClocks / (k.isr_period * clock_frequency)) + 1;
  }

  /// PWM_SCALE_SUM (0..255) from the state and the velocity term 256/TSTEP.
  double Amplitude(const State& s, double velocity_term) const {
    const double sum = pwm_autoscale ? s.ofs_auto + s.grad_auto * velocity_term + s.scale_auto
                                     : pwm_ofs + pwm_grad * velocity_term;  // (CS+1)/32 = 1
    return std::clamp(sum, 0.0, kFullScale);
  }

  static std::vector<const AttributeSpec*> Attributes() {
    std::vector<const AttributeSpec*> list = MicrostepTable::Attributes();
    list.insert(list.end(), {&kAttrPwmOfs, &kAttrPwmGrad, &kAttrPwmAutoscale, &kAttrPwmAutograd,
                             &kAttrPwmReg, &kAttrPwmFreq, &kAttrClockFrequency});
    for (const AttributeSpec* spec : StallGuard::Attributes()) list.push_back(spec);
    return list;
  }
  static StealthChop FromAttributes(const AttributeSource& a, const MotorParams& motor,
                                    const DriveConstants&) {
    const DriverChip* given = FindDriver(a);
    const DriverChip* chip = given != nullptr ? given : &DriverChips().front();  // TMC2209's
    if (chip->clock_frequency == 0) {
      ThrowBad(kAttrDriver, chip->name,
               "has no StealthChop (a constant-off-time chopper): use drive = chopper");
    }
    StealthChop c;
    c.clock_frequency = a.Real(kAttrClockFrequency, chip->clock_frequency, 4e6, 2e7);
    // MicroPlyer on, as TMC drives run it (Klipper's `interpolate: True`).
    c.table = MicrostepTable::FromAttributes(a, motor, chip->interpolate, c.clock_frequency);
    c.pwm_ofs = a.Integer(kAttrPwmOfs, c.pwm_ofs, 0, 255);
    c.pwm_grad = a.Integer(kAttrPwmGrad, c.pwm_grad, 0, 255);
    c.pwm_autoscale = a.Choice(kAttrPwmAutoscale, "on", {"on", "off"}) == "on";
    c.pwm_autograd = a.Choice(kAttrPwmAutograd, "on", {"on", "off"}) == "on";
    c.pwm_reg = a.Integer(kAttrPwmReg, c.pwm_reg, 1, 15);
    c.pwm_freq = a.Integer(kAttrPwmFreq, c.pwm_freq, 0, 3);
    c.stallguard = StallGuard::FromAttributes(a, given != nullptr ? given->stallguard_stealth : 0);
    return c;
  }

  /// At each tick: the step count → the table position → the voltage vector along its entries.
  TickOutput Tick(const DriveConstants& k, const Input& in, const PowerStage& stage,
                  State* s) const {
    return Span(k, in, static_cast<double>(in.tick), 1.0, stage, s);
  }

  /// The averaged fidelity (SPEC §11): the chip over `ticks` interrupts' worth of time at once
  /// (any positive number), as Tick over one: the counters (TSTEP's span and idle time, the
  /// regulator's time since its last step and its mean |i|, weighted by the span) advance by the
  /// span, and the voltage it returns is held over it. `label`: the span's start as a tick label
  /// (fractional between interrupts, as an edge's). At one tick it is Tick.
  TickOutput Span(const DriveConstants& k, const Input& in, double label, double ticks,
                  const PowerStage& stage, State* s) const {
    const double count = table.Count(k, in.command.theta);
    const double position = table.Position(k, count, label, &s->counter);  // microsteps
    const double velocity_term = 256 / MeasureTstep(k, count, ticks, s);
    const double ticks_per_clock = 1 / (k.isr_period * clock_frequency);
    const bool standstill = s->idle_ticks >= kStandstillClocks * ticks_per_clock;
    const double volts_per_unit = VoltsPerUnit(stage.bus_voltage);
    // CoolStep and the standstill current scale the target the regulator aims at
    // (sensors/stallguard.h, step_table.h).
    const double peak =
        in.current_scale * table.StandstillScale(k, label, s->counter) * table.peak_current;
    if (pwm_autoscale) {
      Regulate(k, peak, std::abs(in.current), ticks, position, standstill, velocity_term,
               volts_per_unit, ticks_per_clock, s);
    }
    const PhaseVector direction = table.Targets(position) / table.peak_current;
    const PhaseVector target = peak * direction;  // A, the table's current
    const PhaseVector v = Amplitude(*s, velocity_term) * volts_per_unit * direction;
    return {.bridge = stage.Apply(v), .current_ref = target};
  }

  /// A STEP edge (input = steps) at tick label `tick`, the count now `count`: the voltage vector
  /// turns to the table's new entry at once, at the amplitude the regulator holds (its counters
  /// and TSTEP move at the ticks). Returns the bridge's output and the table's current target.
  TickOutput Edge(const DriveConstants& k, double count, double tick, double current_scale,
                  const PowerStage& stage, State* s) const {
    const double position = table.Position(k, count, tick, &s->counter);  // microsteps
    const double peak =
        current_scale * table.StandstillScale(k, tick, s->counter) * table.peak_current;  // A
    const double velocity_term = 256 / std::clamp(s->tstep, 1.0, kStandstillClocks - 1);
    const PhaseVector direction = table.Targets(position) / table.peak_current;
    const PhaseVector v =
        Amplitude(*s, velocity_term) * VoltsPerUnit(stage.bus_voltage) * direction;
    return {.bridge = stage.Apply(v), .current_ref = peak * direction};
  }

  /// At rest on the table's entry at θcmd, after the automatic tuning's standstill phase (AT#1):
  /// with autoscale the amplitude holds the target current, PWM_OFS_AUTO = R·I*/(V per unit),
  /// PWM_SCALE_AUTO = 0; without, the current is PWM_OFS's, PWM_OFS·(V per unit)/R. Either way
  /// v = R·i, the drive's equilibrium (SPEC §6).
  PhaseVector Rest(const DriveConstants& k, const RestInput& in, State* s) const {
    *s = {};
    const double count = table.Count(k, in.theta_cmd);
    table.RestTargets(k, in.theta_cmd, &s->counter);  // the counter, stood still for ever
    s->step_count = s->span_count = count;
    s->idle_ticks = s->span_ticks = kTickCap;  // rested for ever: at standstill
    s->tstep = kStandstillClocks - 1;
    s->half_wave = HalfWave(count);
    s->last_position = count;
    s->grad_auto = pwm_grad;  // "PWM_GRAD_AUTO is initialized with PWM_GRAD"
    const double volts_per_unit = VoltsPerUnit(k.bus_voltage);
    const double velocity_term = 256 / (kStandstillClocks - 1);             // TSTEP at standstill
    const double peak = table.power_down.HoldScale() * table.peak_current;  // A, at standstill
    s->ofs_auto = std::clamp(k.resistance * peak / volts_per_unit - s->grad_auto * velocity_term,
                             0.0, kFullScale);
    const double amplitude = Amplitude(*s, velocity_term);
    return amplitude * volts_per_unit / k.resistance * table.Targets(count) / table.peak_current;
  }
  double HoldingStiffness(const DriveConstants& k, PhaseVector rest_current) const {
    return OpenLoopStiffness(k, rest_current);
  }

 private:
  /// Tick counters stop here (finite, and far beyond any threshold they are compared with).
  static constexpr double kTickCap = 1e15;
  /// The shortest span TSTEP is measured over, ticks (see MeasureTstep).
  static constexpr double kMinSpanTicks = 32;

  /// The electrical half wave holding position p (microsteps): 2 full steps each.
  double HalfWave(double position) const { return std::floor(position / (2.0 * table.microsteps)); }

  /// The autoscale regulator and the automatic tuning, at one tick (see the file comment).
  void Regulate(const DriveConstants& k, double peak, double current, double ticks, double position,
                bool standstill, double velocity_term, double volts_per_unit,
                double ticks_per_clock, State* s) const {
    s->current_sum += current * ticks;
    s->samples += ticks;
    s->since_regulation = std::min(s->since_regulation + ticks, kTickCap);
    // AT#2 counts the full steps the table moves.
    if (pwm_autograd) s->full_steps += std::abs(position - s->last_position) / table.microsteps;
    s->last_position = position;
    const double half_wave = HalfWave(position);
    bool update = half_wave != s->half_wave;
    s->half_wave = half_wave;
    update |= standstill && s->since_regulation >= kStandstillRegulationClocks * ticks_per_clock;
    if (update) {
      const double measured = s->current_sum / s->samples;  // A, mean |i| since the last step
      s->current_sum = s->samples = s->since_regulation = 0;
      const double error = (peak - measured) * k.resistance / volts_per_unit;
      const double limit = 0.5 * pwm_reg;
      s->scale_auto =
          std::clamp(s->scale_auto + std::clamp(error, -limit, limit), -kFullScale, kFullScale);
      // No wind-up: the sum stays inside 0..255.
      const double base = s->ofs_auto + s->grad_auto * velocity_term;
      if (base + s->scale_auto > kFullScale) {
        s->scale_auto = std::max(-kFullScale, kFullScale - base);
      } else if (base + s->scale_auto < 0) {
        s->scale_auto = std::min(kFullScale, -base);
      }
      if (standstill) {  // AT#1: the offset takes the regulator's output over
        const double total = s->ofs_auto + s->scale_auto;
        s->ofs_auto = std::clamp(total, 0.0, kFullScale);
        s->scale_auto = total - s->ofs_auto;
      }
    }
    if (standstill) {
      s->full_steps = 0;
    } else if (pwm_autograd && s->full_steps >= kFullStepsPerGradChange) {
      s->full_steps = std::fmod(s->full_steps, kFullStepsPerGradChange);  // bounded work
      const double sum = s->ofs_auto + s->grad_auto * velocity_term + s->scale_auto;
      const bool tuning = sum > 1.5 * s->ofs_auto && sum < 4 * s->ofs_auto && sum < kFullScale;
      // One unit of PWM_GRAD_AUTO is worth velocity_term of amplitude: step when that brings
      // PWM_SCALE_AUTO nearer 0.
      if (tuning && s->scale_auto > 0.5 * velocity_term && s->grad_auto < kFullScale) {
        s->grad_auto += 1;
        s->scale_auto -= velocity_term;
      } else if (tuning && s->scale_auto < -0.5 * velocity_term && s->grad_auto > 0) {
        s->grad_auto -= 1;
        s->scale_auto += velocity_term;
      }
    }
  }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_STEALTH_CHOP_H_
