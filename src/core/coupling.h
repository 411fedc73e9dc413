// How the stepper's torque is handed to the multibody integrator over one timestep h (SPEC §10).
//
// MuJoCo integrates the rotor with semi-implicit (symplectic) Euler: v1 = v0 + h·a(θ0),
// θ1 = θ0 + h·v1. On the stepper's stiff spring (T' on the rotor-side inertia J: ωn = √(T'/J))
// a torque taken at the step's start rings at Ω with sin(Ωh/2) = ωn·h/2: fast by (ωn·h)²/24, 4.7 %
// at ωn·h = 1 (the `explicit` coupling).
//
// The `consistent` coupling hands MuJoCo, instead of τ(θ0), the torque that makes its Euler step
// the exact map of the locally linearised rotor. Linearised about the step's start the rotor-side
// acceleration is a(θ) = a0 − ω²·(θ − θ0), with a0 = τ0/J + a_ext (a_ext the acceleration the
// model's other forces give the rotor coordinate) and ω² = k/J, k = −∂τ/∂θ the stiffness the rotor
// feels this step (currents held). Symplectic Euler on a spring k̃ has trace 2 − h²·k̃/J and
// determinant 1; the exact map has trace 2·cos ωh and determinant 1. With
//     k̃ = σ·k,   σ(u) = 2·(1 − cos √u)/u,   u = ω²h² = k·h²/J               (C-1)
// (cosh for k < 0; σ → 1 − u/12 + u²/360 as u → 0) the two agree: the discrete rotor rings at the
// linearised rotor's own frequency, with no energy gained or lost, at any ωn·h < π. Scaling the
// spring about the linearised equilibrium θ0 + a0/ω² rather than about θ0 keeps every static
// equilibrium where it is (a0 = 0 there): the rotor acceleration handed over is σ·a0, that is
//     τ = σ·τ0 + (σ − 1)·J·a_ext.                                              (C-2)
// Beyond ωh = π no Euler step can ring at ω (its fastest ring is the Nyquist rate); there σ·u is
// held at 3.96, just inside symplectic Euler's stability limit σ·u < 4 (at ωh = π, σ = 4/π²): the
// rotor stays bounded, ringing at about half the step rate. A negative stiffness (a rotor past
// its pull-out angle, falling to the next step) grows as cosh; there σ is held at its value at
// |ω|h = π (2.15), the linearisation being worthless over more. The timestep rule keeps models far
// below both.
//
// Steppers coupled through the mass matrix (an arm's wrist rolls J4 and J6 about parallel axes) see
// each other's springs too. For n steppers with moment rows R, G = R·M⁻¹·Rᵀ (the rotors' inverse
// inertia matrix, symmetric positive definite), K = diag(k) and a_ext = R·M⁻¹·F, the linearised
// rotors obey θ'' = G·(τ0 − K·Δθ) + a_ext, and C-1 applied mode by mode to A = G·K gives
//     τ = G⁻¹·(σ(h²·A)·(G·τ0 + a_ext) − a_ext),                                 (C-3)
// σ(h²·A) = L·σ(h²·Lᵀ·K·L)·L⁻¹ with G = L·Lᵀ (Cholesky): A is similar to the symmetric Lᵀ·K·L, so
// one symmetric eigenproblem serves, any sign of k (G^½ in place of L gives the same σ). For one
// stepper C-3 is C-2.
//
// With φ(u) = (σ(u) − 1)/u, so that σ(X) = I + X·φ(X) for X = h²·A, C-3 needs no G⁻¹:
//     τ = τ0 + h²·K·φ(X)·(G·τ0 + a_ext),   φ(u) = Σⱼ 2·(−1)^(j+1)·u^j/(2j+4)!     (C-4)
// (φ = −1/12 + u/360 − u²/20160 + …). While ‖X‖∞ <= 9 every eigenvalue of X lies below π²
// (where C-1 is not held), and since ‖X^j‖∞ <= ‖X‖∞^j the series' tail is bounded whatever the
// shape of X: at most 13 terms reach round-off, each a matrix-vector product: a handful at the
// steps the timestep rule recommends (‖X‖∞ about 0.04), where the eigenproblem cost some 20 000
// instructions for an arm's six steppers. Beyond it C-3 goes by the eigenproblem. C-4 also holds
// where G is singular (two steppers on one joint: the pair is handed C-2 of their joint, shared in
// proportion to their stiffnesses), which the eigenproblem's route leaves at τ0: for such a G
// (singular, or its Cholesky pivots spread by more than 1e9) the handed torques change from C-4 to
// τ0 where ‖X‖∞ passes 9.
#ifndef MJSTEPPER_CORE_COUPLING_H_
#define MJSTEPPER_CORE_COUPLING_H_

#include <span>

namespace mjstepper {

enum class Coupling {
  kExplicit,    ///< τ(θ0): the torque at the step's start
  kConsistent,  ///< C-2: the exact map of the linearised rotor over the step
  kSubstepped,  ///< R-1 (core/substep.h): the rotors sub-stepped against the frozen load
};

/// The largest ω·h of a stepper mode that keeps the simulation within 1 % of a fine reference with
/// this coupling, as measured (docs/coupling.md): the ring of the rotor (H3) holds to ω·h = 1 with
/// the consistent coupling, but the velocity ripple of the Tsui sweep binds first, within 1 % up to
/// ω·h = 0.2 with it (0.7 %; 1.3 % at 0.25) and up to 0.15 with the explicit one (0.62 %; 1.3 % at
/// 0.2). The one timestep rule (core/timestep_rule.h) takes the strictest of a model's steppers.
double MaxOmegaTimesStep(Coupling coupling);

/// σ(u) of C-1, u = k·h²/J (dimensionless, any sign).
double StiffnessScale(double u);

/// C-2: the torque (N·m) to hand the integrator for a step of h (s), given the motor's torque at
/// the step's start τ0 (N·m), the stiffness k = −∂τ/∂θ (N·m/rad), the rotor-side inertia J
/// (kg·m²) and the other forces' rotor acceleration a_ext (rad/s²). τ0 itself when J or h is not
/// positive and finite.
double ConsistentTorque(double torque, double stiffness, double inertia, double external_accel,
                        double h);

/// C-3 for n coupled steppers: G (1/(kg·m²), n×n, row-major), their stiffnesses k (N·m/rad),
/// torques at the step's start τ0 (N·m) and the other forces' rotor accelerations a_ext (rad/s²);
/// writes the torques to hand the integrator to `out` (n values): by C-4 while ‖h²·G·K‖∞ <= 9,
/// else by the eigenproblem. τ0 itself when an input is not finite (or their products overflow),
/// h not positive, or (beyond C-4's reach) G not positive definite. Throws std::invalid_argument
/// when the spans' sizes disagree. Allocates only for n > 8. (No Eigen type crosses this
/// interface: callers may be built without the core's vector instructions.)
void ConsistentTorques(std::span<const double> inverse_inertia, std::span<const double> stiffness,
                       std::span<const double> torque, std::span<const double> external_accel,
                       double h, std::span<double> out);

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_COUPLING_H_
