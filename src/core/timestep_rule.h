// The one timestep rule (issue 19): the model's modes against the simulation step. MuJoCo-free:
// its input is the list of modes, each with its angular frequency, a name and whether a stepper
// takes part in it; plugin/modes.h computes them from a model. The plugin's load warning,
// `mjstepper info` and `mjstepper run` all judge a timestep here, with the same words and numbers.
//
// The rule: every mode must have ω·h <= max_omega_h (kMaxOmegaTimesStep today): MuJoCo's
// semi-implicit Euler turns a mode of frequency ω into one off by about (ω·h)²/24 (drive.h). A
// mode in which no stepper takes part (a model's own spring, e.g. a fingertip or a belt far from
// any motor) is the model's business, as in MuJoCo without the plugin: it is named as a
// "non-stepper mode" and warned about, never refused; only a failing stepper mode refuses a run.
#ifndef MJSTEPPER_CORE_TIMESTEP_RULE_H_
#define MJSTEPPER_CORE_TIMESTEP_RULE_H_

#include <limits>
#include <string>
#include <vector>

namespace mjstepper {

/// The largest ω·h, on the fastest stepper mode, at which a move's ringing after it (its residual
/// vibration, a small remainder of its excitations, which the time of each torque change within a
/// step moves) stays within 5 % of a fine reference with STEP/DIR input, in either fidelity and
/// coupling (issue 30, items 4 and 6). Measured on models/corexy.xml's move at six shifts of the
/// move against the step grid (docs/coupling.md, "The CoreXY's ringing against the step grid"):
/// within ±4.4 % at 50 µs (ω·h 0.064), −4.4 to +9.2 % at 100 µs, −3.8 to +8.8 % at the rule's
/// 154 µs (0.2). The bound depends on the move: the bed-slinger's Y move, whose ringing is larger,
/// stays within 3.8 % to 100 µs (ω·h 0.15 on its 245.8 Hz rotor mode). So it is a recommendation
/// (TimestepVerdict::ringing_timestep: `info`, `run`, `size`, `sweep`, `map`, `pullout` and the
/// load warning give it), never a refusal.
inline constexpr double kRingingOmegaTimesStep = 0.065;
/// The bed-slinger's measured bound, quoted beside it.
inline constexpr double kRingingOmegaTimesStepLargeRing = 0.15;

/// One mode as the rule sees it.
struct RuleMode {
  double omega = 0;  ///< rad/s, > 0 (rigid-body modes at 0 are left out by the caller)
  /// What the mode is: "mode 2 (stepper 'shaft' 61 %, joint 'coupling')", made by the caller.
  std::string name;
  bool stepper = false;  ///< a stepper takes part (its refusal counts)
};

/// One check the timestep fails.
struct FailedCheck {
  std::string name;
  double frequency = 0;         ///< Hz, ω/2π
  double omega_h = 0;           ///< ω·h at the judged timestep
  double largest_timestep = 0;  ///< s, max_omega_h/ω: this check's own largest timestep
  bool stepper = false;
};

struct TimestepVerdict {
  double timestep = 0;     ///< s, the one judged
  double max_omega_h = 0;  ///< the rule's parameter
  /// Every failing check, stepper modes first, each in decreasing frequency.
  std::vector<FailedCheck> failed;
  /// s: the largest timestep that passes every check (stepper or not); infinite without modes.
  double largest_timestep = 0;
  /// s: largest_timestep rounded DOWN to 3 significant figures (printed exactly by {:.3g}); it
  /// passes every check.
  double suggestion = 0;
  /// s: with STEP/DIR input, the largest timestep that keeps a move's ringing within 5 % of a fine
  /// reference, kRingingOmegaTimesStep/ω on the fastest stepper mode rounded down to 3 figures
  /// (JudgeRinging); infinite without STEP/DIR input or a stepper mode. A recommendation: it never
  /// refuses.
  double ringing_timestep = std::numeric_limits<double>::infinity();
  double ringing_frequency = 0;  ///< Hz: the fastest stepper mode it is judged on
  /// A failing stepper mode: a run refuses (unless told to allow it).
  bool refuse() const;
  /// The step is above ringing_timestep.
  bool ringing_exceeded() const { return timestep > ringing_timestep; }
  /// "" unless ringing_exceeded(); else what the step does to a move's ringing and the step that
  /// keeps it, after `subject` (a note: run and size print it, never refuse on it).
  std::string RingingNote(const std::string& subject) const;
  /// "" when nothing fails; else every failing check and the suggestion, each after `separator`
  /// (a new indented line for a terminal, "; " for MuJoCo's one-line warnings), e.g.
  /// "M: timestep 0.0002 s is too coarse for 1 mode(s) ...; use timestep <= 4.99e-05 s ...".
  /// `subject` starts it.
  std::string Message(const std::string& subject, const std::string& separator = "\n  ") const;
  /// Message in one line of a few hundred characters: the count of failing modes, the fastest and
  /// the suggestion (MuJoCo's warnings are cut at 1000 characters, and a model's load warns once).
  std::string Summary(const std::string& subject) const;
};

/// Whether h passes a mode of frequency omega (rad/s): h <= max_omega_h/ω, the same division as
/// its largest timestep, so a timestep equal to a printed suggestion passes.
bool PassesMode(double omega, double timestep, double max_omega_h);

/// Judges `timestep` (s) against every mode; max_omega_h > 0.
TimestepVerdict JudgeTimestep(const std::vector<RuleMode>& modes, double timestep,
                              double max_omega_h);

/// Sets v's ringing_timestep and ringing_frequency from the fastest stepper mode's ω (rad/s, > 0),
/// for a model whose steppers take STEP/DIR input.
void JudgeRinging(TimestepVerdict* v, double fastest_stepper_omega);

/// x > 0 rounded down to 3 significant figures (the double nearest that decimal, never above x);
/// infinity stays infinity.
double RoundDown3(double x);

/// ω·h for a message: at least 3 significant figures, more until it differs from the limit (a
/// failing 0.2000001 is never printed as "0.2 > 0.2").
std::string FormatOmegaH(double omega_h, double limit);

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_TIMESTEP_RULE_H_
