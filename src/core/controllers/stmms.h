// Simplified torque modulated microstepping (STMMS), Kim 2016 §4 eq. (20)-(32), SPEC §3.
//
// The mechanical controller and commutation of kim_mechanical.h give τd and (iad, ibd), then the
// electrical controller is feed-forward only:
//   va = R·iad − Km·ω·sin(Nr·θ),   vb = R·ibd + Km·ω·cos(Nr·θ)                       K(28), K(32)
// i.e. v = R·id + e with the back-EMF e = j·Km·ω·e^{jx} (S-2) cancelled. With no current feedback
// the current error decays at R/L on its own (the boundary layer of K(17)); the tracking error
// is O(L) during motion and zero at rest (Kim Theorem 1).
// Structurally it reads no current: its Input is MechanicalSample, which has no current field
// (H24, checked at compile time in tests/core/kim_test.cc).
#ifndef MJSTEPPER_CORE_CONTROLLERS_STMMS_H_
#define MJSTEPPER_CORE_CONTROLLERS_STMMS_H_

#include "core/controllers/controller.h"
#include "core/controllers/kim_mechanical.h"

namespace mjstepper {

struct Stmms {
  static constexpr const char* kName = "stmms";
  static constexpr const char* kSummary =
      "Kim's simplified torque modulated microstepping, K(20)-(32): position controller K(24), "
      "commutation K(27), feed-forward voltage K(28); no current feedback.";
  static constexpr SpeedFeedback kDefaultSpeedFeedback = SpeedFeedback::kExact;
  /// How HoldingStiffness() is obtained (for `mjstepper info`).
  static constexpr const char* kStiffnessFormula = "J·(k1 + k1p·k2), K(26)";
  static constexpr bool kCountsSlips = false;

  KimMechanical mechanical;  // k1p = 40000, k0 = 10, k1 = 20, k2 = 100 (Kim §5)

  struct State {
    double e0 = 0;  ///< ∫e1 dt, rad·s, K(22)
  };
  using Input = MechanicalSample;

  static std::vector<const AttributeSpec*> Attributes() { return KimMechanical::Attributes(); }
  static Stmms FromAttributes(const AttributeSource& a, const MotorParams& motor,
                              const DriveConstants&) {
    return {.mechanical = KimMechanical::FromAttributes(a, motor, 40000)};
  }

  TickOutput Tick(const DriveConstants& k, const Input& in, const PowerStage& stage,
                  State* s) const {
    const KimMechanical::Errors e = mechanical.Track(in);
    s->e0 += k.isr_period * e.e1;                                      // K(22)
    const double torque = mechanical.DesiredTorque(in, e, s->e0);      // τd, K(24)
    const PhaseVector phasor = in.feedback.ElecPhasor(k.rotor_teeth);  // e^{jx}
    const PhaseVector current_ref =
        KimMechanical::Commutate(torque, k.torque_constant, phasor);  // K(27)
    const PhaseVector emf(0, k.torque_constant * in.feedback.omega);  // j·Km·ω
    const PhaseVector v = k.resistance * current_ref + emf * phasor;  // K(28)
    return {.bridge = stage.Apply(v), .current_ref = current_ref};
  }

  /// At rest on the command the currents already carry τd = τl (SPEC §6: no first-step kick).
  PhaseVector Rest(const DriveConstants& k, const RestInput& in, State* s) const {
    s->e0 = 0;
    return KimMechanical::Commutate(mechanical.load_torque, k.torque_constant,
                                    UnitPhasor(k.rotor_teeth * in.theta));
  }
  double HoldingStiffness(const DriveConstants&, PhaseVector) const {
    return mechanical.Stiffness();
  }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_STMMS_H_
