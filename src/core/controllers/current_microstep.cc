#include "core/controllers/current_microstep.h"

namespace mjstepper {

BridgeOutput CurrentMicrostepController::Update(const ControlSample& in, const TwoHBridges& bridges,
                                                PhaseVector* integral_dq) const {
  const double park_angle = rotor_teeth * in.theta_cmd;                    // ψ = Nr·θcmd, S-12
  const PhaseVector error = Setpoint() - ToDq(in.current, park_angle);     // e[k], S-9
  const PhaseVector integral = *integral_dq + ki_per_tick * error;         // s[k], T(10)
  const PhaseVector request_dq = kp * error + integral;                    // T(9)
  const BridgeOutput out = bridges.Apply(FromDq(request_dq, park_angle));  // S-10, S-13
  if (!out.saturated) *integral_dq = integral;  // conditional integration (anti-windup)
  return out;
}

}  // namespace mjstepper
