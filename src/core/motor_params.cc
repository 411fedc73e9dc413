#include "core/motor_params.h"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace mjstepper {
namespace {

// Written as !(v > 0) so that NaN fails too.
void RequirePositive(const char* name, double value, const char* unit) {
  if (!(value > 0) || !std::isfinite(value)) {
    throw std::invalid_argument(
        fmt::format("MotorParams: {} = {} {}; must be finite and > 0", name, value, unit));
  }
}

}  // namespace

void Validate(const MotorParams& p) {
  if (p.rotor_teeth < 1) {
    throw std::invalid_argument(
        fmt::format("MotorParams: rotor_teeth = {}; must be >= 1", p.rotor_teeth));
  }
  RequirePositive("resistance", p.resistance, "Ω");
  RequirePositive("inductance", p.inductance, "H");
  RequirePositive("torque_constant", p.torque_constant, "N·m/A");
  for (size_t i = 0; i < p.detent.size(); ++i) {
    const DetentHarmonic& h = p.detent[i];
    if (h.order < 1 || !(h.amplitude >= 0) || !std::isfinite(h.amplitude) ||
        !std::isfinite(h.phase)) {
      throw std::invalid_argument(fmt::format(
          "MotorParams: detent[{}] = (order {}, amplitude {} N·m, phase {} rad); need order >= 1, "
          "finite amplitude >= 0, finite phase",
          i, h.order, h.amplitude, h.phase));
    }
  }
}

}  // namespace mjstepper
