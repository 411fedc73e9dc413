// The digital PI current loop of Tsui 2009 eq. (9)-(11), in a Park frame at angle ψ.
//   i_dq[k] = e^{−jψ}·i_ab(t_k)                                               T(11), S-9
//   e[k] = i*_dq[k] − i_dq[k]
//   s[k] = s[k−1] + Ki·e[k]          (Ki per tick, V/A: 0.01 at 20 kHz = 200 V/(A·s))   T(9)-(10)
//   v_dq[k] = Kp·e[k] + s[k],   v_ab[k] = e^{jψ}·v_dq[k]                         S-10
// The power stage limits v_ab (S-13/S-14). Anti-windup by conditional integration: when the stage
// cuts the request, s[k] = s[k−1].
#ifndef MJSTEPPER_CORE_CONTROLLERS_DQ_CURRENT_LOOP_H_
#define MJSTEPPER_CORE_CONTROLLERS_DQ_CURRENT_LOOP_H_

#include "core/motor.h"
#include "core/power_stage.h"

namespace mjstepper {

struct DqCurrentLoop {
  double kp = 7.5;            ///< V/A, T(9)
  double ki_per_tick = 0.01;  ///< V/A per tick, T(10)

  /// One tick; `integral_dq` is s[k−1] on entry and s[k] on return (V, d + j·q).
  BridgeOutput Update(PhaseVector setpoint_dq, double park_angle, PhaseVector current_ab,
                      const PowerStage& stage, PhaseVector* integral_dq) const {
    const PhaseVector error = setpoint_dq - ToDq(current_ab, park_angle);  // e[k]
    const PhaseVector integral = *integral_dq + ki_per_tick * error;       // s[k]
    const BridgeOutput out = stage.Apply(FromDq(kp * error + integral, park_angle));
    if (!out.saturated) *integral_dq = integral;  // conditional integration
    return out;
  }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_DQ_CURRENT_LOOP_H_
