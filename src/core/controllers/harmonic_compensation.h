// Harmonic torque compensation, Tsui 2009 eq. (8), (13), (19): the torque that cancels the detent
// harmonics of S-5 at electrical angle x,
//   τcomp(x) = Σh Kdh·sin(h·x + φh)                                             T(13)
// with the drive's own estimates of Kdh and φh (which may differ from the motor's true ones), and
// only the harmonics the user switched on. iq* = τcomp/Km.
#ifndef MJSTEPPER_CORE_CONTROLLERS_HARMONIC_COMPENSATION_H_
#define MJSTEPPER_CORE_CONTROLLERS_HARMONIC_COMPENSATION_H_

#include <cmath>
#include <vector>

#include "core/motor_params.h"

namespace mjstepper {

struct HarmonicCompensation {
  std::vector<DetentHarmonic> harmonics;  ///< the enabled harmonics, the drive's estimates

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
