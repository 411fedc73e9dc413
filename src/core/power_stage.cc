#include "core/power_stage.h"

#include <algorithm>

namespace mjstepper {

BridgeOutput TwoHBridges::Apply(PhaseVector request) const {
  const double va = std::clamp(request.real(), -bus_voltage, bus_voltage);  // S-13
  const double vb = std::clamp(request.imag(), -bus_voltage, bus_voltage);
  return {.voltage = {va, vb}, .saturated = va != request.real() || vb != request.imag()};
}

}  // namespace mjstepper
