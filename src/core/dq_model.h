// The motor in the rotor's own DQ frame, S-11 (Kim 2016 eq. 2-3): with ψ = x = Nr·θ,
//   τm = Km·iq
//   L·did/dt = vd − R·id + Nr·L·ω·iq
//   L·diq/dt = vq − R·iq − Nr·L·ω·id − Km·ω
// The same physics as the phase frame of S-3/S-4 seen from the rotor (the drive integrates the
// phase frame); H7 checks that both give the same motion.
#ifndef MJSTEPPER_CORE_DQ_MODEL_H_
#define MJSTEPPER_CORE_DQ_MODEL_H_

#include "core/motor.h"

namespace mjstepper {

/// d(id + j·iq)/dt in A/s for currents i_dq and voltages v_dq (both in the rotor frame, S-9).
inline PhaseVector DqCurrentDerivative(const MotorParams& p, PhaseVector current_dq,
                                       PhaseVector voltage_dq, double omega) {
  const double R = p.resistance, L = p.inductance, Km = p.torque_constant;
  const double w = p.rotor_teeth * omega;  // Nr·ω, rad/s (electrical)
  const double id = current_dq.real(), iq = current_dq.imag();
  return {(voltage_dq.real() - R * id + w * L * iq) / L,
          (voltage_dq.imag() - R * iq - w * L * id - Km * omega) / L};
}

/// τm = Km·iq (N·m), S-11.
inline double DqTorque(const MotorParams& p, PhaseVector current_dq) {
  return p.torque_constant * current_dq.imag();
}

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_DQ_MODEL_H_
