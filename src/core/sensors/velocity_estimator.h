// Velocity estimate of the Tsui servo, S-17: the backward difference of the encoder angle at each
// tick (T = 50 µs: one count of 4000 is a quantum of 2π/4000/T = 31.4 rad/s = 300 r/min), then a
// first-order IIR low-pass with corner fc (32 Hz):
//   w_raw[k] = (θmeas[k] − θmeas[k−1]) / T
//   w[k] = w[k−1] + a·(w_raw[k] − w[k−1]),   a = 1 − exp(−2π·fc·T)
// (the step-invariant discretisation of 1/(1 + s/(2π·fc))).
#ifndef MJSTEPPER_CORE_SENSORS_VELOCITY_ESTIMATOR_H_
#define MJSTEPPER_CORE_SENSORS_VELOCITY_ESTIMATOR_H_

#include <cmath>

#include "core/units.h"

namespace mjstepper {

struct VelocityEstimator {
  double period = 50e-6;  ///< T, s
  double cutoff = 32.0;   ///< fc, Hz

  double Gain() const { return 1.0 - std::exp(-kTwoPi * cutoff * period); }

  /// One tick: `previous_angle` (rad) and `estimate` (rad/s) are updated in place.
  void Update(double measured_angle, double* previous_angle, double* estimate) const {
    Update(Gain(), measured_angle, previous_angle, estimate);
  }
  /// The same with the gain a = Gain() computed once (the drive's per-tick path).
  void Update(double gain, double measured_angle, double* previous_angle, double* estimate) const {
    const double raw = (measured_angle - *previous_angle) / period;
    *estimate += gain * (raw - *estimate);
    *previous_angle = measured_angle;
  }
  /// The estimate over `duration` (s) of ticks at a constant speed `omega` (rad/s), where each
  /// tick's raw difference is ω: e ← ω + (e − ω)·(1 − a) per period, and (1 − a)^{Δ/T} =
  /// e^{−2π·fc·Δ}. An averaged drive's estimate (SPEC §11), continuous in Δ.
  void Advance(double omega, double duration, double* estimate) const {
    *estimate = omega + (*estimate - omega) * std::exp(-kTwoPi * cutoff * duration);
  }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_SENSORS_VELOCITY_ESTIMATOR_H_
