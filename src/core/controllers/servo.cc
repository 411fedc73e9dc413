#include "core/controllers/servo.h"

#include <fmt/format.h>

#include <cmath>

namespace mjstepper {
namespace {

// The field-oriented current loop at ψ = Nr·θfb with id* = 0, T(18).
TickOutput FieldOriented(const DriveConstants& k, const DqCurrentLoop& loop, double iq_cmd,
                         const Sample& in, const PowerStage& stage, double* integral_d,
                         double* integral_q) {
  PhaseVector integral(*integral_d, *integral_q);
  const PhaseVector target(0.0, iq_cmd);
  const PhaseVector park = in.feedback.ElecPhasor(k.rotor_teeth);  // ψ = Nr·θfb
  const BridgeOutput out = loop.Update(target, park, in.current, stage, &integral);
  *integral_d = integral.real();
  *integral_q = integral.imag();
  return {.bridge = out, .current_ref = park * target};
}

}  // namespace

std::vector<const AttributeSpec*> Servo::Attributes() {
  return {&kAttrPositionPeriod,
          &kAttrServoKp,
          &kAttrServoKi,
          &kAttrServoKv,
          &kAttrKp,
          &kAttrKi,
          &kAttrDamping,
          &kAttrDampingDetent,
          &kAttrFrictionCompensation};
}

Servo Servo::FromAttributes(const AttributeSource& a, const MotorParams& motor,
                            const DriveConstants& k) {
  using Rule = AttributeSource::Rule;
  Servo s;
  s.position_period = a.Real(kAttrPositionPeriod, 250e-6, Rule::kPositive);
  const double ratio = s.position_period / k.isr_period;
  if (!(ratio >= 1 && std::abs(ratio - std::round(ratio)) < 1e-9 * ratio)) {
    ThrowBad(kAttrPositionPeriod, a.Raw(kAttrPositionPeriod).value_or("250e-6"),
             fmt::format("must be a whole multiple of isr_period = {} (s)", k.isr_period));
  }
  s.ticks_per_position = std::lround(ratio);
  s.kp = a.Real(kAttrServoKp, 1.0, Rule::kNonNegative);
  s.ki = a.Real(kAttrServoKi, 10.0, Rule::kNonNegative);
  s.kv = a.Real(kAttrServoKv, 0.01, Rule::kNonNegative);
  s.friction = a.Real(kAttrFrictionCompensation, motor.static_friction, Rule::kNonNegative);
  s.damping = HarmonicCompensation::FromAttributes(a, motor);
  s.loop = DqCurrentLoop::FromAttributes(a);
  return s;
}

void Servo::Position(const DriveConstants& k, const Input& in, State* s) const {
  const double x_fb = k.rotor_teeth * in.feedback.theta;            // ψ = Nr·θfb, T(18)
  const double theta_error = in.command.theta - in.feedback.theta;  // rad
  const double omega_error = in.command.omega - in.feedback.omega;  // rad/s
  s->position_integral += theta_error * position_period;
  const double torque = kv * omega_error + kp * theta_error + ki * s->position_integral +
                        damping.Torque(x_fb) + friction * Sign(in.command.omega);  // T(19), N·m
  s->iq_cmd = torque / k.torque_constant;
}

TickOutput Servo::Tick(const DriveConstants& k, const Input& in, const PowerStage& stage,
                       State* s) const {
  if (in.tick % ticks_per_position == 0) Position(k, in, s);
  return FieldOriented(k, loop, s->iq_cmd, in, stage, &s->integral_d, &s->integral_q);
}

std::vector<const AttributeSpec*> Identification::Attributes() {
  return {&kAttrKp, &kAttrKi, &kAttrDamping, &kAttrDampingDetent, &kAttrFrictionCompensation};
}

Identification Identification::FromAttributes(const AttributeSource& a, const MotorParams& motor,
                                              const DriveConstants&) {
  return {.friction = a.Real(kAttrFrictionCompensation, motor.static_friction,
                             AttributeSource::Rule::kNonNegative),
          .setpoint = {.hold_current = 0,
                       .damping = HarmonicCompensation::FromAttributes(a, motor),
                       .microsteps = 0},
          .loop = DqCurrentLoop::FromAttributes(a)};
}

TickOutput Identification::Tick(const DriveConstants& k, const Input& in, const PowerStage& stage,
                                State* s) const {
  // T(8): compensation only, updated every tick.
  const double x_fb = k.rotor_teeth * in.feedback.theta;
  const double iq_cmd =
      (setpoint.damping.Torque(x_fb) + friction * Sign(in.feedback.omega)) / k.torque_constant;
  return FieldOriented(k, loop, iq_cmd, in, stage, &s->integral_d, &s->integral_q);
}

}  // namespace mjstepper
