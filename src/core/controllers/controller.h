// What every controller unit looks like, and what the drive hands it at each tick.
//
// A controller is a leaf (DESIGN §8): const parameters read from its own attributes, its own state
// (plain doubles the drive stores in the simulator's state array), and one Tick that turns a typed
// input into a bridge voltage. The drive owns the clock, the power stage, the windings and the
// sensors; each controller declares which input it reads:
//   - Sample: command, feedback and the phase-current sensors (current-loop controllers);
//   - MechanicalSample: command and position/speed feedback only (no current field at all, so a
//     controller taking it cannot read a current: K(32) needs none, H24).
// The registry (registry.h) is the closed set of controllers the drive can hold.
#ifndef MJSTEPPER_CORE_CONTROLLERS_CONTROLLER_H_
#define MJSTEPPER_CORE_CONTROLLERS_CONTROLLER_H_

#include <concepts>
#include <type_traits>
#include <vector>

#include "core/attributes.h"
#include "core/motor.h"
#include "core/power_stage.h"

namespace mjstepper {

/// Constants of the motor the drive assumes and of its clock, the same at every tick.
struct DriveConstants {
  int rotor_teeth = 50;          ///< Nr
  double resistance = 0.9;       ///< R, Ω
  double inductance = 2.2e-3;    ///< L, H
  double torque_constant = 0.3;  ///< Km, N·m/A
  double isr_period = 50e-6;     ///< T, s: control tick period
  double bus_voltage = 48.0;     ///< Vbus, V (S-13): what a voltage-mode PWM's duty scales
};

/// T' = Nr·Km·|i| (SPEC §1, T(1)): the holding stiffness, N·m/rad, of a rotor held by a current
/// vector i aligned with it: the open-loop drives' stiffness at rest.
inline double OpenLoopStiffness(const DriveConstants& k, PhaseVector rest_current) {
  return k.rotor_teeth * k.torque_constant * std::abs(rest_current);
}

/// The command at tick t_k: θd and its derivatives (from the drive's motion profile, exact).
struct CommandSample {
  double theta = 0;  ///< θd, rad (rotor side)
  double omega = 0;  ///< θ̇d, rad/s
  double accel = 0;  ///< θ̈d, rad/s²
  double jerk = 0;   ///< θ⃛d, rad/s³
};

/// Position and speed feedback at tick t_k.
struct FeedbackSample {
  double theta = 0;  ///< θfb: encoder angle (S-16), rad
  double omega = 0;  ///< ωfb: speed feedback (S-17 estimate, or exact), rad/s

  /// e^{j·Nr·θfb} (cos + j·sin of the measured electrical angle), for the controllers that
  /// commutate on the feedback.
  PhaseVector ElecPhasor(int rotor_teeth) const { return UnitPhasor(rotor_teeth * theta); }
};

/// Everything the drive samples at tick t_k (S-15).
struct Sample {
  CommandSample command;
  FeedbackSample feedback;
  PhaseVector current;       ///< ia + j·ib at t_k, A (ideal current sensors)
  double current_scale = 1;  ///< CoolStep's scale of the run current (sensors/stallguard.h)
  long tick = 0;             ///< k: this tick is at t_k = k·T (exact while |t|/T < 2^53;
                             ///< beyond, a label counted from the clock's anchor: only its
                             ///< residues mean something, as the servo's decimation uses them)

  static Sample From(const Sample& s) { return s; }
};

/// The sample without the current sensors: what a controller with no current feedback reads.
struct MechanicalSample {
  CommandSample command;
  FeedbackSample feedback;

  static MechanicalSample From(const Sample& s) { return {s.command, s.feedback}; }
};

/// What a tick produces: the bridge voltage and the phase currents the controller aims at (its
/// current reference in the phase frame, a signal for plots; A).
struct TickOutput {
  BridgeOutput bridge;
  PhaseVector current_ref;
};

/// A controller at rest (SPEC §6): rotor at θ, command θcmd, speed zero. Rest writes the
/// controller's state and returns the phase currents it holds there.
struct RestInput {
  double theta = 0;      ///< rad
  double theta_cmd = 0;  ///< rad
};

/// How the drive measures speed for this controller unless the user says otherwise.
enum class SpeedFeedback {
  kEstimate,  ///< S-17: backward difference of the encoder angle, then the low-pass
  kExact,     ///< the rotor's true speed (a simulation's ideal sensor)
};

template <class C>
concept ControllerUnit = std::is_trivially_copyable_v<typename C::State> &&
                         (std::is_empty_v<typename C::State> ||
                          sizeof(typename C::State) % sizeof(double) == 0) &&
                         requires(const C c, const DriveConstants& k, const typename C::Input& in,
                                  const PowerStage& stage, typename C::State* state,
                                  const RestInput& rest, const Sample& sample,
                                  const AttributeSource& attrs, const MotorParams& motor) {
  { C::kName } -> std::convertible_to<const char*>;
  { C::kSummary } -> std::convertible_to<const char*>;
  { C::kDefaultSpeedFeedback } -> std::convertible_to<SpeedFeedback>;
  { C::kStiffnessFormula } -> std::convertible_to<const char*>;
  // true: open loop, the drive counts slips of whole electrical cycles (lost_steps); false: a
  // closed position loop, whose error is position_error.
  { C::kCountsSlips } -> std::convertible_to<bool>;
  { C::Attributes() } -> std::same_as<std::vector<const AttributeSpec*>>;
  { C::FromAttributes(attrs, motor, k) } -> std::same_as<C>;
  { C::Input::From(sample) } -> std::same_as<typename C::Input>;
  { c.Tick(k, in, stage, state) } -> std::same_as<TickOutput>;
  { c.Rest(k, rest, state) } -> std::same_as<PhaseVector>;
  { c.HoldingStiffness(k, PhaseVector{}) } -> std::same_as<double>;
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_CONTROLLER_H_
