// The drive's own motion profile (ramp generator), as a stepper driver's: `ctrl` sets the target
// angle, and the drive moves its command θd there within speed, acceleration and (S-curve) jerk
// limits, handing θd, θ̇d, θ̈d and θ⃛d exactly to the controller at every tick.
//
// A plan is a list of segments of constant jerk j from a start state (t0, p0, v0):
//   a(τ) = a0 + j·τ,  v(τ) = v + a0·τ + j·τ²/2,  p(τ) = p + v·τ + a0·τ²/2 + j·τ³/6.
//   trapezoid: up to four segments of constant acceleration (j = 0): an optional stop (when the
//     target lies behind, or too close to stop before it), ±A to the peak, cruise, ∓A to rest;
//     a new target while moving is planned from the current position and speed.
//   scurve: seven segments, jerk ±Jm (rest to rest, a0 = 0 at both ends); a new target while
//     moving is taken when the current move ends.
// Kim 2016's trajectory (SPEC §4) is the trapezoid with speed 2π rad/s, acceleration 4π rad/s²
// (0.5 s ramps), start time 0.5 s and target 5π rad.
#ifndef MJSTEPPER_CORE_MOTION_PROFILE_H_
#define MJSTEPPER_CORE_MOTION_PROFILE_H_

#include <array>
#include <type_traits>

#include "core/controllers/controller.h"

namespace mjstepper {

enum class ProfileKind { kNone, kTrapezoid, kSCurve };

struct MotionProfile {
  ProfileKind kind = ProfileKind::kNone;
  double max_speed = 6.283185307179586;   ///< V, rad/s (rotor side), > 0
  double max_accel = 12.566370614359172;  ///< A, rad/s², > 0
  double max_jerk = 1000.0;               ///< Jm, rad/s³, > 0 (scurve)
  double start_time = 0;                  ///< s: no move starts before this time

  struct Segment {
    double duration = 0;  ///< s
    double accel = 0;     ///< a0 at the segment's start, rad/s²
    double jerk = 0;      ///< rad/s³
  };
  /// The plan, as plain doubles (stored in the simulator's state array).
  struct State {
    double t0 = 0;      ///< s, plan start
    double p0 = 0;      ///< rad
    double v0 = 0;      ///< rad/s
    double target = 0;  ///< rad, where the plan ends
    double t_end = 0;   ///< s, when it ends (t0 when at rest)
    std::array<Segment, 7> segments{};
  };
  static_assert(std::is_trivially_copyable_v<State> && sizeof(State) % sizeof(double) == 0);

  /// At rest at angle p.
  static State Rest(double time, double p);

  /// The command at time t (exact; holds the target after the plan's end).
  CommandSample Evaluate(const State& s, double t) const;

  /// The first time after t (s) at which the plan's polynomial changes (its start, a segment's
  /// end, its end), or +infinity.
  double NextBreak(const State& s, double t) const;

  /// Called at the start of each simulation step [t0, t1] with the step's target: starts a new
  /// plan at max(t0, start_time) when the target changed and the profile allows it then.
  void Update(State* s, double t0, double t1, double target) const;

  /// The rest-to-rest move of `distance` (signed), in segments; exposed for tests.
  std::array<Segment, 7> PlanSCurve(double distance) const;
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_MOTION_PROFILE_H_
