// The two-phase stepper motor of SPEC §1: electrical angle, back-EMF, torque, detent, Park frame.
//
// Phase quantities are carried as one complex number, a + j·b ("phase vector"): ia + j·ib, va +
// j·vb. With e^{jx} = cos x + j·sin x the equations of S-2..S-4 and S-9/S-10 become one-liners:
//   back-EMF   ea + j·eb = j·Km·ω·e^{jx}                        S-2
//   torque     τm = Km·Im(e^{−jx}·i)                              S-4
//   Park       id + j·iq = e^{−jψ}·i,   i = e^{jψ}·(id + j·iq)     S-9, S-10
#ifndef MJSTEPPER_CORE_MOTOR_H_
#define MJSTEPPER_CORE_MOTOR_H_

#include <complex>

#include "core/motor_params.h"

namespace mjstepper {

using PhaseVector = std::complex<double>;  ///< a + j·b (A or V, by context)

/// Unit vector e^{jψ} = cos ψ + j·sin ψ.
inline PhaseVector UnitPhasor(double angle) { return std::polar(1.0, angle); }

/// S-1: x = Nr·θ (rad, electrical).
inline double ElectricalAngle(const MotorParams& p, double theta) { return p.rotor_teeth * theta; }

/// S-2: ea + j·eb = j·Km·ω·e^{jx}, i.e. ea = −Km·ω·sin x, eb = Km·ω·cos x (V).
inline PhaseVector BackEmf(const MotorParams& p, double theta, double omega) {
  return PhaseVector(0, p.torque_constant * omega) * UnitPhasor(ElectricalAngle(p, theta));
}

/// S-4: τm = Km·(−ia·sin x + ib·cos x) (N·m).
inline double ElectromagneticTorque(const MotorParams& p, double theta, PhaseVector current) {
  return p.torque_constant * (UnitPhasor(-ElectricalAngle(p, theta)) * current).imag();
}

/// S-5: τdet = −Σh Kdh·sin(h·x + φh) (N·m).
double DetentTorque(const MotorParams& p, double theta);

/// S-9: (id, iq) = Park transform at angle ψ, returned as id + j·iq.
inline PhaseVector ToDq(PhaseVector ab, double park_angle) { return UnitPhasor(-park_angle) * ab; }

/// S-10: inverse Park transform.
inline PhaseVector FromDq(PhaseVector dq, double park_angle) { return UnitPhasor(park_angle) * dq; }

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_MOTOR_H_
