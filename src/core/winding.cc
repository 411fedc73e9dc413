#include "core/winding.h"

#include <algorithm>
#include <cmath>

namespace mjstepper {

namespace {

// ∫0^h e^{s·t} dt = (e^{s·h} − 1)/s given exp_sh = e^{s·h}, by its series where s·h is small (no
// cancellation at s → 0; the series' error there is (s·h)⁴/120 < 1e-14 relative).
PhaseVector IntegralOfExp(PhaseVector s, double h, PhaseVector exp_sh) {
  const PhaseVector z = s * h;
  if (std::norm(z) < 1e-6) return h * (1.0 + z / 2.0 + z * z / 6.0 + z * z * z / 24.0);
  return (exp_sh - 1.0) / s;
}

}  // namespace

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
  // With i = A + B·e^{jΩt} + C·e^{−at} (A = steady_, B = emf_, C = transient_), every integral is
  // one of ∫e^{s·t} for five values of s, and all their end values follow from two: e^{jΩh} and
  // e^{−ah} (one sincos and one exp per interval).
  const PhaseVector A = steady_, B = emf_, C = transient_;
  const PhaseVector jw(0, electrical_speed_);
  const double a = decay_;
  const PhaseVector rotation = UnitPhasor(electrical_speed_ * h);  // e^{jΩh}
  const double decay = std::exp(-a * h);                           // e^{−ah}
  const PhaseVector current = A + B * rotation + C * decay;
  if (energy == nullptr) return current;
  const PhaseVector e_jw = IntegralOfExp(jw, h, rotation);                // ∫e^{jΩt}
  const PhaseVector e_a = IntegralOfExp(-a, h, decay);                    // ∫e^{−at}
  const PhaseVector e_2a = IntegralOfExp(-2 * a, h, decay * decay);       // ∫e^{−2at}
  const PhaseVector e_jw_a = IntegralOfExp(jw - a, h, rotation * decay);  // ∫e^{(jΩ−a)t}
  const PhaseVector e_mjw_a = IntegralOfExp(-jw - a, h, std::conj(rotation) * decay);
  // input: ∫Re(conj(v)·i)
  energy->input = (std::conj(voltage_) * (A * h + B * e_jw + C * e_a)).real();
  // copper: R·∫|i|², |i|² expanded into its nine products
  const double norm_integral = std::norm(A) * h + std::norm(B) * h + std::norm(C) * e_2a.real() +
                               2 * (A * std::conj(B) * std::conj(e_jw)).real() +
                               2 * (A * std::conj(C)).real() * e_a.real() +
                               2 * (B * std::conj(C) * e_jw_a).real();
  energy->copper = p_.resistance * norm_integral;
  // mechanical: ∫τm·ω = Km·ω·∫Im(e^{−jx(t)}·i(t)), e^{−jx(t)} = e^{−jx0}·e^{−jΩt}   (S-4)
  const PhaseVector back = UnitPhasor(-ElectricalAngle(p_, theta0_));
  energy->mechanical =
      p_.torque_constant * omega_ * (back * (A * std::conj(e_jw) + B * h + C * e_mjw_a)).imag();
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
