#include "core/drive.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "core/motor.h"
#include "core/sensors/encoder.h"
#include "core/units.h"
#include "core/winding.h"

namespace mjstepper {
namespace {

void Require(bool ok, const char* name, double value, const char* rule) {
  if (!ok) throw std::invalid_argument(fmt::format("DriveConfig: {} = {}; {}", name, value, rule));
}

}  // namespace

const char* DriveKindName(DriveKind kind) {
  switch (kind) {
    case DriveKind::kVoltageMicrostep:
      return "voltage_microstep";
    case DriveKind::kCurrentMicrostep:
      return "current_microstep";
    case DriveKind::kIdealCurrent:
      return "ideal_current";
    case DriveKind::kServo:
      return "servo";
    case DriveKind::kIdentification:
      return "identification";
  }
  return "?";
}

DriveState LoadState(const double* values) {
  DriveState state;
  std::memcpy(static_cast<void*>(&state), values, sizeof(state));  // trivially copyable
  return state;
}

void StoreState(const DriveState& state, double* values) {
  std::memcpy(values, static_cast<const void*>(&state), sizeof(state));
}

void Validate(const DriveConfig& c) {
  Validate(c.motor);
  // Each check is written so that NaN fails it.
  Require(c.bus_voltage > 0 && std::isfinite(c.bus_voltage), "bus_voltage", c.bus_voltage,
          "must be finite and > 0 (V)");
  Require(c.voltage_amplitude > 0 &&
              (c.kind != DriveKind::kVoltageMicrostep || c.voltage_amplitude <= c.bus_voltage),
          "voltage_amplitude", c.voltage_amplitude,
          "must be > 0, and <= bus_voltage for voltage_microstep (V)");
  Require(c.hold_current > 0 && std::isfinite(c.hold_current), "hold_current", c.hold_current,
          "must be finite and > 0 (A)");
  Require(c.kp >= 0 && std::isfinite(c.kp), "kp", c.kp, "must be finite and >= 0 (V/A)");
  Require(c.ki_per_tick >= 0 && std::isfinite(c.ki_per_tick), "ki", c.ki_per_tick,
          "must be finite and >= 0 (V/A per tick)");
  Require(c.isr_period > 0 && std::isfinite(c.isr_period), "isr_period", c.isr_period,
          "must be finite and > 0 (s)");
  Require(c.compute_delay >= 0 && c.compute_delay < c.isr_period, "compute_delay", c.compute_delay,
          "must be >= 0 and < isr_period (s)");
  Require(c.rk4_step > 0, "rk4_step", c.rk4_step, "must be > 0 (s)");
  Require(c.encoder_counts >= 0, "encoder_counts", c.encoder_counts, "must be >= 0 (0: ideal)");
  Require(c.velocity_cutoff > 0 && std::isfinite(c.velocity_cutoff), "velocity_cutoff",
          c.velocity_cutoff, "must be finite and > 0 (Hz)");
  const double ratio = c.position_period / c.isr_period;
  Require(ratio >= 1 && std::abs(ratio - std::round(ratio)) < 1e-9 * ratio, "position_period",
          c.position_period, "must be a whole multiple of isr_period (s)");
  for (double gain : {c.servo_kp, c.servo_ki, c.servo_kv, c.friction_compensation}) {
    Require(gain >= 0 && std::isfinite(gain), "servo gain or friction_compensation", gain,
            "must be finite and >= 0");
  }
  MotorParams damping_check = c.motor;
  damping_check.detent = c.damping;
  Validate(damping_check);
}

Drive::Drive(DriveConfig config) : config_(std::move(config)) {
  Validate(config_);
  const MotorParams& motor = config_.motor;
  stage_ = {.kind = config_.power_stage, .bus_voltage = config_.bus_voltage};
  const DqCurrentLoop loop{.kp = config_.kp, .ki_per_tick = config_.ki_per_tick};
  const HarmonicCompensation damping{.harmonics = config_.damping};
  voltage_controller_ = {.rotor_teeth = motor.rotor_teeth,
                         .voltage_amplitude = config_.voltage_amplitude};
  current_controller_ = {.rotor_teeth = motor.rotor_teeth,
                         .torque_constant = motor.torque_constant,
                         .hold_current = config_.hold_current,
                         .damping = damping,
                         .loop = loop};
  servo_controller_ = {.rotor_teeth = motor.rotor_teeth,
                       .torque_constant = motor.torque_constant,
                       .kp = config_.servo_kp,
                       .ki = config_.servo_ki,
                       .kv = config_.servo_kv,
                       .friction = config_.friction_compensation,
                       .position_period = config_.position_period,
                       .identification = config_.kind == DriveKind::kIdentification,
                       .damping = damping,
                       .loop = loop};
  velocity_estimator_ = {.period = config_.isr_period, .cutoff = config_.velocity_cutoff};
  ticks_per_position_update_ = std::lround(config_.position_period / config_.isr_period);
}

DriveState Drive::Rest(double time, double theta, double command) const {
  DriveState s;
  s.started = 1;
  s.theta = theta;
  s.theta_cmd = config_.input == InputMode::kPosition ? command : theta;
  PhaseVector current;
  switch (config_.kind) {
    case DriveKind::kVoltageMicrostep:
      current = voltage_controller_.RestCurrent(s.theta_cmd, config_.motor.resistance);
      break;
    case DriveKind::kCurrentMicrostep:
    case DriveKind::kIdealCurrent: {
      current = current_controller_.RestCurrent(s.theta_cmd);
      const PhaseVector integral =
          current_controller_.RestIntegral(s.theta_cmd, config_.motor.resistance);
      s.integral_d = integral.real();
      s.integral_q = integral.imag();
      break;
    }
    case DriveKind::kServo:
    case DriveKind::kIdentification:
      current = 0;  // the servo at rest on its command asks for no torque
      break;
  }
  s.theta_meas = EncoderAngle(theta, config_.encoder_counts);
  // At rest v = R·i holds the current constant (S-3 with ω = 0).
  const PhaseVector voltage = config_.motor.resistance * current;
  s.current_a = current.real();
  s.current_b = current.imag();
  s.voltage_a = s.pending_a = voltage.real();
  s.voltage_b = s.pending_b = voltage.imag();
  s.next_tick = std::ceil(time / config_.isr_period);
  return s;
}

void Drive::Tick(DriveState* s, long k, double theta, double theta_cmd, double omega_cmd,
                 PhaseVector current) const {
  // Sensors: encoder (S-16) and the backward-difference velocity estimate (S-17), every tick.
  const double theta_meas = EncoderAngle(theta, config_.encoder_counts);
  velocity_estimator_.Update(theta_meas, &s->theta_meas, &s->omega_est);
  const ControlSample sample{.theta_cmd = theta_cmd,
                             .omega_cmd = omega_cmd,
                             .current = current,
                             .theta_fb = theta_meas,
                             .omega_fb = s->omega_est,
                             .position_tick = k % ticks_per_position_update_ == 0};
  PhaseVector integral(s->integral_d, s->integral_q);
  BridgeOutput out;
  switch (config_.kind) {
    case DriveKind::kVoltageMicrostep:
      out = voltage_controller_.Update(sample, stage_);
      break;
    case DriveKind::kCurrentMicrostep:
    case DriveKind::kIdealCurrent:
      out = current_controller_.Update(sample, stage_, &integral);
      break;
    case DriveKind::kServo:
    case DriveKind::kIdentification: {
      ServoState servo{.position_integral = s->position_integral, .iq_cmd = s->iq_cmd};
      out = servo_controller_.Update(sample, stage_, &integral, &servo);
      s->position_integral = servo.position_integral;
      s->iq_cmd = servo.iq_cmd;
      break;
    }
  }
  s->integral_d = integral.real();
  s->integral_q = integral.imag();
  s->pending_a = out.voltage.real();
  s->pending_b = out.voltage.imag();
  s->pending = 1;
}

void Drive::Advance(DriveState* s, double t0, double t1, double theta1, double command) const {
  const MotorParams& motor = config_.motor;
  const double h = t1 - t0;                                  // s
  const double theta0 = s->theta;                            // rad
  const double omega = h > 0 ? (theta1 - theta0) / h : 0.0;  // rad/s, constant over the step
  const double theta_cmd0 = s->theta_cmd;
  const double omega_cmd =
      config_.input == InputMode::kVelocity ? command : (h > 0 ? (command - theta_cmd0) / h : 0.0);
  auto theta_at = [&](double t) { return theta0 + omega * (t - t0); };
  auto theta_cmd_at = [&](double t) {
    return config_.input == InputMode::kVelocity ? theta_cmd0 + command * (t - t0) : command;
  };

  if (config_.kind == DriveKind::kIdealCurrent) {
    const PhaseVector i = current_controller_.RestCurrent(theta_cmd_at(t1));
    s->current_a = i.real();
    s->current_b = i.imag();
  } else {
    const double period = config_.isr_period;  // T
    // Tick times k·T and the accumulated simulation time differ by round-off only.
    const double eps = 1e-9 * period;
    if (s->next_tick * period < t0 - eps) {  // time was moved back or jumped: resynchronise
      s->next_tick = std::ceil((t0 - eps) / period);
      s->pending = 0;
    }
    PhaseVector current = s->current();
    PhaseVector voltage = s->voltage();
    double t = t0;
    auto integrate_to = [&](double t_end) {
      if (t_end <= t) return;
      if (config_.solver == WindingSolver::kExact) {
        const WindingInterval piece(motor, current, voltage, theta_at(t), omega);
        IntervalEnergy e;
        current = piece.EndOfInterval(t_end - t, &e);
        s->energy_input += e.input;
        s->energy_copper += e.copper;
        s->energy_mechanical += e.mechanical;
      } else {
        current = IntegrateWindingRk4(motor, current, voltage, theta_at(t), omega, t_end - t,
                                      config_.rk4_step);
      }
      t = t_end;
    };
    constexpr double kNever = std::numeric_limits<double>::infinity();
    while (true) {
      const double t_apply =
          s->pending ? (s->next_tick - 1) * period + config_.compute_delay : kNever;
      const double t_tick = s->next_tick * period;
      const double t_event = std::min(t_apply, t_tick);
      // Events in [t0, t1 − eps] belong to this step; one within eps of t1 is the next step's, so
      // that a tick at a step boundary samples the command set for the step that starts there.
      if (t_event > t1 - eps) {
        integrate_to(t1);
        break;
      }
      integrate_to(std::min(t_event, t1));
      if (t_apply <= t_tick) {  // S-15: v[k−1] reaches the phases at t_{k−1} + D, then is held
        voltage = {s->pending_a, s->pending_b};
        s->pending = 0;
      } else {  // interrupt k: sample, compute v[k]
        Tick(s, std::lround(s->next_tick), theta_at(t), theta_cmd_at(t), omega_cmd, current);
        s->next_tick += 1;
      }
    }
    s->current_a = current.real();
    s->current_b = current.imag();
    s->voltage_a = voltage.real();
    s->voltage_b = voltage.imag();
  }
  s->theta = theta1;
  s->theta_cmd = theta_cmd_at(t1);
  s->omega_cmd = omega_cmd;
}

double Drive::Torque(const DriveState& s, double theta) const {
  return ElectromagneticTorque(config_.motor, theta, s.current()) +
         DetentTorque(config_.motor, theta);
}

DriveSignals Drive::Signals(const DriveState& s, double theta) const {
  const MotorParams& motor = config_.motor;
  DriveSignals out;
  out.current_a = s.current_a;
  out.current_b = s.current_b;
  out.voltage_a = s.voltage_a;
  out.voltage_b = s.voltage_b;
  const PhaseVector dq = ToDq(s.current(), motor.rotor_teeth * s.theta_cmd);  // S-9, ψ = Nr·θcmd
  out.current_d = dq.real();
  out.current_q = dq.imag();
  out.theta_cmd = s.theta_cmd;
  out.omega_cmd = s.omega_cmd;
  out.torque_em = ElectromagneticTorque(motor, theta, s.current());
  out.torque_detent = DetentTorque(motor, theta);
  out.torque_total = out.torque_em + out.torque_detent;
  out.load_angle = motor.rotor_teeth * (s.theta_cmd - theta);  // S-12
  out.lost_steps = 4.0 * std::round(out.load_angle / kTwoPi);
  out.theta_meas = s.theta_meas;
  out.omega_est = s.omega_est;
  return out;
}

double Drive::RestCurrentMagnitude() const {
  if (IsServo()) return 0.0;
  return config_.kind == DriveKind::kVoltageMicrostep
             ? config_.voltage_amplitude / config_.motor.resistance
             : config_.hold_current;
}

double Drive::HoldingStiffness() const {
  if (config_.kind == DriveKind::kServo) return config_.servo_kp;  // the position loop's spring
  return config_.motor.rotor_teeth * config_.motor.torque_constant * RestCurrentMagnitude();
}

}  // namespace mjstepper
