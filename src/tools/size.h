// `mjstepper size`: does each joint's motor, drive and bus carry a move?
//
// A move is a list of joint waypoints (poses): from the model's start pose the arm goes through
// each waypoint in turn and back to the start, one cycle, every joint through its drive's own
// motion profile (trapezoid or S-curve) at its speed and acceleration, all joints leaving a pose
// together once the slowest has arrived and `dwell` has passed. Size then
//  1. each joint's torque-speed demand: the torque its joint needs to follow its drive's plan
//     exactly (MuJoCo's inverse dynamics, mj_inverse, with every stepper's joint on its plan and
//     every other dof held at the start pose: the rigid arm's need, gravity, inertia and damping
//     included, the actuator's own damping left to the bench's curve), against the commanded
//     speed, rotor side (qfrc_inverse/gear − B·ω); and one cycle run
//     (Run, at the model's own timestep) for what the motor then does: its torque τm + τdet
//     averaged over kDemandWindow, its lost steps and its heat. (A stepper on a tendon has no
//     single dof: its demand is the simulated motor torque.)
//  2. simulates each motor's pull-out curve (PullOut) with its drive and bus, on a bench: the
//     same <config> (its motion profile off) on a rotor of the joint's rotor-side inertia at the
//     start pose (ReflectedInertia, the other joints held) and the actuator's damping, no gravity
//     or friction;
//  3. compares them: at each sample the margin 1 − |τ|/T_po(|ω|) (the curve interpolated
//     linearly in speed; beyond the curve, (T_po − |τ|)/|τ|, minus the share of the demand the
//     motor lacks, down to −1), the worst one, and the full steps the drive counted as lost;
//  4. with the heat model, carries the cycle's copper loss over N cycles (RiseUnderCurrent: the
//     cycle's mean ia² + ib², R(T_w) updated every cycle) and gives the winding's temperature
//     after them and in continuous duty, beside the insulation class's limit.
// Torques and speeds are rotor-side (the motor's own); the gear is in the table. On a linear axis
// (README, "Linear axes") the table and the CSVs give them at the carriage too, in mm/s and N.
#ifndef MJSTEPPER_TOOLS_SIZE_H_
#define MJSTEPPER_TOOLS_SIZE_H_

#include <iosfwd>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "options.h"  // ParseJointValues
#include "runner.h"
#include "sweep.h"

namespace mjstepper::tools {

/// The simulated motor torque is averaged over this window, s: a pull-out torque is a mean over
/// the electrical cycle (6 ms at 20 rad/s for Nr = 50), while the instantaneous torque carries the
/// microstep and detent ripple on top.
inline constexpr double kDemandWindow = 0.01;

/// The most steps of a sizing's cycle: every step's records are kept (about 20 doubles per
/// stepper), so this bounds its memory (a cycle of 1000 s at 0.1 ms).
inline constexpr double kMaxSizeSteps = 1e7;

struct SizeOptions {
  /// The model and how it runs: model, overrides (--set), masses, keyframe, allow_coarse, render,
  /// log, progress. Size sets ctrl, duration and keep_traces.
  RunOptions run;
  /// Actuator → its joint's waypoints, one per pose, e.g. "30,60deg" (ParseJointValues; a hinge
  /// in deg or rad, a slide in mm or m); every named actuator has as many. Unnamed steppers hold.
  std::map<std::string, std::string> moves;
  /// Actuator → joint-side speed ("90deg/s") and acceleration ("600deg/s²") of its drive's
  /// profile; default: the drive's profile_speed and profile_accel over the gear.
  std::map<std::string, std::string> speeds, accelerations;
  double dwell = 0.25;      ///< s at each pose
  int cycles = 1;           ///< N: the winding temperature after N cycles
  int pullout_points = 12;  ///< speeds of each pull-out curve, 0 to 1.15 × the joint's top speed
  int threads = 0;          ///< pull-out workers; 0: one per core
  std::string out;          ///< the output prefix, checked before the run (WriteSizeOutputs)
};

struct SizeJoint {
  std::string name;   ///< actuator
  std::string motor;  ///< the `motor` attribute
  std::string drive;  ///< the controller's name
  double gear = 1;    ///< rotor angle per joint unit
  /// A linear axis's rotor rad per m of its carriage (RadPerMetre), in whose units the table adds
  /// a line and the CSVs columns (mm/s, N: README, "Linear axes"); 0 on a rotary joint.
  double rad_per_metre = 0;
  std::vector<double> time;           ///< s, each step's start
  std::vector<double> speed;          ///< rad/s, the drive's commanded speed (rotor side)
  std::vector<double> torque;         ///< N·m, the demand: the torque the plan needs (rotor side)
  std::vector<double> motor_speed;    ///< rad/s, simulated, averaged over kDemandWindow
  std::vector<double> motor_torque;   ///< N·m, simulated τm + τdet, averaged over kDemandWindow
  bool inverse_dynamics = true;       ///< the demand is mj_inverse's (else the motor's torque)
  std::vector<PullOutPoint> pullout;  ///< the bench's curve
  double bench_inertia = 0;           ///< kg·m², rotor side
  double peak_speed = 0;              ///< rad/s, max |ω|
  double peak_torque = 0;             ///< N·m, max |τ| of the demand
  double worst_time = 0;              ///< s, where the margin is least
  double worst_speed = 0, worst_torque = 0, worst_pullout = 0;  ///< there: rad/s, N·m, N·m
  double margin = 0;  ///< at the worst point: 1 − |τ|/T_po, or (T_po − |τ|)/|τ| beyond the curve
  double lost_steps = 0;          ///< full steps by the cycle's end (signed, as the drive counts)
  bool heat = false;              ///< the heat model is on
  double current_squared = 0;     ///< A², the cycle's mean ia² + ib²
  double temperature_cycle = 0;   ///< °C, T_w after the simulated cycle
  double temperature = 0;         ///< °C, T_w after N cycles
  double temperature_steady = 0;  ///< °C, T_w in continuous duty (+inf: runaway)
  double insulation_limit = 0;    ///< °C
};

struct SizeResult {
  double cycle_time = 0;  ///< s
  int cycles = 1;
  std::vector<double> pose_times;  ///< s, when each pose's move starts (the last: back to start)
  std::vector<SizeJoint> joints;   ///< every stepper, in model order
  RunResult run;                   ///< the simulated cycle
};

/// Throws std::invalid_argument naming a bad option or value, std::runtime_error for the rest.
SizeResult Size(const SizeOptions& options, std::ostream& progress);

/// The per-joint files of an output prefix: PREFIX_JOINT.csv (the demand and the curve) and
/// PREFIX_JOINT.png.
std::vector<std::string> SizeJointOutputs(const std::string& prefix, const std::string& joint);

/// PREFIX.csv (the table) and each joint's CSV; every file whole (CsvWriter / OutputFile).
void WriteSizeCsvs(const std::string& prefix, const SizeResult& result);

/// The table as printed: one line per joint.
void PrintSizeTable(const SizeResult& result, std::ostream& out);

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_SIZE_H_
