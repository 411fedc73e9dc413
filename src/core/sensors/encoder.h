// Incremental encoder, S-16: θmeas = floor(θ·cpr/2π)·2π/cpr (Tsui 4000 counts/rev, Kim 32000).
#ifndef MJSTEPPER_CORE_SENSORS_ENCODER_H_
#define MJSTEPPER_CORE_SENSORS_ENCODER_H_

#include <cmath>

#include "core/units.h"

namespace mjstepper {

/// The measured angle (rad) of an encoder with `counts` per revolution; counts <= 0: ideal.
inline double EncoderAngle(double theta, int counts) {
  if (counts <= 0) return theta;
  const double quantum = kTwoPi / counts;  // rad per count
  return std::floor(theta / quantum) * quantum;
}

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_SENSORS_ENCODER_H_
