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
  const double electrical_speed = p.rotor_teeth * omega;  // Nr·ω, rad/s
  steady_ = voltage / R;
  emf_gain_ = PhaseVector(0, -Km * omega) / PhaseVector(R, electrical_speed * L);
  transient_ = current0 - steady_ - emf_gain_ * UnitPhasor(ElectricalAngle(p, theta0));
}

PhaseVector WindingInterval::CurrentAt(double t) const {
  const double x = ElectricalAngle(p_, theta0_ + omega_ * t);
  return steady_ + emf_gain_ * UnitPhasor(x) +
         transient_ * std::exp(-p_.resistance * t / p_.inductance);
}

IntervalEnergy WindingInterval::Energy(double h) const {
  IntervalEnergy e;
  constexpr double kWeights[3] = {1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0};
  for (int k = 0; k < 3; ++k) {
    const double t = 0.5 * h * k;
    const PhaseVector i = CurrentAt(t);
    const double theta = theta0_ + omega_ * t;
    e.input += kWeights[k] * h * (voltage_.real() * i.real() + voltage_.imag() * i.imag());
    e.copper += kWeights[k] * h * p_.resistance * std::norm(i);
    e.mechanical += kWeights[k] * h * ElectromagneticTorque(p_, theta, i) * omega_;
  }
  return e;
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
