// The mechanical (position) controller and commutation shared by Kim 2016's STMMS and its FOC
// baseline, Kim §4, SPEC §3:
//   e1 = θ − θd                                                                K(20)
//   e2 = ė1 + k1p·e1                                                           K(21)
//   e0 = ∫0^t e1 dτ                        (here e0[k] = e0[k−1] + T·e1[k])     K(22)
//   τd = B·ω + τl + J·(θ̈d − k1p·ė1 − k0·e0 − k1·e1 − k2·e2)                    K(24)
//   iad = −(τd/Km)·sin(Nr·θ),  ibd = (τd/Km)·cos(Nr·θ),  i.e. iad + j·ibd = j·(τd/Km)·e^{jNrθ}
//   K(27)
// B, τl and J are the controller's own feed-forward values (they may differ from the plant's).
// With τ̄ = τd the error obeys ė = A·e, A = [0 1 0; 0 −k1p 1; −k0 −k1 −k2]            K(26), K(31)
// and a torque error τ̃ reaches e1 through E1/T̃ = (1/J)·s/det(sI − A)                  K(35)
#ifndef MJSTEPPER_CORE_CONTROLLERS_KIM_MECHANICAL_H_
#define MJSTEPPER_CORE_CONTROLLERS_KIM_MECHANICAL_H_

#include <array>
#include <complex>
#include <vector>

#include "core/controllers/controller.h"

namespace mjstepper {

inline constexpr AttributeSpec kAttrK1p{
    "k1p", "real", "40000 (`stmms`), the case's (`foc`)", "1/s",
    "k1p of K(21), K(24): e2 = ė1 + k1p·e1. `foc` case1 1000, case2 10000 (SPEC §3). > 0."};
inline constexpr AttributeSpec kAttrK0{"k0", "real", "10", "1/s³",
                                       "k0 of K(24), the gain on e0 = ∫e1 dt. ≥ 0."};
inline constexpr AttributeSpec kAttrK1{"k1", "real", "20", "1/s²",
                                       "k1 of K(24), the gain on e1. ≥ 0."};
inline constexpr AttributeSpec kAttrK2{"k2", "real", "100", "1/s",
                                       "k2 of K(24), the gain on e2. > 0."};
inline constexpr AttributeSpec kAttrFfInertia{
    "ff_inertia", "real", "preset J (4.8e-5 for kim2016)", "kg·m²",
    "J in K(24): the controller's own rotor(+load) inertia, which may differ from the plant's "
    "(put the plant's in the actuator's `armature`). > 0."};
inline constexpr AttributeSpec kAttrFfDamping{
    "ff_damping", "real", "preset B (1e-3 for kim2016)", "N·m·s/rad",
    "B in K(24): the controller's viscous feed-forward B·ω. ≥ 0."};
inline constexpr AttributeSpec kAttrFfLoadTorque{
    "ff_load_torque", "real", "preset τl (0.1 for kim2016, else 0)", "N·m",
    "τl in K(24): the load torque the controller feeds forward (the plant's load is a separate "
    "MuJoCo force, see \"Load torque\" in plugin/README.md)."};

struct KimMechanical {
  double k1p = 40000;        ///< 1/s
  double k0 = 10;            ///< 1/s³
  double k1 = 20;            ///< 1/s²
  double k2 = 100;           ///< 1/s
  double inertia = 4.8e-5;   ///< J, kg·m²
  double damping = 1e-3;     ///< B, N·m·s/rad
  double load_torque = 0.1;  ///< τl, N·m

  /// The shared attributes; `k1p_default` is the controller's own.
  static std::vector<const AttributeSpec*> Attributes() {
    return {&kAttrK1p,       &kAttrK0,        &kAttrK1,          &kAttrK2,
            &kAttrFfInertia, &kAttrFfDamping, &kAttrFfLoadTorque};
  }
  static KimMechanical FromAttributes(const AttributeSource& a, const MotorParams& motor,
                                      double k1p_default) {
    using Rule = AttributeSource::Rule;
    // J defaults to the motor's rotor_inertia, which may be 0 (the model carries the rotor): the
    // controller still needs its own J > 0 (foc divides by it; a NaN state, found by tests/fuzz).
    if (!a.Raw(kAttrFfInertia) && !(motor.rotor_inertia > 0)) {
      ThrowBad(kAttrFfInertia, "0",
               "must be > 0; with rotor_inertia = 0 it has no default: set ff_inertia to the "
               "rotor's (and load's) inertia (kg·m²)");
    }
    return {.k1p = a.Real(kAttrK1p, k1p_default, Rule::kPositive),
            .k0 = a.Real(kAttrK0, 10, Rule::kNonNegative),
            .k1 = a.Real(kAttrK1, 20, Rule::kNonNegative),
            .k2 = a.Real(kAttrK2, 100, Rule::kPositive),
            .inertia = a.Real(kAttrFfInertia, motor.rotor_inertia, Rule::kPositive),
            .damping = a.Real(kAttrFfDamping, motor.viscous_damping, Rule::kNonNegative),
            .load_torque = a.Real(kAttrFfLoadTorque, motor.load_torque, Rule::kAny)};
  }

  /// The tracking errors at one tick.
  /// The spring on e1 of the closed loop K(26), J·(k1 + k1p·k2), N·m/rad: its holding stiffness.
  double Stiffness() const { return inertia * (k1 + k1p * k2); }

  struct Errors {
    double e1 = 0;      ///< θ − θd, rad, K(20)
    double e1_dot = 0;  ///< ω − θ̇d, rad/s
    double e2 = 0;      ///< ė1 + k1p·e1, rad/s, K(21)
  };
  Errors Track(const MechanicalSample& in) const {
    const double e1 = in.feedback.theta - in.command.theta;
    const double e1_dot = in.feedback.omega - in.command.omega;
    return {.e1 = e1, .e1_dot = e1_dot, .e2 = e1_dot + k1p * e1};
  }

  /// τd of K(24), N·m, given the errors and e0 = ∫e1 (rad·s).
  double DesiredTorque(const MechanicalSample& in, const Errors& e, double e0) const {
    return damping * in.feedback.omega + load_torque +
           inertia * (in.command.accel - k1p * e.e1_dot - k0 * e0 - k1 * e.e1 - k2 * e.e2);
  }

  /// K(27): iad + j·ibd = j·(τd/Km)·e^{jx}, A.
  static PhaseVector Commutate(double torque, double torque_constant, PhaseVector elec_phasor) {
    return PhaseVector(0, torque / torque_constant) * elec_phasor;
  }

  /// The characteristic polynomial det(sI − A) = s³ + c2·s² + c1·s + c0 of K(26): {c2, c1, c0}.
  std::array<double, 3> Characteristic() const { return {k1p + k2, k1 + k1p * k2, k0}; }

  /// J·|E1/T̃|(j·2π·f) of K(35), rad/(N·m)·kg·m² (i.e. |s/det(sI − A)|).
  double Sensitivity(double frequency) const;
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_KIM_MECHANICAL_H_
