// `mjstepper identify`: estimate a stepper's detent harmonics and static friction the way Tsui's
// bench does (Tsui 2009 §II.C): the drive in identification mode with the position loop off
// (T(7)-(8)), something else turning the shaft at constant speed, and the torque that takes read
// against the encoder angle. At constant speed (motor torque ≈ 0, J·α ≈ 0) the turning torque is
//   τext(θ) = −τdet(θ) + Fs + B·ω = Σh Kdh·sin(h·Nr·θ + φh) + Fs + B·ω                S-5..S-7
// so a least-squares fit of τext on sin(h·x), cos(h·x) with x = Nr·θ and one constant per speed
// gives Kdh = √(a² + b²), φh = atan2(b, a), and the constants at two speeds give Fs and B.
#ifndef MJSTEPPER_TOOLS_IDENTIFY_H_
#define MJSTEPPER_TOOLS_IDENTIFY_H_

#include <iosfwd>
#include <string>
#include <vector>

#include "config_overrides.h"
#include "core/motor_params.h"

namespace mjstepper::tools {

struct IdentifyOptions {
  std::string model;               ///< MJCF with the stepper and a velocity actuator turning it
  std::string actuator = "shaft";  ///< the stepper
  std::string dyno = "dyno";       ///< the actuator that turns the shaft; ctrl = speed (rad/s)
  std::vector<double> speeds;      ///< rad/s, at least two of one sign to separate Fs from B
  std::vector<int> orders = {4, 2, 1};  ///< harmonics fitted
  double settle = 0.3;                  ///< s at each speed before measuring
  double measure = 1.0;                 ///< s measured at each speed
  std::vector<ConfigOverride> overrides;
};

struct Identified {
  std::vector<DetentHarmonic> harmonics;  ///< Kdh (N·m), φh (rad), in IdentifyOptions::orders
  double static_friction = 0;             ///< Fs, N·m
  double viscous_damping = 0;             ///< B, N·m·s/rad
  double residual_rms = 0;                ///< N·m, what the fit leaves of τext

  /// The estimates as a `damping_detent` value: "4 K φ; 2 K φ; 1 K φ".
  std::string DampingDetent() const;
};

/// Throws std::runtime_error / std::invalid_argument with a message for the user.
Identified Identify(const IdentifyOptions& options);

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_IDENTIFY_H_
