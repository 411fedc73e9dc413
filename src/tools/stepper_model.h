// Loads an MJCF model for the tools: loads the plugin library, adds a signal sensor (a
// mjstepper.stepper probe) to every stepper actuator that has none, compiles, and lists the
// steppers. Only MuJoCo's public API and the plugin's documented config and sensor layout are used.
#ifndef MJSTEPPER_TOOLS_STEPPER_MODEL_H_
#define MJSTEPPER_TOOLS_STEPPER_MODEL_H_

#include <mujoco/mujoco.h>

#include <iosfwd>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "config_overrides.h"
#include "core/coupling.h"
#include "core/drive.h"
#include "core/timestep_rule.h"
#include "modes.h"

namespace mjstepper::tools {

struct StepperActuator {
  int actuator = -1;    ///< actuator id
  std::string name;     ///< actuator name
  int sensor_adr = -1;  ///< first of kNumSignals values in sensordata
  DriveConfig config;   ///< parsed from the instance's <config> with the plugin's own parser
  Coupling coupling = Coupling::kConsistent;  ///< the torque handed to MuJoCo (core/coupling.h)
  int ctrladr = 0;
  int outadr = 0;
};

/// The actuator's gear (rotor angle per joint unit): actuator_gear is per force output (nout x 6).
inline double Gear(const mjModel* m, const StepperActuator& s) {
  return m->actuator_gear[6 * s.outadr];
}

/// A linear axis's rotor rad per metre of its carriage, for profiles in m, mm, m/s, … and the
/// carriage's columns: the gear of a stepper on a slide joint or a tendon (θ = gear·x), gear/r on a
/// hinge whose <config> declares its carriage (a pulley or lead screw of r m per rad,
/// core/transmission.h); none on any other hinge, whose profiles are rotor angles only.
std::optional<double> RadPerMetre(const mjModel* m, const StepperActuator& s);

/// A linear stepper's carriage, as the log shows it (issue 32, item 3): its position and speed
/// from the step-start quantities MuJoCo leaves after mj_step (actuator_length, ten_length), and
/// the motor's force on it.
struct Carriage {
  double rad_per_metre = 0;  ///< the rotor's rad per m of the carriage (RadPerMetre)
  /// A hinge with a declared pulley that winds a fixed tendon with a slide joint in it (a belt
  /// written into the model, models/belt_axis.xml): the carriage is the belt's far end, the
  /// tendon's length less the hinge's share, Σ coef·q over its other joints (CoreXY's belt A:
  /// x + y). -1: the carriage is the rotor's travel, actuator_length / rad_per_metre.
  int belt = -1;
  double belt_coef = 0;  ///< the belt's coefficient on the hinge, m per rad of the joint
  double gear = 1;       ///< rotor rad per rad of the joint

  double Position(const mjData* d, const StepperActuator& s) const;  ///< m
  double Speed(const mjData* d, const StepperActuator& s) const;     ///< m/s
  /// N: a rotor torque τ (N·m) at the carriage, τ·rad_per_metre (the gear train's losses aside).
  double Force(double torque) const { return torque * rad_per_metre; }
};

/// The stepper's carriage when it drives a linear axis (RadPerMetre), else none.
std::optional<Carriage> CarriageOf(const mjModel* m, const StepperActuator& s);

/// What the stepper drives, for messages: "hinge joint 'shaft'", "tendon 'belt'".
std::string TransmissionTarget(const mjModel* m, const StepperActuator& s);

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

struct SpecDeleter {
  void operator()(mjSpec* s) const { mj_deleteSpec(s); }
};
using SpecPtr = std::unique_ptr<mjSpec, SpecDeleter>;

struct StepperModel {
  ModelPtr model;
  std::vector<StepperActuator> steppers;
};

/// Compiles an edited spec; throws std::runtime_error with MuJoCo's error, each line once (the
/// plugin's own message among them).
ModelPtr CompileSpec(mjSpec* spec, const mjVFS* vfs = nullptr);

/// Loads the plugin shared library once: $MJSTEPPER_PLUGIN if set, else the one built beside the
/// tools. Throws std::runtime_error when MuJoCo does not then know mjstepper.stepper.
void LoadPluginLibrary();

/// While one lives, the plugin's own load warning on the timestep (core/timestep_rule.h's
/// Summary, "mjstepper: timestep …") is not shown: the tool judges the timestep itself and prints
/// the whole verdict (run, info), so each warning is shown once.
class ToolJudgesTimestep {
 public:
  ToolJudgesTimestep();
  ~ToolJudgesTimestep();
  ToolJudgesTimestep(const ToolJudgesTimestep&) = delete;
  ToolJudgesTimestep& operator=(const ToolJudgesTimestep&) = delete;
};

/// Throws std::runtime_error with MuJoCo's own message on any load or compile error. `overrides`
/// change steppers' <config> values for this load only (config_overrides.h). `text`, when given,
/// is the MJCF itself, read in place of the file `path` (which then only names it); it takes no
/// overrides.
StepperModel LoadStepperModel(const std::string& path,
                              const std::vector<ConfigOverride>& overrides = {},
                              const std::string& text = "");

/// The sensordata address of the model's accelerometer sensor `name` (a virtual ADXL345's input,
/// resonance.h); throws std::invalid_argument naming it when there is none.
int AccelerometerAddress(const mjModel* m, const std::string& name);

/// "" while the run is sound; else what MuJoCo found when it reset the simulation (a bad qpos,
/// qvel or qacc: mjWARN_BADQPOS/QVEL/QACC, counted in d->warning), at time t (s).
std::string InstabilityMessage(const mjData* d, double t);

/// Sets the constant load torque τl (N·m) of the load actuator `name`: a non-plugin actuator with
/// a fixed zero gain and an affine bias (plugin/README.md, "Load torque"), whose force is then
/// biasprm[0] = −τl, against positive motion whatever the speed (Kim's τl, S-7). Throws
/// std::invalid_argument naming the actuator and value when it is not such an actuator or τl is
/// not finite.
void SetLoadTorque(mjModel* m, const std::string& name, double torque);

/// Sets body `name`'s mass to `mass` (kg), scaling its inertia with it (same shape, same centre of
/// mass), and recomputes MuJoCo's constants (mj_setConst): a payload changed for one run. Throws
/// std::invalid_argument naming the body and value when there is no such body or mass is not
/// finite and > 0.
void SetBodyMass(mjModel* m, const std::string& name, double mass);

/// A stepper's holding resonance with the other joints held (the rigid case, T(1)).
struct StepperResolution {
  double stiffness = 0;         ///< T', N·m/rad (Drive::HoldingStiffness)
  double detent_stiffness = 0;  ///< Σh h·Nr·Kdh, N·m/rad: the detent's worst case
  double inertia = 0;           ///< rotor-side, kg·m² (ReflectedInertia)
  double omega_n = 0;           ///< √(T'/J), rad/s: the holding resonance (T(1))
};
StepperResolution Resolution(const mjModel* m, const StepperActuator& s);

/// The steppers as the modes see them (plugin/modes.h): actuator, name, T' and the detent's
/// worst-case stiffness, in the model's order.
std::vector<plugin::ModalStepper> ModalSteppers(const StepperModel& sm);

/// The one timestep rule (core/timestep_rule.h) on the model's modes at qpos0 or keyframe `key`,
/// as the plugin's load warning judges it.
TimestepVerdict CheckTimestep(const StepperModel& sm, int key = -1);

/// The rule as every experiment applies it (run, sweep, map, pullout, size; README, "The
/// command"): a stepper mode too fast for the step refuses the experiment with
/// std::invalid_argument naming every failing mode, the largest step that passes them all and
/// --allow-coarse; with `allow_coarse`, and for a mode without a stepper, the same text is
/// printed to `out` once as a warning. `subject` names the model in the message.
void ApplyTimestepRule(const StepperModel& sm, int key, const std::string& subject,
                       bool allow_coarse, std::ostream& out);

/// Long jobs are estimated before they run (issue 33: a sizing of 5 000 waypoints ran for minutes
/// without a word): a job's wall time is its steps times WallTimePerStep, and an estimate above
/// kLongJob (s) is said even without progress, with how to stop it.
inline constexpr double kLongJob = 60;
/// Seconds of wall time per step of `m` from the pose of `pose` (an mjData of a model with the
/// same joints: only its qpos is read; none: qpos0), timed over 50 steps of a fresh mjData.
double WallTimePerStep(const mjModel* m, const mjData* pose = nullptr);
/// "WHAT: about N s of wall time" to `out` when `progress`, or when `seconds` > kLongJob.
void SayEstimate(std::ostream& out, bool progress, const std::string& what, double seconds);

/// A switching chopper's fastest steady cycle, Hz (averaged_bridge.h's FastestCycle: its own rules
/// on a linear cycle, a tenth to all of its peak, drops within ±Vbus/2); 0 for any other drive and
/// for fidelity = averaged.
double SwitchingCycle(const DriveConfig& c);

/// "" or a warning that the model integrates with MuJoCo's RK4, with the measured cost in fidelity
/// (plugin/README.md, "Integrators"): issue 32, item 8.
std::string IntegratorWarning(const mjModel* m);

/// "" or a note that the model's timestep is above kSubsteppedMeasuredStep (core/substep.h) while
/// a stepper is sub-stepped: a step at which the coupling's fidelity is not measured.
std::string SubstepNote(const StepperModel& sm);

/// One resonant speed of a stepper: detent (or step) harmonic h of its motor excites mode `mode`
/// at rotor speed n_h = 60·f/(h·Nr) r/min (SPEC §2-3: h·Nr·n/60 = f).
struct ResonantSpeed {
  int mode = 0;              ///< index in the modes, 0 = the slowest
  double frequency = 0;      ///< Hz
  double participation = 0;  ///< the stepper's share of the mode's potential energy
  int order = 0;             ///< h
  double speed = 0;          ///< r/min of the rotor
};

/// The harmonic orders whose resonant speeds `info` lists: the motor's detent orders, or Tsui's h
/// = 1, 2, 4 (S-5) when it lists none (the full step excites h = 4: four per electrical cycle).
std::vector<int> ExcitationOrders(const DriveConfig& c);

/// Every resonant speed of stepper `index` (in ModalSteppers' order): for each mode it takes part
/// in (participation >= plugin::kMinParticipation), each order of ExcitationOrders; by mode, then
/// by order.
std::vector<ResonantSpeed> ResonantSpeeds(const std::vector<plugin::Mode>& modes, size_t index,
                                          const DriveConfig& c);

/// Rotor-side inertia seen by the actuator at qpos0, kg·m² (armature included), from its moment
/// row r = ∂θ/∂q (gear on a joint, gear·∂L/∂q on a tendon): the dofs the row moves are free, every
/// other dof is held, J = 1/(r_S·M_SS⁻¹·r_Sᵀ) over the row's dofs S. On a joint that is
/// M[dof, dof]/gear² (computed so, to the bit); on a fixed tendon over one joint the same.
/// With `pose`, at its qpos (a model with m's layout) instead of qpos0.
double ReflectedInertia(const mjModel* m, int actuator, const mjData* pose = nullptr);

/// The actuator's moment row at d's pose (after mj_forward or mj_fwdPosition): ∂θ/∂q, dense over
/// the nv dofs (gear at the joint's dof on a joint transmission; gear·∂L/∂q on a tendon).
std::vector<double> MomentRow(const mjModel* m, const mjData* d, int actuator);

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_STEPPER_MODEL_H_
