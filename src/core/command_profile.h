// Command profiles for a stepper: what θcmd or ωcmd does over time.
//   constant(100rpm)                 constant speed (rpm, r/min, rad/s)
//   constant(0.5rad)                 hold an angle (rad, deg)
//   ramp(0rpm, 200rpm, 0.8s)         speed ramp, then hold the final speed
//   ramp(0rpm, 200rpm, 50rad/s²)     the same by its acceleration (rad/s²): T = |Δω|/a
//   ramp(0rad, 3.1416rad, 1s)        angle ramp (constant speed), then hold the final angle
//   trapezoid(200rpm, 0.2s, 0.5s, 0.2s)  0 → peak in Ta, cruise Tc, → 0 in Td, then rest (Ta and
//                                    Td may be accelerations: Ta = |peak|/a)
//   targets(0deg, 90deg@0.5s, 0deg@2s)  angle targets, each from its time on (absolute; times
//                                    rising): waypoints for a position-input drive whose own
//                                    motion profile moves between them (`mjstepper size`)
//   steps(moves.txt)                 STEP/DIR pulses from a step-time list (step_times.h), for
//                                    drives with input = steps: the count at t
//   shaped(PROFILE, mzv 40Hz)        PROFILE through an input shaper (shaper.h): TYPE (zv, mzv,
//   shaped(PROFILE, ei 40Hz 0.15)    zvd, ei, 2hump_ei, 3hump_ei), its frequency in Hz and
//                                    optionally its damping ratio (default 0.1); nested shaped()
//                                    puts two shapers in series (two modes)
// On a linear axis (a stepper on a slide joint or a tendon: θ = gear·x; on a hinge whose config
// declares its carriage, θ = gear·x/r with r the pulley's or screw's m per rad) lengths, speeds and
// accelerations may be linear: m, mm, m/s, mm/s, m/s², mm/s² (also m/s^2, mm/s^2), converted to
// the rotor's rad, rad/s, rad/s² with the rotor's rad per metre: θ = (rad per metre)·(v·unit).
// A shaped profile is the convolution Σ A_i·P(t − T_i) of its angle, its speed and a step list's
// count (rounded to whole steps); for profiles relative to t = 0 (speeds, step lists) less its
// value at t = 0, so the angle stays relative to t = 0 (nothing to take away for those starting at
// rest; a constant speed is left as it is, which is what shaping it does, bar the delay).
#ifndef MJSTEPPER_CORE_COMMAND_PROFILE_H_
#define MJSTEPPER_CORE_COMMAND_PROFILE_H_

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/drive.h"
#include "core/shaper.h"
#include "core/step_times.h"

namespace mjstepper {

/// The bounds of a profile's numbers: a speed (and an angle ramp's slope) within ±1e4 rad/s
/// (95 493 r/min, thirty times the fastest stepper's top speed), an angle within ±1e7 rad, a time
/// within 1e6 s. Beyond them a profile is a typing error, and its commands would pass
/// Drive::CommandFrom's bound (kMaxCommand) and be ignored while a summary reported them.
inline constexpr double kMaxProfileSpeed = 1e4;  // rad/s
inline constexpr double kMaxProfileAngle = 1e7;  // rad
inline constexpr double kMaxProfileTime = 1e6;   // s
/// An acceleration: the bound of speed over a 1 µs ramp, 1e10 rad/s².
inline constexpr double kMaxProfileAcceleration = 1e10;  // rad/s²
/// The most targets a targets(…) profile holds (a robot's program, not a sampled trajectory).
inline constexpr size_t kMaxTargets = 100000;
/// The most shaped(…) a profile may nest: two modes' shapers in series is the use; each level is
/// parsed by a recursion over its inner text, which 6 000 levels overflowed (issue 33).
inline constexpr size_t kMaxNestedShapers = 4;
/// The longest profile text, characters: kMaxTargets targets of about 40 characters each.
inline constexpr size_t kMaxProfileText = 4000000;

class CommandProfile {
 public:
  /// Throws std::invalid_argument quoting the text and saying what is expected (and any number
  /// beyond the bounds above). `rad_per_metre`: the rotor's rad per metre of a linear axis (a slide
  /// joint, a tendon, a hinge with a declared carriage), which converts linear units; none (any
  /// other hinge) refuses them, naming the unit.
  static CommandProfile Parse(std::string_view text,
                              std::optional<double> rad_per_metre = std::nullopt);

  /// Commanded speed at t, rad/s; a step list's step rate times `step_angle` (rad per microstep).
  double Speed(double t, double step_angle = 0) const;
  /// Commanded angle at t, rad: absolute for angle profiles, relative to t = 0 for speed profiles
  /// and step lists (count·step_angle).
  double Angle(double t, double step_angle = 0) const;
  /// True for steps(FILE) (shaped or not): a STEP/DIR stream, only for drives with input = steps.
  bool step_list() const { return kind_ == Kind::kStepList; }
  /// A step list's steps as a driver receives them, each at its own time: the list itself, or,
  /// shaped, the times at which the shaped count round(Σ A_i·count(t − T_i)) changes, each change
  /// of one a step. Empty when not a step list, or when the shaped list would pass
  /// kMaxStepTimes.
  std::optional<StepTimes> PulseTimes() const;
  /// The input shaper of shaped(…), or nullptr.
  const InputShaper* shaper() const { return shaper_.get(); }
  /// True for angle profiles (constant(…rad), ramp(…rad, …rad, T), targets(…)).
  bool absolute_angle() const {
    return kind_ == Kind::kAngleHold || kind_ == Kind::kAngleRamp || kind_ == Kind::kTargets;
  }

  /// The control for the simulation step [t, t + h]: the mean speed over the step (velocity input,
  /// so that the drive's integrated θcmd matches Angle at step ends), or the angle at mid-step
  /// (position input, centring the held staircase on the profile). `theta_start` is added to
  /// speed profiles' angles. STEP/DIR input (kSteps): the microstep count of the angle at the
  /// step's end, round(angle/step_angle), step_angle in rad per microstep (Drive::StepAngle).
  double ControlForStep(double t, double h, InputMode input, double theta_start,
                        double step_angle = 0) const;

  const std::string& text() const { return text_; }

 private:
  enum class Kind {
    kConstantSpeed,
    kAngleHold,
    kSpeedRamp,
    kAngleRamp,
    kTrapezoid,
    kStepList,
    kTargets
  };
  struct Target {
    double time = 0;   // s, from when it holds
    double angle = 0;  // rad
  };
  static CommandProfile ParseShaped(const std::string& whole, const std::string& inner,
                                    std::optional<double> rad_per_metre);
  static CommandProfile ParseTargets(const std::string& whole, const std::string& inner,
                                     std::optional<double> rad_per_metre);
  // The profile before shaping.
  double RawSpeed(double t, double step_angle) const;
  double RawAngle(double t, double step_angle) const;
  // A step list's microstep count at t, shaped: round(Σ A_i·count(t − T_i)).
  double StepCount(double t) const;

  Kind kind_ = Kind::kConstantSpeed;
  double a_ = 0, b_ = 0;             // speeds (rad/s) or angles (rad)
  double t1_ = 0, t2_ = 0, t3_ = 0;  // s
  std::string text_;
  std::shared_ptr<const StepTimes> steps_;              // kStepList
  std::shared_ptr<const InputShaper> shaper_;           // shaped(…)
  std::shared_ptr<const std::vector<Target>> targets_;  // targets(…), times rising
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_COMMAND_PROFILE_H_
