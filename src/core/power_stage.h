// Power stage: the phase voltages the bridges can make from one bus, S-13 and S-14.
#ifndef MJSTEPPER_CORE_POWER_STAGE_H_
#define MJSTEPPER_CORE_POWER_STAGE_H_

#include <numbers>

#include "core/motor.h"

namespace mjstepper {

enum class PowerStageKind {
  kTwoHBridges,    ///< S-13: each phase its own full bridge, |va|, |vb| <= Vbus
  kThreeLegSvpwm,  ///< S-14: legs α, β and a common return γ (Tsui eq. 14-17)
};

/// What the stage applies, and whether the request was cut (the controller's anti-windup input).
struct BridgeOutput {
  PhaseVector voltage;     ///< V, applied va + j·vb
  bool saturated = false;  ///< true when the request was outside the stage's range
};

/// Leg (pole) voltages of the three-leg stage, each in [0, Vbus]: va = vα − vγ, vb = vβ − vγ.
struct LegVoltages {
  double alpha = 0, beta = 0, gamma = 0;  ///< V
};

struct PowerStage {
  PowerStageKind kind = PowerStageKind::kTwoHBridges;
  double bus_voltage = 48.0;  ///< Vbus, V; > 0

  /// The phase voltages for a request. Two H-bridges clamp each phase (S-13); SVPWM is linear while
  /// max(va, vb, 0) − min(va, vb, 0) <= Vbus and beyond that scales (va, vb) down keeping their
  /// direction (S-14, over-modulation).
  BridgeOutput Apply(PhaseVector request) const;
  /// The largest |va + j·vb| that Apply never cuts, V: Vbus for two H-bridges (|va|, |vb| <=
  /// |v|), Vbus/√2 for SVPWM (max(va, vb, 0) − min(va, vb, 0) <= √2·|v|).
  double LinearRadius() const {
    return kind == PowerStageKind::kTwoHBridges ? bus_voltage : bus_voltage / std::numbers::sqrt2;
  }

  /// S-14, T(14)-(17): vo = Vbus/2 − (max(va,vb,0) + min(va,vb,0))/2, vα = va + vo, vβ = vb + vo,
  /// vγ = vo, for phase voltages inside the linear range.
  LegVoltages SvpwmLegs(PhaseVector voltage) const;
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_POWER_STAGE_H_
