// The digital PI current loop of Tsui 2009 eq. (9)-(11), in a Park frame at angle ψ.
//   i_dq[k] = e^{−jψ}·i_ab(t_k)                                               T(11), S-9
//   e[k] = i*_dq[k] − i_dq[k]
//   s[k] = s[k−1] + Ki·e[k]          (Ki per tick, V/A: 0.01 at 20 kHz = 200 V/(A·s))   T(9)-(10)
//   v_dq[k] = Kp·e[k] + s[k],   v_ab[k] = e^{jψ}·v_dq[k]                         S-10
// The power stage limits v_ab (S-13/S-14). Anti-windup by conditional integration: when the stage
// cuts the request, s[k] = s[k−1].
#ifndef MJSTEPPER_CORE_CONTROLLERS_DQ_CURRENT_LOOP_H_
#define MJSTEPPER_CORE_CONTROLLERS_DQ_CURRENT_LOOP_H_

#include <vector>

#include "core/attributes.h"
#include "core/motor.h"
#include "core/power_stage.h"

namespace mjstepper {

inline constexpr AttributeSpec kAttrKp{"kp", "real", "7.5", "V/A",
                                       "PI current-loop proportional gain, T(9); ≥ 0."};
inline constexpr AttributeSpec kAttrKi{
    "ki", "real", "0.01", "V/A per tick",
    "PI integral gain **per interrupt**, T(10); at 20 kHz 0.01 is 200 V/(A·s). ≥ 0."};

struct DqCurrentLoop {
  double kp = 7.5;            ///< V/A, T(9)
  double ki_per_tick = 0.01;  ///< V/A per tick, T(10)

  static std::vector<const AttributeSpec*> Attributes() { return {&kAttrKp, &kAttrKi}; }
  static DqCurrentLoop FromAttributes(const AttributeSource& a) {
    using Rule = AttributeSource::Rule;
    return {.kp = a.Real(kAttrKp, 7.5, Rule::kNonNegative),
            .ki_per_tick = a.Real(kAttrKi, 0.01, Rule::kNonNegative)};
  }

  /// One tick; `integral_dq` is s[k−1] on entry and s[k] on return (V, d + j·q).
  BridgeOutput Update(PhaseVector setpoint_dq, PhaseVector park_phasor, PhaseVector current_ab,
                      const PowerStage& stage, PhaseVector* integral_dq) const {
    const PhaseVector error = setpoint_dq - std::conj(park_phasor) * current_ab;  // e[k]
    const PhaseVector integral = *integral_dq + ki_per_tick * error;              // s[k]
    const BridgeOutput out = stage.Apply(park_phasor * (kp * error + integral));
    if (!out.saturated) *integral_dq = integral;  // conditional integration
    return out;
  }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_DQ_CURRENT_LOOP_H_
