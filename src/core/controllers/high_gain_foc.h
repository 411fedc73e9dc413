// The high-gain FOC baseline of Kim 2016 §5, eq. (33)-(34), SPEC §3.
//
// The same mechanical controller K(24) and commutation K(27) as the STMMS (kim_mechanical.h),
// then current feedback with a high gain ρ:
//   va = R·ia − Km·ω·sin(Nr·θ) + L·(i̇ad + ρ·(iad − ia))                               K(33)
//   vb = R·ib + Km·ω·cos(Nr·θ) + L·(i̇bd + ρ·(ibd − ib))
// With exact R, L, Km and the back-EMF, L·d(id − i)/dt = −L·ρ·(id − i): the current error decays
// at ρ (H20). Named gain sets (Kim §5, SPEC §7 corrections): case1 k1p = 1000, ρ = 25000;
// case2 k1p = 10000, ρ = 10000; k0 = 10, k1 = 20, k2 = 100 in both.
//
// i̇d: the paper does not say how it was obtained. `foc_derivative` chooses:
//   analytic (default): differentiate K(27) along the motion,
//     i̇d = j·e^{jx}·(τ̇d + j·Nr·ω·τd)/Km,
//     τ̇d = B·ω̇ + J·(θ⃛d − k1p·ë1 − k0·e1 − k1·ė1 − k2·ė2),  ë1 = ω̇ − θ̈d,  ė2 = ë1 + k1p·ė1,
//     with ω̇ from the controller's own model and the measured current,
//     ω̇ = (Km·Im(e^{−jx}·i) − B·ω − τl)/J   (S-4, S-7): what a continuous-time design means;
//   numeric: the backward difference (id[k] − id[k−1])/T over the control period, what a DSP
//     implementation does; it lags by half a period and is 0 at the first tick. With the exact
//     speed feedback (ideal sensors) it also differences the simulator's speed, constant over
//     each MuJoCo step h (the step's chord): where the rotor accelerates at a, the tick after a
//     step boundary sees ω change by a·h and applies about L·J·(k1p + k2)·a·h/(Km·T) for one
//     tick (Kim's case 2 at h = 50 µs, a = 4π rad/s²: 5.7 V), which the `voltage_peak` signal
//     shows and a continuous rotor would not: keep h small with it.
#ifndef MJSTEPPER_CORE_CONTROLLERS_HIGH_GAIN_FOC_H_
#define MJSTEPPER_CORE_CONTROLLERS_HIGH_GAIN_FOC_H_

#include "core/controllers/controller.h"
#include "core/controllers/kim_mechanical.h"

namespace mjstepper {

inline constexpr AttributeSpec kAttrFocCase{
    "foc_case", "name", "`case1`", "—",
    "Kim's named gain sets for `foc` (§5): `case1` k1p = 1000, ρ = 25000; `case2` k1p = 10000, "
    "ρ = 10000. `k1p` and `rho` override them."};
inline constexpr AttributeSpec kAttrRho{"rho", "real", "the case's (25000 or 10000)", "1/s",
                                        "ρ of K(33): the current error decays at ρ. > 0."};
inline constexpr AttributeSpec kAttrFocDerivative{
    "foc_derivative", "name", "`analytic`", "—",
    "How `foc` gets dia_d/dt, dib_d/dt of K(33): `analytic` (K(27) differentiated along the "
    "motion, ω̇ from the measured current through the controller's model) or `numeric` (backward "
    "difference over one control period; with exact speed feedback it also sees the speed's step "
    "of a·h at each MuJoCo step, for one tick about L·J·(k1p + k2)·a·h/(Km·T) V: keep the "
    "timestep small)."};

struct HighGainFoc {
  static constexpr const char* kName = "foc";
  static constexpr const char* kSummary =
      "Kim's high-gain FOC baseline, K(33)-(34): the STMMS position controller with current "
      "feedback of gain ρ; `foc_case` picks case1 or case2.";
  static constexpr SpeedFeedback kDefaultSpeedFeedback = SpeedFeedback::kExact;
  /// How HoldingStiffness() is obtained (for `mjstepper info`).
  static constexpr const char* kStiffnessFormula = "J·(k1 + k1p·k2), K(26)";
  static constexpr bool kCountsSlips = false;

  enum class Derivative { kAnalytic, kNumeric };

  KimMechanical mechanical;
  double rho = 25000;  ///< 1/s
  Derivative derivative = Derivative::kAnalytic;

  struct State {
    double e0 = 0;            ///< ∫e1 dt, rad·s, K(22)
    double previous_a = 0;    ///< iad at the previous tick, A (numeric derivative)
    double previous_b = 0;    ///< ibd, A
    double has_previous = 0;  ///< 1 once previous_a/b hold a tick's value
  };
  using Input = Sample;

  static std::vector<const AttributeSpec*> Attributes();
  static HighGainFoc FromAttributes(const AttributeSource& a, const MotorParams& motor,
                                    const DriveConstants& k);
  TickOutput Tick(const DriveConstants& k, const Input& in, const PowerStage& stage,
                  State* s) const;
  /// τ̇d of the analytic derivative, N·m/s: B·ω̇ + J·(θ⃛d − k1p·ë1 − k0·e1 − k1·ė1 − k2·ė2),
  /// given the rotor's acceleration ω̇ (rad/s²) as the controller's model has it.
  double TorqueRate(const MechanicalSample& in, const KimMechanical::Errors& e,
                    double omega_dot) const;
  PhaseVector Rest(const DriveConstants& k, const RestInput& in, State* s) const;
  double HoldingStiffness(const DriveConstants&, PhaseVector) const {
    return mechanical.Stiffness();
  }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_HIGH_GAIN_FOC_H_
