#include "core/power_stage.h"

#include <algorithm>

namespace mjstepper {

BridgeOutput PowerStage::Apply(PhaseVector request) const {
  const double va = request.real(), vb = request.imag();
  if (kind == PowerStageKind::kTwoHBridges) {
    const double ca = std::clamp(va, -bus_voltage, bus_voltage);  // S-13
    const double cb = std::clamp(vb, -bus_voltage, bus_voltage);
    return {.voltage = {ca, cb}, .saturated = ca != va || cb != vb};
  }
  // S-14: the legs can make any (va, vb) whose span max(va, vb, 0) − min(va, vb, 0) fits the bus.
  const double span = std::max({va, vb, 0.0}) - std::min({va, vb, 0.0});
  if (span <= bus_voltage) return {.voltage = request, .saturated = false};
  return {.voltage = request * (bus_voltage / span), .saturated = true};
}

LegVoltages PowerStage::SvpwmLegs(PhaseVector voltage) const {
  const double va = voltage.real(), vb = voltage.imag();
  const double v_max = std::max({va, vb, 0.0});             // T(15)
  const double v_min = std::min({va, vb, 0.0});             // T(16)
  const double vo = bus_voltage / 2 - (v_max + v_min) / 2;  // T(17)
  return {.alpha = va + vo, .beta = vb + vo, .gamma = vo};  // T(14)
}

}  // namespace mjstepper
