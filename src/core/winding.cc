#include "core/winding.h"

#include <algorithm>
#include <cmath>

namespace mjstepper {

WindingInterval::WindingInterval(const MotorParams& p, PhaseVector current0, PhaseVector voltage,
                                 double theta0, double omega)
    : p_(p), voltage_(voltage), theta0_(theta0), omega_(omega) {
  const double R = p.resistance;        // Ω
  const double L = p.inductance;        // H
  const double Km = p.torque_constant;  // V·s/rad
  decay_ = R / L;
  electrical_speed_ = p.rotor_teeth * omega;
  steady_ = voltage / R;
  const PhaseVector emf_gain = PhaseVector(0, -Km * omega) / PhaseVector(R, electrical_speed_ * L);
  emf_ = emf_gain * UnitPhasor(ElectricalAngle(p, theta0));
  transient_ = current0 - steady_ - emf_;
}

PhaseVector WindingInterval::CurrentAt(double t) const {
  return steady_ + emf_ * UnitPhasor(electrical_speed_ * t) + transient_ * std::exp(-decay_ * t);
}

IntervalEnergy WindingInterval::Energy(double h) const {
  IntervalEnergy e;
  EndOfInterval(h, &e);
  return e;
}

PhaseVector WindingInterval::EndOfInterval(double h, IntervalEnergy* energy) const {
  return AdvanceInterval(p_, WindingKernel(p_, omega_, h), steady_ + emf_ + transient_, voltage_,
                         UnitPhasor(ElectricalAngle(p_, theta0_)), energy);
}

DecayKernel::DecayKernel(const MotorParams& p, double h_) : h(h_) {
  const double a = p.resistance / p.inductance;  // 1/s
  decay = std::exp(-a * h);
  int_a = IntegralOfExp(-a, h, decay, [a] { return PhaseVector(-1 / a); }).real();
  int_2a = IntegralOfExp(-2 * a, h, decay * decay, [a] { return PhaseVector(-0.5 / a); }).real();
}

SpeedKernel::SpeedKernel(const MotorParams& p, double omega_) : omega(omega_) {
  electrical = p.rotor_teeth * omega;
  decay_rate = p.resistance / p.inductance;
  // 1/(jΩ − a) = (−jΩ − a)/(Ω² + a²); P = −j·Km·ω/(L·(a + jΩ)) = j·Km·ω/L · conj(1/(jΩ − a)).
  inv_jw_a =
      PhaseVector(-decay_rate, -electrical) / (electrical * electrical + decay_rate * decay_rate);
  emf_gain = PhaseVector(0, p.torque_constant * omega / p.inductance) * std::conj(inv_jw_a);
}

SpeedKernel::SpeedKernel(const MotorParams& p, double omega_, double h, PhaseVector z0,
                         PhaseVector z1)
    : SpeedKernel(p, omega_) {
  // The half-angle identity needs 1 + e^{jΩh} away from 0: |Ω·h| <= 3 rad (of π) is kept.
  if (!(h > 0 && std::abs(electrical * h) <= 3.0)) return;
  step = h;
  step_rotation = z1 * std::conj(z0);
  const PhaseVector sum = 1.0 + step_rotation;
  half_rotation = sum / std::sqrt(std::norm(sum));
}

PhaseVector SpeedKernel::Rotation(double t) const {
  if (std::abs(t - step) <= 1e-9 * t) return step_rotation;
  if (std::abs(2 * t - step) <= 2e-9 * t) return half_rotation;
  return UnitPhasor(electrical * t);
}

WindingKernel::WindingKernel(const SpeedKernel& speed, const DecayKernel& decay_kernel)
    : h(decay_kernel.h),
      omega(speed.omega),
      rotation(speed.Rotation(decay_kernel.h)),
      decay(decay_kernel.decay),
      emf_gain(speed.emf_gain),
      int_a(decay_kernel.int_a),
      int_2a(decay_kernel.int_2a) {
  const PhaseVector jw(0, speed.electrical);
  int_jw = IntegralOfExp(jw, h, rotation, [&] { return PhaseVector(0, -1 / speed.electrical); });
  int_jw_a =
      IntegralOfExp(jw - speed.decay_rate, h, rotation * decay, [&] { return speed.inv_jw_a; });
}

WindingKernel::WindingKernel(const MotorParams& p, double omega_, double h_)
    : WindingKernel(SpeedKernel(p, omega_), DecayKernel(p, h_)) {}

PhaseVector AdvanceInterval(const MotorParams& p, const WindingKernel& k, PhaseVector current0,
                            PhaseVector voltage, PhaseVector phasor0, IntervalEnergy* energy) {
  // i(t) = A + B·e^{jΩt} + C·e^{−at}: A = v/R, B = P·e^{jx0}, C = i0 − A − B (winding.h).
  const PhaseVector A = voltage / p.resistance, B = k.emf_gain * phasor0, C = current0 - A - B;
  const PhaseVector current = A + B * k.rotation + C * k.decay;
  if (energy == nullptr) return current;
  const double h = k.h;
  energy->charge = A * h + B * k.int_jw + C * k.int_a;  // ∫i dt
  energy->input = (std::conj(voltage) * energy->charge).real();
  const double norm_integral = std::norm(A) * h + std::norm(B) * h + std::norm(C) * k.int_2a +
                               2 * (A * std::conj(B) * std::conj(k.int_jw)).real() +
                               2 * (A * std::conj(C)).real() * k.int_a +
                               2 * (B * std::conj(C) * k.int_jw_a).real();
  energy->copper = p.resistance * norm_integral;
  // ∫τm·ω = Km·ω·∫Im(e^{−jx(t)}·i(t)), e^{−jx(t)} = e^{−jx0}·e^{−jΩt}   (S-4)
  const PhaseVector rotor_frame_integral =
      std::conj(phasor0) * (A * std::conj(k.int_jw) + B * h + C * std::conj(k.int_jw_a));
  energy->mechanical = p.torque_constant * k.omega * rotor_frame_integral.imag();
  return current;
}

PhaseVector AdvanceRotatingVoltage(const MotorParams& p, double omega, PhaseVector current0,
                                   PhaseVector voltage0, double command_electrical_speed, double h,
                                   PhaseVector phasor0, IntervalEnergy* energy) {
  const double R = p.resistance, L = p.inductance;  // Ω, H
  const double a = R / L;                           // 1/s
  const double wc = command_electrical_speed;       // Ωc, rad/s
  const double w = p.rotor_teeth * omega;           // Ω, rad/s
  // i(t) = Q·e^{jΩc·t} + B·e^{jΩt} + C·e^{−at}: Q = v0/(R + jΩcL), B = P·e^{jx0}, C = i0 − Q − B.
  const PhaseVector Q = voltage0 / PhaseVector(R, wc * L);
  const PhaseVector B =
      PhaseVector(0, -p.torque_constant * omega) / PhaseVector(R, w * L) * phasor0;
  const PhaseVector C = current0 - Q - B;
  const PhaseVector rotation_c = UnitPhasor(wc * h),
                    rotation = UnitPhasor(w * h);  // e^{jΩc·h}, e^{jΩh}
  const double decay = std::exp(-a * h);
  const PhaseVector current = Q * rotation_c + B * rotation + C * decay;
  if (energy == nullptr) return current;
  // ∫0^h e^{s·t} dt for the exponents the products below take.
  auto integral = [h](PhaseVector s, PhaseVector exp_sh) {
    return IntegralOfExp(s, h, exp_sh, [s] { return 1.0 / s; });
  };
  const PhaseVector slip =
      integral({0, w - wc}, rotation * std::conj(rotation_c));  // ∫e^{j(Ω−Ωc)t}
  const PhaseVector c_decay = integral({-a, -wc}, std::conj(rotation_c) * decay);  // ∫e^{(−jΩc−a)t}
  const PhaseVector w_decay = integral({-a, -w}, std::conj(rotation) * decay);  // ∫e^{(−jΩ−a)t}
  const double int_2a = integral({-2 * a, 0}, decay * decay).real();            // ∫e^{−2at}
  // v·i = Re(conj(v)·i), conj(v(t)) = conj(v0)·e^{−jΩc·t}.
  energy->input = (std::conj(voltage0) * (Q * h + B * slip + C * c_decay)).real();
  const double norm_integral = std::norm(Q) * h + std::norm(B) * h + std::norm(C) * int_2a +
                               2 * (B * std::conj(Q) * slip).real() +
                               2 * (Q * std::conj(C) * std::conj(c_decay)).real() +
                               2 * (B * std::conj(C) * std::conj(w_decay)).real();
  energy->copper = R * norm_integral;
  // ∫τm·ω = Km·ω·∫Im(e^{−jx(t)}·i(t)), e^{−jx(t)} = e^{−jx0}·e^{−jΩt}   (S-4)
  const PhaseVector rotor_frame_integral =
      std::conj(phasor0) * (Q * std::conj(slip) + B * h + C * w_decay);
  energy->mechanical = p.torque_constant * omega * rotor_frame_integral.imag();
  return current;
}

PhaseVector IntegrateWindingRk4(const MotorParams& p, PhaseVector current0, PhaseVector voltage,
                                double theta0, double omega, double h, double max_step) {
  const int n = std::max(1, static_cast<int>(std::ceil(h / max_step - 1e-9)));
  const double dt = h / n;
  // S-3: di/dt = (v − R·i − e(t)) / L, e = j·Km·ω·e^{jx(t)}.
  auto derivative = [&](double t, PhaseVector i) {
    const PhaseVector emf = BackEmf(p, theta0 + omega * t, omega);
    return (voltage - p.resistance * i - emf) / p.inductance;
  };
  PhaseVector i = current0;
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    const PhaseVector k1 = derivative(t, i);
    const PhaseVector k2 = derivative(t + dt / 2, i + dt / 2 * k1);
    const PhaseVector k3 = derivative(t + dt / 2, i + dt / 2 * k2);
    const PhaseVector k4 = derivative(t + dt, i + dt * k3);
    i += dt / 6 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
  }
  return i;
}

}  // namespace mjstepper
