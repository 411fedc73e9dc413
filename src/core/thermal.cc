#include "core/thermal.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace mjstepper {
namespace {

// Written as !(v > 0) so that NaN fails too.
void RequirePositive(const char* name, double value, const char* unit) {
  if (!(value > 0) || !std::isfinite(value)) {
    throw std::invalid_argument(
        fmt::format("ThermalParams: {} = {} {}; must be finite and > 0", name, value, unit));
  }
}

void RequireWithin(const char* name, double value, double low, double high, const char* unit) {
  if (!(value >= low && value <= high)) {
    throw std::invalid_argument(
        fmt::format("HeatParams: {} = {} {}; must be in [{}, {}]", name, value, unit, low, high));
  }
}

}  // namespace

void Validate(const ThermalParams& p) {
  RequirePositive("resistance_winding", p.resistance_winding, "K/W");
  RequirePositive("resistance_housing", p.resistance_housing, "K/W");
  RequirePositive("capacity_winding", p.capacity_winding, "J/K");
  RequirePositive("capacity_housing", p.capacity_housing, "J/K");
}

void Validate(const HeatParams& p) {
  Validate(p.network);
  RequireWithin("ambient_temperature", p.ambient_temperature, -50, 150, "°C");
  RequireWithin("initial_temperature", p.initial_temperature, -50, 400, "°C");
  RequireWithin("insulation_limit", p.insulation_limit, 0, 400, "°C");
  // Within these the factors stay > 0.2 over [kLeastLawTemperature, kMostLawTemperature].
  RequireWithin("resistance_coefficient", p.resistance_coefficient, 0, 0.01, "1/K");
  RequireWithin("torque_constant_coefficient", p.torque_constant_coefficient, -0.002, 0.002, "1/K");
}

double TemperatureFactor(double coefficient, double temperature) {
  const double t = std::clamp(temperature, kLeastLawTemperature, kMostLawTemperature);
  return 1 + coefficient * (t - kReferenceTemperature);
}

ThermalNetwork::ThermalNetwork(const ThermalParams& p) : p_(p) {
  Validate(p);
  const double g = 1 / p.resistance_winding;  // W/K, winding → housing
  const double k = 1 / p.resistance_housing;  // W/K, housing → ambient
  const double cw = p.capacity_winding, ch = p.capacity_housing;
  // S = D^{1/2}·A·D^{-1/2}: A = [[−g/C_w, g/C_w], [g/C_h, −(g+k)/C_h]] made symmetric.
  Eigen::Matrix2d s;
  s << -g / cw, g / std::sqrt(cw * ch), g / std::sqrt(cw * ch), -(g + k) / ch;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver(s);
  if (solver.info() != Eigen::Success) {
    throw std::invalid_argument("ThermalParams: the network's decomposition failed");
  }
  const Eigen::Vector2d rates = solver.eigenvalues();  // ascending: the fast mode first
  const Eigen::Matrix2d q = solver.eigenvectors();     // orthonormal columns
  const Eigen::Vector2d root_c(std::sqrt(cw), std::sqrt(ch));
  const Eigen::Matrix2d to_modes = q.transpose() * root_c.asDiagonal();       // M
  const Eigen::Matrix2d from_modes = root_c.cwiseInverse().asDiagonal() * q;  // N
  const Eigen::Vector2d input = to_modes * Eigen::Vector2d(1 / cw, 0);        // M·b
  // The fast rate from the solver (its error, ε·‖S‖, is relative to it); the slow one from
  // λ1·λ2 = det A = g·k/(C_w·C_h), which keeps it exact to round-off however far apart the two
  // time constants are (the solver's absolute error ε·|λ1| would swamp a λ2 1e12 times smaller).
  rates_[0] = rates(0);
  rates_[1] = g * k / (cw * ch) / rates(0);
  for (int i = 0; i < 2; ++i) {
    input_[i] = input(i);
    for (int j = 0; j < 2; ++j) {
      to_modes_[i][j] = to_modes(i, j);
      from_modes_[i][j] = from_modes(i, j);
    }
  }
}

std::array<double, 2> ThermalNetwork::Step(std::array<double, 2> rise, double power,
                                           double h) const {
  std::array<double, 2> mode;
  for (int i = 0; i < 2; ++i) {
    // y_i(h) = e^{λi·h}·y_i(0) + (e^{λi·h} − 1)/λi · c_i·P, both from one expm1 (no
    // cancellation for λi·h small, the usual case: seconds to minutes against a timestep).
    const double y = to_modes_[i][0] * rise[0] + to_modes_[i][1] * rise[1];
    const double growth = std::expm1(rates_[i] * h);  // e^{λi·h} − 1
    mode[i] = y + growth * y + growth / rates_[i] * input_[i] * power;
  }
  return {from_modes_[0][0] * mode[0] + from_modes_[0][1] * mode[1],
          from_modes_[1][0] * mode[0] + from_modes_[1][1] * mode[1]};
}

std::array<double, 2> ThermalNetwork::TimeConstants() const {
  return {-1 / rates_[0], -1 / rates_[1]};
}

std::array<double, 2> ThermalNetwork::SteadyRise(double power) const {
  return {power * (p_.resistance_winding + p_.resistance_housing), power * p_.resistance_housing};
}

std::array<double, 2> RiseUnderCurrent(const ThermalNetwork& network, const HeatParams& heat,
                                       double r20, double current_squared,
                                       std::array<double, 2> rise, double duration, int pieces) {
  const double dt = duration / pieces;  // s
  for (int k = 0; k < pieces; ++k) {
    const double temperature = heat.ambient_temperature + rise[0];  // °C, T_w
    const double power =
        r20 * TemperatureFactor(heat.resistance_coefficient, temperature) * current_squared;  // W
    rise = network.Step(rise, power, dt);
  }
  return rise;
}

double SteadyWindingTemperature(const HeatParams& heat, double r20, double current_squared) {
  const double k = (heat.network.resistance_winding + heat.network.resistance_housing) * r20 *
                   current_squared;  // K per unit of R's factor
  const double alpha = heat.resistance_coefficient;
  if (!(k * alpha < 1)) return std::numeric_limits<double>::infinity();
  return heat.ambient_temperature +
         k * (1 + alpha * (heat.ambient_temperature - kReferenceTemperature)) / (1 - k * alpha);
}

}  // namespace mjstepper
