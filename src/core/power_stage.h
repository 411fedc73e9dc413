// Power stage: the voltage the bridges can put on the phases, S-13.
#ifndef MJSTEPPER_CORE_POWER_STAGE_H_
#define MJSTEPPER_CORE_POWER_STAGE_H_

#include "core/motor.h"

namespace mjstepper {

/// What the bridges apply, and whether the request was cut (the controller's anti-windup input).
struct BridgeOutput {
  PhaseVector voltage;     ///< V, applied
  bool saturated = false;  ///< true when the request was outside the bridges' range
};

/// S-13, two full H-bridges from one bus: each phase independently |va|, |vb| <= Vbus.
struct TwoHBridges {
  double bus_voltage = 48.0;  ///< Vbus, V; > 0
  BridgeOutput Apply(PhaseVector request) const;
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_POWER_STAGE_H_
