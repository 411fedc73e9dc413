// The model's modes, linearised at qpos0 or a keyframe (issue 19): the generalised eigenproblem
// K·v = ω²·M·v with M from mj_fullM, K = Σ k·a·aᵀ over the model's springs (hinge and slide joint
// stiffness, tendon stiffness along the tendon's Jacobian) and each stepper's holding stiffness T'
// along its actuator's moment row (which holds the gear: joint and tendon transmissions alike),
// in the null space of the equality constraints and the joint and tendon limits active there
// (held; contacts are not: modes.cc, Held). Gravity's own stiffness, dof and tendon friction and
// ball or free joints' springs are left out; rigid-body modes (ω = 0) are dropped. Used by the
// plugin's load warning and by the tools (`mjstepper info`, `run`), so that both judge the timestep
// on the same numbers (core/timestep_rule.h).
#ifndef MJSTEPPER_PLUGIN_MODES_H_
#define MJSTEPPER_PLUGIN_MODES_H_

#include <mujoco/mujoco.h>

#include <string>
#include <vector>

#include "core/drive.h"
#include "core/timestep_rule.h"

namespace mjstepper::plugin {

/// A stepper as the modes see it.
struct ModalStepper {
  int actuator = -1;            ///< actuator id
  std::string name;             ///< actuator name
  double stiffness = 0;         ///< T', N·m/rad on the rotor (Drive::HoldingStiffness)
  double detent_stiffness = 0;  ///< Σh h·Nr·Kdh, N·m/rad: the detent's worst case
  /// The largest ω·h its coupling keeps within 1 % (core/coupling.h, MaxOmegaTimesStep).
  double max_omega_h = kMaxOmegaTimesStep;
  /// Sub-stepped (core/substep.h): its rotor's spring is integrated within the step, not by
  /// MuJoCo, so the timestep rule leaves it out of the modes it judges.
  bool substepped = false;
  /// Takes STEP/DIR input (input = steps): the verdict then recommends the step a move's ringing
  /// needs (core/timestep_rule.h, kRingingOmegaTimesStep).
  bool step_input = false;
};

/// A stepper takes part in a mode when at least this fraction of the mode's potential energy is in
/// its holding stiffness: 1 % keeps a belt mode in which the rotor moves little (3 % on
/// models/belt_axis.xml) and drops the steppers of a mode that is a spring far from them.
inline constexpr double kMinParticipation = 0.01;

struct Mode {
  double omega = 0;  ///< rad/s
  /// Per ModalStepper, in their order: the fraction of the mode's potential energy in its T'.
  std::vector<double> participation;
  /// Per ModalStepper: for a sub-stepped one, the fraction of the mode's kinetic energy in its
  /// rotor (armature·(moment row·v)²); 0 for the others. A mode that moves a sub-stepped rotor is
  /// a stepper's mode whatever spring makes it: R-1 holds the other forces over the step.
  std::vector<double> rotor_motion;
  /// The spring terms holding at least kMinParticipation of its energy, largest first, e.g.
  /// "stepper 'shaft' 61 %, joint 'coupling' 39 %".
  std::string springs;
  /// The term with the most energy: "joint 'coupling'", "tendon 'belt'" or "stepper 'shaft'".
  std::string dominant;
  /// Some stepper's participation, or a sub-stepped rotor's motion, >= kMinParticipation.
  bool stepper() const;
};

/// The modes in increasing frequency. `key` >= 0: at that keyframe, else at qpos0. With
/// worst_case, each stepper's stiffness is T' + detent_stiffness (where both peak: what the
/// timestep must resolve); else T' (the resonances a speed excites). Throws std::runtime_error
/// when M restricted to the free directions is not positive definite.
std::vector<Mode> ComputeModes(const mjModel* m, const std::vector<ModalStepper>& steppers,
                               int key = -1, bool worst_case = false);

/// The timestep rule on the model's worst-case modes (core/timestep_rule.h), at m->opt.timestep
/// and the strictest coupling's ω·h; sub-stepped steppers' springs are left out (the rule then
/// follows the model's mechanical modes: SPEC §11).
TimestepVerdict JudgeModelTimestep(const mjModel* m, const std::vector<ModalStepper>& steppers,
                                   int key = -1);

/// The rule's view of one mode: "mode 2 at ... (stepper 'shaft' 61 %, joint 'coupling' 39 %)".
RuleMode ToRuleMode(const Mode& mode, int index);

}  // namespace mjstepper::plugin

#endif  // MJSTEPPER_PLUGIN_MODES_H_
