// The gear train between a rotor and its load (SPEC §12, "Gear trains"): its efficiency, which a
// simulator applies to the torque the rotor hands the load, and the carriage a rotary joint may
// move (a belt pulley or a lead screw), in whose units the tools speak (issue 32, item 3). (Its
// Coulomb and viscous friction and its own inertia are the joint's `frictionloss`, `damping` and
// `armature` in MJCF, which MuJoCo treats as constraints and implicitly: models/README.md, "Gear
// trains".)
//
// A train of efficiency η_f passes η_f of the power that drives it forward (motor → load) and
// η_b of the power that drives it back (load → motor). In rotor terms, with τ the rotor's torque
// and ω its speed:
//   τ·ω > 0 (the motor drives):      the load receives   s·τ,  s = η_f
//   τ·ω < 0 (the load drives it):    the load must exert s·τ,  s = 1/η_b   (the train's loss adds
//                                                                          to the motor's braking)
// So the torque handed to the load is s·τ: a loss that opposes the motion and scales with the
// transmitted torque, as a gear mesh's friction does (Modelica's LossyGear: separate efficiencies
// driving and driven). At standstill the direction of the power is undecided: within a speed
// band |ω| < kEfficiencyBand the factor moves linearly from 1 at ω = 0 to its value at the band's
// edge, so that a held rotor does not chatter between the two (a static gear holds what it
// holds; its breakaway is the joint's frictionloss).
#ifndef MJSTEPPER_CORE_TRANSMISSION_H_
#define MJSTEPPER_CORE_TRANSMISSION_H_

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

namespace mjstepper {

/// The rotor speed over which the efficiency comes in, rad/s (rotor side): 1 rad/s is 9.5 r/min,
/// a full step of a 1.8° motor every 31 ms.
inline constexpr double kEfficiencyBand = 1.0;

struct Transmission {
  double efficiency = 1.0;            ///< η_f in (0, 1]: motor → load
  double backdrive_efficiency = 1.0;  ///< η_b in (0, 1]: load → motor
  /// The carriage on a hinge joint, declared once: a timing-belt pulley of `pulley_teeth` teeth
  /// on a belt of `belt_pitch` (m), or a lead screw of `lead` (m per turn). The carriage moves
  /// TravelPerRevolution() per turn of the joint (Klipper's rotation_distance), x = q·travel/2π.
  /// None set: a rotary load.
  int pulley_teeth = 0;
  double belt_pitch = 0;  ///< m, with pulley_teeth
  double lead = 0;        ///< m per turn of the joint

  bool Lossless() const { return efficiency == 1.0 && backdrive_efficiency == 1.0; }

  /// m the carriage moves per turn of the joint; 0 on a rotary load.
  double TravelPerRevolution() const { return pulley_teeth > 0 ? pulley_teeth * belt_pitch : lead; }
  /// m per rad of the joint (a pulley's pitch radius); 0 on a rotary load.
  double MetresPerRadian() const { return TravelPerRevolution() / (2 * std::numbers::pi); }
  /// What declares the carriage, for messages: "pulley_teeth = 20, belt_pitch = 0.002 m (40 mm per
  /// turn)", "lead = 0.008 m (8 mm per turn)"; "" on a rotary load.
  std::string CarriageText() const;

  /// The factor s on the rotor's torque τ (N·m) at rotor speed ω (rad/s): the torque the load
  /// receives is s·τ. Continuous in ω; 1 when lossless.
  double Scale(double torque, double omega) const {
    if (Lossless() || torque == 0) return 1.0;
    const double u = std::clamp((torque > 0 ? omega : -omega) / kEfficiencyBand, -1.0, 1.0);
    return u >= 0 ? 1.0 + (efficiency - 1.0) * u : 1.0 + (1.0 / backdrive_efficiency - 1.0) * -u;
  }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_TRANSMISSION_H_
