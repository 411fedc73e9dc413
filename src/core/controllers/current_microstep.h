// Current-controlled microstepping, Tsui 2009 §III (eq. 9-12), SPEC §3, without damping.
//
// Park frame at the commanded electrical angle, open loop in position (S-12):
//   ψ = Nr·θcmd
//   id* = I_hold,   iq* = 0                                                    T(12)
// Discrete PI per axis at each tick t_k (ki is per tick, V/A; at 20 kHz 0.01 = 200 V/(A·s)):
//   e[k] = i*[k] − i_dq[k]                  i_dq[k] = e^{−jψ}·i_ab(t_k)          S-9
//   s[k] = s[k−1] + Ki·e[k]                                                    T(10)
//   v_dq[k] = Kp·e[k] + s[k],   v_ab[k] = e^{jψ}·v_dq[k]                       T(9), S-10
// The bridges clamp v_ab (S-13). Anti-windup by conditional integration: when the bridges cut the
// request, s[k] = s[k−1] (the integrator holds).
#ifndef MJSTEPPER_CORE_CONTROLLERS_CURRENT_MICROSTEP_H_
#define MJSTEPPER_CORE_CONTROLLERS_CURRENT_MICROSTEP_H_

#include "core/controllers/control_sample.h"
#include "core/power_stage.h"

namespace mjstepper {

struct CurrentMicrostepController {
  int rotor_teeth = 50;       ///< Nr
  double hold_current = 1.9;  ///< I_hold, A, T(12)
  double kp = 7.5;            ///< V/A, T(9)
  double ki_per_tick = 0.01;  ///< V/A per tick, T(10)

  /// id* + j·iq* in the commanded frame, T(12).
  PhaseVector Setpoint() const { return {hold_current, 0.0}; }

  /// One tick; `integral_dq` is s[k−1] on entry and s[k] on return (V, d + j·q).
  BridgeOutput Update(const ControlSample& in, const TwoHBridges& bridges,
                      PhaseVector* integral_dq) const;

  /// The state in which the drive rests with its current on the setpoint: i_ab and the integrator
  /// that holds it there against R (s = R·i*, e = 0).
  PhaseVector RestCurrent(double theta_cmd) const {
    return FromDq(Setpoint(), rotor_teeth * theta_cmd);
  }
  PhaseVector RestIntegral(double resistance) const { return resistance * Setpoint(); }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_CURRENT_MICROSTEP_H_
