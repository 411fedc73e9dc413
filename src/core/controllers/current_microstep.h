// Current-controlled microstepping with open-loop harmonic damping, Tsui 2009 §III.A, SPEC §3.
//
// Park frame at the commanded electrical angle, open loop in position (S-12):
//   ψ = Nr·θcmd
//   id* = I_hold                                                               T(12)
//   iq* = (1/Km)·Σh Kdh·sin(h·Nr·θcmd + φh)   (0 with no harmonic enabled)      T(13)
// then the PI current loop of T(9)-(11) in that frame (dq_current_loop.h).
#ifndef MJSTEPPER_CORE_CONTROLLERS_CURRENT_MICROSTEP_H_
#define MJSTEPPER_CORE_CONTROLLERS_CURRENT_MICROSTEP_H_

#include "core/controllers/control_sample.h"
#include "core/controllers/dq_current_loop.h"
#include "core/controllers/harmonic_compensation.h"

namespace mjstepper {

struct CurrentMicrostepController {
  int rotor_teeth = 50;          ///< Nr
  double torque_constant = 0.3;  ///< Km the drive assumes, N·m/A
  double hold_current = 1.9;     ///< I_hold, A, T(12)
  HarmonicCompensation damping;  ///< T(13); empty: no damping
  DqCurrentLoop loop;

  /// id* + j·iq* at the commanded angle, T(12)-(13).
  PhaseVector Setpoint(double theta_cmd) const {
    return {hold_current, damping.Torque(rotor_teeth * theta_cmd) / torque_constant};
  }

  BridgeOutput Update(const ControlSample& in, const PowerStage& stage,
                      PhaseVector* integral_dq) const {
    return loop.Update(Setpoint(in.theta_cmd), rotor_teeth * in.theta_cmd, in.current, stage,
                       integral_dq);
  }

  /// Currents on the setpoint at θcmd (A), and the integrator that holds them against R (V).
  PhaseVector RestCurrent(double theta_cmd) const {
    return FromDq(Setpoint(theta_cmd), rotor_teeth * theta_cmd);
  }
  PhaseVector RestIntegral(double theta_cmd, double resistance) const {
    return resistance * Setpoint(theta_cmd);
  }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_CURRENT_MICROSTEP_H_
