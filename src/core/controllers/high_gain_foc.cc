#include "core/controllers/high_gain_foc.h"

namespace mjstepper {

std::vector<const AttributeSpec*> HighGainFoc::Attributes() {
  std::vector<const AttributeSpec*> list = KimMechanical::Attributes();
  list.insert(list.end(), {&kAttrFocCase, &kAttrRho, &kAttrFocDerivative});
  return list;
}

HighGainFoc HighGainFoc::FromAttributes(const AttributeSource& a, const MotorParams& motor,
                                        const DriveConstants&) {
  const bool case2 = a.Choice(kAttrFocCase, "case1", {"case1", "case2"}) == "case2";
  HighGainFoc c;
  c.mechanical = KimMechanical::FromAttributes(a, motor, case2 ? 10000 : 1000);
  c.rho = a.Real(kAttrRho, case2 ? 10000 : 25000, AttributeSource::Rule::kPositive);
  c.derivative = a.Choice(kAttrFocDerivative, "analytic", {"analytic", "numeric"}) == "numeric"
                     ? Derivative::kNumeric
                     : Derivative::kAnalytic;
  return c;
}

TickOutput HighGainFoc::Tick(const DriveConstants& k, const Input& in, const PowerStage& stage,
                             State* s) const {
  const MechanicalSample m = MechanicalSample::From(in);
  const KimMechanical& mech = mechanical;
  const KimMechanical::Errors e = mech.Track(m);
  s->e0 += k.isr_period * e.e1;                                      // K(22)
  const double torque = mech.DesiredTorque(m, e, s->e0);             // τd, K(24)
  const PhaseVector phasor = in.feedback.ElecPhasor(k.rotor_teeth);  // e^{jx}
  const PhaseVector current_ref = KimMechanical::Commutate(torque, k.torque_constant, phasor);
  const double omega = in.feedback.omega;
  PhaseVector current_ref_dot;  // i̇d, A/s
  if (derivative == Derivative::kAnalytic) {
    // ω̇ from the measured torque through the controller's model (S-4, S-7).
    const double torque_measured = k.torque_constant * (std::conj(phasor) * in.current).imag();
    const double omega_dot =
        (torque_measured - mech.damping * omega - mech.load_torque) / mech.inertia;
    const double torque_dot = TorqueRate(m, e, omega_dot);
    current_ref_dot = PhaseVector(0, 1.0 / k.torque_constant) * phasor *
                      PhaseVector(torque_dot, k.rotor_teeth * omega * torque);
  } else {
    const PhaseVector previous(s->previous_a, s->previous_b);
    current_ref_dot = s->has_previous ? (current_ref - previous) / k.isr_period : PhaseVector(0);
    s->previous_a = current_ref.real();
    s->previous_b = current_ref.imag();
    s->has_previous = 1;
  }
  const PhaseVector emf = PhaseVector(0, k.torque_constant * omega) * phasor;  // j·Km·ω·e^{jx}
  const PhaseVector v =
      k.resistance * in.current + emf +
      k.inductance * (current_ref_dot + rho * (current_ref - in.current));  // K(33)
  return {.bridge = stage.Apply(v), .current_ref = current_ref};
}

double HighGainFoc::TorqueRate(const MechanicalSample& in, const KimMechanical::Errors& e,
                               double omega_dot) const {
  const KimMechanical& mech = mechanical;
  const double e1_ddot = omega_dot - in.command.accel;
  const double e2_dot = e1_ddot + mech.k1p * e.e1_dot;
  return mech.damping * omega_dot +
         mech.inertia * (in.command.jerk - mech.k1p * e1_ddot - mech.k0 * e.e1 -
                         mech.k1 * e.e1_dot - mech.k2 * e2_dot);
}

PhaseVector HighGainFoc::Rest(const DriveConstants& k, const RestInput& in, State* s) const {
  *s = {};
  const PhaseVector i = KimMechanical::Commutate(mechanical.load_torque, k.torque_constant,
                                                 UnitPhasor(k.rotor_teeth * in.theta));
  s->previous_a = i.real();
  s->previous_b = i.imag();
  s->has_previous = 1;
  return i;
}

}  // namespace mjstepper
