// The sub-stepped rotor (SPEC §11): within one multibody step of h, the rotors' fast dynamics (the
// motor's nonlinear torque, S-4 with detent, from the drive's currents, which move with them)
// integrated against the load as the rest of the model presents it over the step.
//
// The load is frozen at the step's start. For n rotors with angles θ (rad, rotor side) and
// speeds ω (rad/s), on moment rows R (MuJoCo's actuator_moment, which hold the gear):
//     θ'' = G·τ(θ, i) + a_x − B·(ω − c0),                                      
// G = R·M⁻¹·Rᵀ (the rotors' inverse inertia matrix, 1/(kg·m²)), a_x = R·M⁻¹·F the other forces'
// rotor acceleration with the dofs' velocities at the step's start (whose rotor speeds are c0),
// and B = R·M⁻¹·D·M⁻¹·Rᵀ·G⁻¹ (1/s) the dofs' viscous damping D as the rotors feel it when they
// move away from c0 along the direction a rotor torque moves the model, M⁻¹·Rᵀ. is
// integrated in N sub-steps δ = h/N, each one C-3 (core/coupling.h) on the sub-step: the exact
// map of the linearised rotors over δ, with the stiffness −∂τ/∂θ and the acceleration at its
// start; after each, every drive is advanced over the sub-step to its rotor's new angle (the
// back-EMF follows the sub-stepped path), so the currents that make the next torque are the
// ones the rotor's own motion left. N is chosen (by the caller, SubstepCount) so that the stiffest
// rotor mode has ω·δ <= kSubstepRingOmegaTimesStep and the torque's fastest forcing at the
// rotors' speeds (the full-step ripple at 4·Nr·|ω|, or a higher detent harmonic) ω·δ <=
// kSubstepOmegaTimesStep: the rotor's ring and ripple are resolved whatever h is.
//
// The step's end angles θ1 are handed to the multibody integrator as positions (the plugin picks
// the torque that makes MuJoCo's step land there, plugin/stepper.cc); the end speeds ω1 are kept
// in the plugin's state, since MuJoCo's own velocity after such a step is the chord (θ1 − θ0)/h.
#ifndef MJSTEPPER_CORE_SUBSTEP_H_
#define MJSTEPPER_CORE_SUBSTEP_H_

#include <span>
#include <utility>

namespace mjstepper {

/// What the sub-stepping asks of the n motors and their drives.
class SubsteppedMotors {
 public:
  virtual ~SubsteppedMotors() = default;
  /// Motor i's torque (N·m) and stiffness −∂τ/∂θ (N·m/rad) at rotor angle θ (rad), from its
  /// drive's currents now; `speed` (rad/s) for a gear train's efficiency.
  virtual std::pair<double, double> TorqueAndStiffness(int i, double theta, double speed) = 0;
  /// Moves drive i from t0 to t1 (s), its rotor going linearly to θ1 (rad).
  virtual void Advance(int i, double t0, double t1, double theta1) = 0;
};

/// The frozen load of R-1 for n rotors (row-major n×n matrices).
struct RotorLoad {
  std::span<const double> inverse_inertia;  ///< G, 1/(kg·m²)
  std::span<const double> acceleration;     ///< a_x, rad/s², at speeds c0
  std::span<const double> damping;          ///< B, 1/s (empty: none)
  std::span<const double> reference_speed;  ///< c0, rad/s
};

/// The largest ω·δ of a sub-step for the torque's fastest forcing at the rotors' speeds (what a
/// sub-step cannot make exact is the torque held over it while the drive moves the currents).
/// Measured on the Tsui rotor at 20 rad/s and 1 ms (docs/coupling.md, "The sub-stepped rotor"):
/// the velocity ripple is +0.6 % of the 10 µs reference's at 0.2, +1.0 % at 0.3, +2.1 % at 0.4
/// and +5.2 % at 0.8, with one bound for the ring and the forcing. 0.3 costs two thirds of 0.2.
inline constexpr double kSubstepOmegaTimesStep = 0.3;

/// The largest ω·δ of a sub-step for the stiffest rotor mode alone. Its C-3 makes the linearised
/// ring exact at any ω·δ; the ring's bound is looser than the forcing's (docs/coupling.md, "A
/// looser bound for the ring"): at 0.6 against 0.3, PAROL6 holding at 1 ms takes 4 sub-steps, not
/// 8 (15 % fewer instructions per step), its load angles over the pick-and-place move by 0.05 %
/// at most, arm3's lost steps stay equal to 2 ms and the Tsui ring frequency stays within 0.5 %.
/// At 0.8 arm3's lost steps differed at 1.7 and 2 ms (+144 against +148 full steps).
inline constexpr double kSubstepRingOmegaTimesStep = 0.6;

/// The largest MuJoCo step (s) at which the sub-stepped coupling's fidelity is measured against a
/// 10 µs reference (docs/coupling.md, "The sub-stepped rotor": the Tsui ring and ripple, arm3's
/// lost steps, PAROL6's load angles, pull-out, StealthChop's lag; issue 30, item 3). Where no
/// mode bounds the step (a rigid arm's only springs are its sub-stepped steppers'), the tools
/// recommend no more than this and note a step above it as unmeasured.
inline constexpr double kSubsteppedMeasuredStep = 2e-3;

/// The most sub-steps a step takes: beyond, a rotor's ω·δ passes its bound (a step of h with a
/// forcing's ω·h > 300: one that turns about 50 times per step).
inline constexpr int kMaxSubsteps = 1000;

/// N for a step of h (s) whose stiffest rotor mode is `ring` and whose fastest forcing is
/// `forcing` (rad/s each): the least N with ring·h/N <= kSubstepRingOmegaTimesStep and
/// forcing·h/N <= kSubstepOmegaTimesStep, at least 1 and at most kMaxSubsteps.
int SubstepCount(double ring, double forcing, double h);

/// An upper bound (rad/s) on the fastest linearised mode of R-1, √‖G·K‖∞, for the rotors'
/// largest stiffnesses K (N·m/rad, T' plus the detent's worst case).
double FastestRotorMode(std::span<const double> inverse_inertia, std::span<const double> stiffness);

/// Integrates R-1 from t0 to t1 in `substeps` sub-steps: θ and ω (n each) hold the start and
/// receive the end. `scratch` holds at least 4·n doubles, 4·n + n² with damping. Throws
/// std::invalid_argument when the sizes disagree.
void IntegrateRotors(const RotorLoad& load, SubsteppedMotors& motors, double t0, double t1,
                     int substeps, std::span<double> theta, std::span<double> omega,
                     std::span<double> scratch);

/// What MuJoCo's step does with the handed torques: its Euler step takes the dofs' viscous damping
/// D (dof damping and joint actuators' damping, diagonal) implicitly, v1 = v0 + h·(M + h·D)⁻¹·f.
/// With E the columns of the s damped dofs (Woodbury on M + h·E·D_s·Eᵀ), for n rotors:
struct Landing {
  std::span<const double> inverse_inertia;  ///< G = R·M⁻¹·Rᵀ, n×n, 1/(kg·m²)
  std::span<const double> damped_rows;      ///< U = R·M⁻¹·E, n×s
  std::span<const double> damped_block;     ///< Q = Eᵀ·M⁻¹·E, s×s
  std::span<const double> step_damping;     ///< h·D of the s damped dofs (each > 0)
  std::span<const double> acceleration;     ///< a_x = R·M⁻¹·F, rad/s² (F: all but the rotors)
  std::span<const double> damped_force;     ///< Eᵀ·M⁻¹·F, s
  std::span<const double> start_speed;      ///< c0 = R·v0, rad/s
};

/// the torques (N·m, n) that make MuJoCo's step land the rotors at speeds `chord` (rad/s,
/// n), so that its positions θ0 + h·chord are the sub-stepped ones: with K = (h·D)⁻¹ + Q,
///     G̃ = G − U·K⁻¹·Uᵀ,   ã = a_x − U·K⁻¹·Eᵀ·M⁻¹·F,   τ = G̃⁻¹·((chord − c0)/h − ã)   
/// (G and a_x when s = 0). G̃ singular (two rotors on one coordinate): the least-squares torques
/// of least norm. Returns false (out untouched) when an input is not finite or h is not positive.
bool LandingTorques(const Landing& landing, std::span<const double> chord, double h,
                    std::span<double> out);

/// B of R-1, 1/s (n×n, row-major): P·G⁻¹ with P = R·M⁻¹·D·M⁻¹·Rᵀ (n×n). Zero when G is not
/// positive definite.
void RotorDamping(std::span<const double> inverse_inertia, std::span<const double> p,
                  std::span<double> out);

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_SUBSTEP_H_
