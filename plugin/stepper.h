// The mjstepper.stepper plugin: the adapter between MuJoCo's plugin API and the core drive.
//
// Two kinds of instance share the plugin name:
//   - a drive instance, bound to one or more <actuator><plugin> elements (an implicit instance with
//     its own <config>, or a named <instance> shared by several actuators): actuator capability;
//   - a signal probe, a <sensor><plugin objtype="actuator" objname="..."> with no config: sensor
//     capability, reading the signals of the drive on that actuator.
// State: the drive's StateLayout (core, controller, profile) per bound actuator in plugin_state;
// plugin_data holds the parsed configuration and the actuators' addresses (constant after init),
// and diagnostic flags (which causes of a warning were reported, which windings passed their
// insulation class), never simulation state.
#ifndef MJSTEPPER_PLUGIN_STEPPER_H_
#define MJSTEPPER_PLUGIN_STEPPER_H_

#include <mujoco/mujoco.h>

#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/coupling.h"
#include "core/drive.h"
#include "modes.h"

namespace mjstepper::plugin {

inline constexpr char kPluginName[] = "mjstepper.stepper";

/// The range of |gear| a stepper actuator takes (rotor angle = gear · joint angle): 1e-6 (a rotor
/// turning a millionth of its joint) to 1e6 (a million turns per joint turn) covers every
/// gearbox, lead screw and pulley; beyond, the rotor angle underflows or the joint's motion is
/// below round-off.
inline constexpr double kMinGear = 1e-6;
inline constexpr double kMaxGear = 1e6;

/// "" when the headers and the library agree, else a message naming both versions. Exported (the
/// library hides everything else) for the plugin tests.
[[gnu::visibility("default")]] std::string VersionMismatch(int built_for, int running);

class Stepper {
 public:
  /// Parses and checks the instance; on error warns (naming attribute and value) and returns null.
  static std::unique_ptr<Stepper> Create(const mjModel* m, int instance, bool advice);

  /// The plugin's init: creates the instance into plugin_data; 0, or -1 on error. MuJoCo frees
  /// mjData without destroying the instances made before a failing one, so the model's first
  /// stepper instance checks every later one before any is stored; its errors come first, then
  /// theirs, in model order (each one warned once). Then it judges the timestep on the model's
  /// modes (JudgeModelTimestep, the rule info and run use) and warns once with every failing mode.
  static int Init(const mjModel* m, mjData* d, int instance);

  /// Steppers alive in this process (plugin_data that was never destroyed shows up here).
  [[gnu::visibility("default")]] static int LiveCount();
  ~Stepper();

  /// Appends this instance's steppers (actuator, name, T', detent's worst case) for the modes.
  void AddModalSteppers(const mjModel* m, std::vector<ModalStepper>* out) const;

  /// mjtNums of plugin_state for the instance: the drive's layout, per bound actuator.
  static int StateSize(const mjModel* m, int instance);

  /// Writes the "not started" state (all zero); the drive starts at rest on first use (SPEC §6).
  static void Reset(const mjModel* m, mjtNum* plugin_state, int instance);

  static Stepper& FromData(const mjData* d, int instance) {
    return *reinterpret_cast<Stepper*>(d->plugin_data[instance]);
  }

  /// Called several times per step (RK4 stages, finite differences, mj_forward): pure in mjData.
  /// Actuator capability: writes actuator_force from the state's currents at the step's start.
  /// Sensor capability: writes the probe sensors' signals.
  void Compute(const mjModel* m, mjData* d, int instance, int capability) const;

  /// Called once per step after integration (time already t + h): moves each drive from t to t+h.
  void Advance(const mjModel* m, mjData* d, int instance) const;

  /// Called by mjv_updateScene: adds each rotor's load-angle gauge to the scene (no state change).
  void Visualize(const mjModel* m, const mjData* d, mjvScene* scene, int instance) const;

 private:
  struct Actuator {
    int id = -1;
    int ctrladr = 0;
    int actadr = -1;  // the activation the drive reads instead of ctrl (a dyntype set), or -1
    int outadr = 0;
    int qposadr = -1;            // a joint transmission's joint: θ = gear·qpos[qposadr]
    int tendon = -1;             // a tendon transmission's tendon (plugin/README.md, "Tendons")
    int gauge_joint = -1;        // the hinge the gauge is drawn on, or -1 (none)
    double gauge_radius = 0.02;  // m, the gauge's scale (GaugeRadius, at load)
    double gear = 1;
  };
  /// C-2 / C-3 of core/coupling.h over every started stepper of coupled_: the torques handed to
  /// MuJoCo this step, from the motors' τ0 and stiffness k, with G and a_ext read from d (mass
  /// matrix, forces); writes each one's actuator_force. Called by the first instance of coupled_
  /// only, so that the model's coupled system is solved once per step. `constraint`: the
  /// previous step's qfrc_constraint as kept in the plugin state (ConstraintForces).
  void ConsistentForces(const mjModel* m, mjData* d, const mjtNum* constraint) const;
  /// The sub-stepped rotors (core/substep.h) of every stepper of coupled_ when they are
  /// `substepped`: given R, M⁻¹·Rᵀ (`rows`, n×nv), G and F (every force but theirs, damping
  /// included) as ConsistentForces gathers them, integrates the rotors and their drives over the
  /// step into each slot's tentative state (SubstepSlot), and writes the torques that land
  /// MuJoCo's step on the sub-stepped angles.
  void SubsteppedForces(const mjModel* m, mjData* d, int n, const int* outputs, const mjtNum* rows,
                        const mjtNum* inverse_inertia, const mjtNum* force) const;
  /// A substepped slot's own region, after the constraint forces: kSubstepExtras values (the
  /// SubstepValue indices), then a tentative drive state (state_size_ values) made by compute
  /// and taken by advance.
  mjtNum* SubstepSlot(const mjModel* m, const mjData* d, int instance, int slot) const {
    return d->plugin_state + m->plugin_stateadr[instance] +
           static_cast<long>(actuators_.size()) * state_size_ + 1 + m->nv +
           static_cast<long>(slot) * (kSubstepExtras + state_size_);
  }
  enum SubstepValue : int {
    kSpeedKept = 0,     // 1 once kSpeed and kChord hold a step's end (0: take MuJoCo's speed)
    kSpeed = 1,         // rad/s, the sub-stepped rotor's speed at the last step's end
    kChord = 2,         // rad/s, the speed MuJoCo was asked to land that step at, (θ1 − θ0)/h
    kStamp = 3,         // s, the end time of the step the tentative state was made for
    kNextSpeed = 4,     // rad/s, the tentative kSpeed
    kNextChord = 5,     // rad/s, the tentative kChord
    kStatus = 6,        // the AdvanceStatus of the tentative state's sub-steps (worst)
    kSubstepExtras = 7  // (the count)
  };
  /// The instance's copy of qfrc_constraint at the end of the last step (after its actuators'
  /// slots: a flag, 1 once a step has written it, then nv mjtNums), written by the coupling's
  /// leader in Advance: state, so that restoring a state restores it.
  mjtNum* ConstraintForces(const mjModel* m, mjData* d, int instance) const;
  /// Output `output` of actuator `actuator`: its force this step as far as known during a
  /// plugin's compute (a stepper's motor torque at the step's start, any other actuator's
  /// actuator_force), within the actuator's forcerange.
  static double OtherActuatorForce(const mjModel* m, const mjData* d, int actuator, int output);
  /// The rotor angle at the step's end t1 (qpos already integrated), rad.
  static double RotorAngleAtEnd(const mjModel* m, const mjData* d, const Actuator& a);

  Stepper();
  /// The actuator's command from its ctrl, clamped as MuJoCo would, or from its activation when
  /// it has a dyntype; a bad one (NaN, infinite, beyond mjMAXVAL) holds the drive's command
  /// instead (`state`: the drive's, if started).
  double Command(const mjModel* m, const mjData* d, const Actuator& a,
                 const DriveState* state) const;
  mjtNum* Slot(const mjModel* m, const mjData* d, int instance, int slot) const {
    return d->plugin_state + m->plugin_stateadr[instance] + slot * state_size_;
  }
  // What Advance reports, each once per instance and mjData: a core AdvanceStatus, or these.
  enum Cause : unsigned {
    kCauseStatus = 0,          // + AdvanceStatus: bits 0..5
    kCauseBadTimestep = 8,     // timestep not a positive finite number
    kCauseManyInterrupts = 9,  // timestep raised past the load's interrupt bound
    kCauseSubsteppedRk4 = 10,  // integrator set to RK4 after a sub-stepped load
    kCauseLawRange = 11,       // a winding beyond the temperatures R(T) and Km(T) are made for
  };
  // Restarts at rest, in place, every started slot of `instance` whose stored state no step could
  // have made (Drive::Plausible: a user's write, a corrupt file), warning once: before any force
  // or signal is read from it (issue 33: ±1e300 applied its force for a step).
  void RestartImplausible(const mjModel* m, mjData* d, int instance) const;
  // Warns `message` through mju_warning unless `cause` was reported already; true if it warned.
  bool WarnOnce(unsigned cause, const std::string& message) const;
  // Slot's rotor speed at the step's start, rad/s (the `omega` signal): MuJoCo's, `mujoco`
  // (moment row · qvel), or the sub-stepped rotor's own speed.
  double RotorSpeed(const mjModel* m, const mjData* d, int instance, int slot, double mujoco) const;
  // The state of slot, or the rest state it starts in when it has not started.
  DriveState CurrentState(const mjModel* m, const mjData* d, int instance, int slot) const;
  void ComputeProbe(const mjModel* m, mjData* d, int instance) const;

  std::optional<Drive> drive_;  // empty for a probe
  int state_size_ = 0;          // doubles of plugin_state per actuator: drive_->layout().total()
  bool gauge_ = true;
  Coupling coupling_ = Coupling::kConsistent;
  // The model's stepper actuators with the consistent coupling, found at load (C-3's rows).
  struct CoupledActuator {
    int actuator = -1;
    int instance = -1;  // the drive instance that owns it
    int slot = 0;       // its slot in that instance's plugin_state
    int output = 0;     // its output (moment row, actuator_force)
  };
  std::vector<CoupledActuator> coupled_;
  // ConsistentForces' scratch, sized at load in the instance that solves (this mjData's own
  // instance, so no other thread shares it; not simulation state: every step overwrites it).
  mutable std::vector<double> scratch_;
  mutable std::vector<int> scratch_outputs_;
  // The dofs whose gravity compensation the actuators apply (jnt_actgravcomp), found at load:
  // C-3 counts it among the other forces.
  std::vector<int> gravcomp_dofs_;
  // The substepped leader's, found at load: the dofs MuJoCo's Euler step damps implicitly (dof
  // damping and joint actuators' damping), their damping D (N·m·s/rad or N·s/m), and each coupled
  // stepper's largest stiffness (T' plus the detent's worst case, N·m/rad) for the sub-step count.
  std::vector<int> damped_dofs_;
  std::vector<double> dof_damping_;
  mutable std::vector<double> member_stiffness_;  // (filled at the first step)
  mutable std::vector<double> member_forcing_;    // rad per rad of rotor turn: 4·Nr or h·Nr
  // SubsteppedForces' scratch (as scratch_): the members' drive states and the numbers around them.
  mutable std::vector<DriveState> substep_states_;
  mutable std::vector<double> substep_scratch_;
  // The causes (bit 1 << Cause) already reported by this instance on this mjData: a diagnostic,
  // not simulation state.
  mutable std::atomic<unsigned> warned_{0};
  // Per bound actuator: whether its winding's passing the insulation class was said (heat).
  mutable std::unique_ptr<std::atomic<bool>[]> insulation_warned_;
  std::vector<Actuator> actuators_;  // bound actuators, in id order
};

/// Registers the plugin with MuJoCo (idempotent).
void RegisterStepperPlugin();

}  // namespace mjstepper::plugin

#endif  // MJSTEPPER_PLUGIN_STEPPER_H_
