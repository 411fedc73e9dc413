// Harmonic torque compensation, Tsui 2009 eq. (8), (13), (19): the torque that cancels the detent
// harmonics of S-5 at electrical angle x,
//   τcomp(x) = Σh Kdh·sin(h·x + φh)                                             T(13)
// with the drive's own estimates of Kdh and φh (which may differ from the motor's true ones), and
// only the harmonics the user switched on. iq* = τcomp/Km.
#ifndef MJSTEPPER_CORE_CONTROLLERS_HARMONIC_COMPENSATION_H_
#define MJSTEPPER_CORE_CONTROLLERS_HARMONIC_COMPENSATION_H_

#include <cmath>
#include <vector>

#include "core/attributes.h"
#include "core/motor_params.h"

namespace mjstepper {

inline constexpr AttributeSpec kAttrDamping{
    "damping", "list", "`none`", "—",
    "Harmonic torque compensation, T(13) in `current_microstep`/`ideal_current`, T(19) in "
    "`servo`, T(8) in `identification`: `none`, `all`, or the harmonic orders to switch on, e.g. "
    "`4 2 1` or `2`."};
inline constexpr AttributeSpec kAttrDampingDetent{
    "damping_detent", "list", "the motor's `detent`", "—, N·m, rad",
    "The drive's own estimates of the harmonics it compensates (same format as `detent`); they "
    "may differ from the motor's true ones, e.g. values from `mjstepper identify`."};

struct HarmonicCompensation {
  std::vector<DetentHarmonic> harmonics;  ///< the enabled harmonics, the drive's estimates

  static std::vector<const AttributeSpec*> Attributes() {
    return {&kAttrDamping, &kAttrDampingDetent};
  }
  /// `damping` selects from `damping_detent` (default: the motor's detent).
  static HarmonicCompensation FromAttributes(const AttributeSource& a, const MotorParams& motor);

  /// τcomp(x) in N·m.
  double Torque(double elec_angle) const {
    double torque = 0;
    for (const DetentHarmonic& h : harmonics) {
      torque += h.amplitude * std::sin(h.order * elec_angle + h.phase);
    }
    return torque;
  }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_HARMONIC_COMPENSATION_H_
