#include "core/controllers/servo.h"

namespace mjstepper {
namespace {

double Sign(double v) { return (v > 0) - (v < 0); }

}  // namespace

BridgeOutput ServoController::Update(const ControlSample& in, const PowerStage& stage,
                                     PhaseVector* integral_dq, ServoState* state) const {
  const double x_fb = rotor_teeth * in.theta_fb;  // ψ = Nr·θfb, T(18)
  if (identification) {
    // T(8): compensation only, updated every tick.
    state->iq_cmd = (damping.Torque(x_fb) + friction * Sign(in.omega_fb)) / torque_constant;
  } else if (in.position_tick) {
    const double theta_error = in.theta_cmd - in.theta_fb;  // rad
    const double omega_error = in.omega_cmd - in.omega_fb;  // rad/s
    state->position_integral += theta_error * position_period;
    const double torque = kv * omega_error + kp * theta_error + ki * state->position_integral +
                          damping.Torque(x_fb) + friction * Sign(in.omega_cmd);  // T(19), N·m
    state->iq_cmd = torque / torque_constant;
  }
  return loop.Update({0.0, state->iq_cmd}, x_fb, in.current, stage, integral_dq);
}

}  // namespace mjstepper
