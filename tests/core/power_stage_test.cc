// Power stages, S-13 and S-14 (Tsui eq. 14-17): the SVPWM linear range, its scaling, its legs.
#include "core/power_stage.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace mjstepper {
namespace {

// A rotating vector of amplitude V ≤ Vbus/√2 is in the linear range at every angle: applied as
// asked, and the legs of T(14)-(17) lie in [0, Vbus] and make va = vα − vγ, vb = vβ − vγ.
TEST(PowerStage, SvpwmLinearRangeIsVbusOverRootTwo) {
  const PowerStage stage{.kind = PowerStageKind::kThreeLegSvpwm, .bus_voltage = 48};
  const double amplitude = 48 / std::sqrt(2.0) * (1 - 1e-12);
  for (int k = 0; k < 3600; ++k) {
    const PhaseVector v = std::polar(amplitude, k * std::numbers::pi / 1800);
    const BridgeOutput out = stage.Apply(v);
    ASSERT_FALSE(out.saturated) << "angle step " << k;
    EXPECT_EQ(out.voltage, v);
    const LegVoltages legs = stage.SvpwmLegs(out.voltage);
    for (double leg : {legs.alpha, legs.beta, legs.gamma}) {
      EXPECT_GE(leg, -1e-12);
      EXPECT_LE(leg, 48 + 1e-12);
    }
    EXPECT_NEAR(legs.alpha - legs.gamma, v.real(), 1e-12);
    EXPECT_NEAR(legs.beta - legs.gamma, v.imag(), 1e-12);
  }
  // Just beyond Vbus/√2 at −45° (va = −vb, where the span va − vb is largest): saturated.
  EXPECT_TRUE(stage.Apply(std::polar(48 / std::sqrt(2.0) * 1.01, -std::numbers::pi / 4)).saturated);
}

// Over-modulation: the request is scaled down keeping its direction, onto span = Vbus exactly.
TEST(PowerStage, SvpwmOvermodulationScalesKeepingDirection) {
  const PowerStage stage{.kind = PowerStageKind::kThreeLegSvpwm, .bus_voltage = 48};
  const PhaseVector request(60.0, -30.0);  // span 90 V
  const BridgeOutput out = stage.Apply(request);
  EXPECT_TRUE(out.saturated);
  EXPECT_NEAR(std::arg(out.voltage), std::arg(request), 1e-15);
  EXPECT_NEAR(out.voltage.real() - out.voltage.imag(), 48.0, 1e-12);
  // Along a phase axis the three-leg stage reaches the full bus, like an H-bridge.
  EXPECT_FALSE(stage.Apply({48.0, 0.0}).saturated);
}

// Two H-bridges clamp each phase on its own (S-13), changing the direction.
TEST(PowerStage, TwoHBridgesClampEachPhase) {
  const PowerStage stage{.kind = PowerStageKind::kTwoHBridges, .bus_voltage = 48};
  const BridgeOutput out = stage.Apply({60.0, -30.0});
  EXPECT_TRUE(out.saturated);
  EXPECT_EQ(out.voltage, PhaseVector(48.0, -30.0));
  EXPECT_FALSE(stage.Apply({48.0, -48.0}).saturated);  // the full square: H-bridges reach √2 more
}

}  // namespace
}  // namespace mjstepper
