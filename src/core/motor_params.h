// Parameters of one two-phase hybrid or permanent-magnet stepper motor, SPEC §1 and §4.
#ifndef MJSTEPPER_CORE_MOTOR_PARAMS_H_
#define MJSTEPPER_CORE_MOTOR_PARAMS_H_

#include <vector>

namespace mjstepper {

/// One detent (cogging) harmonic of S-5:  τdet,h = −Kdh·sin(h·x + φh),  x = Nr·θ.
struct DetentHarmonic {
  int order = 1;         ///< h, multiple of the electrical angle; >= 1
  double amplitude = 0;  ///< Kdh, N·m; >= 0
  double phase = 0;      ///< φh, rad
};

/// The electrical and magnetic constants of S-1..S-8. Mechanical constants (rotor inertia J,
/// viscous damping B, static friction Fs) belong to the MuJoCo model (actuator armature, damping,
/// joint frictionloss); they are carried here only as the preset's documented values.
struct MotorParams {
  int rotor_teeth = 50;          ///< Nr (Tsui: "pole pairs"); electrical angle x = Nr·θ, S-1
  double resistance = 0.9;       ///< R, Ω per phase; > 0
  double inductance = 2.2e-3;    ///< L, H per phase; > 0
  double torque_constant = 0.3;  ///< Km, N·m/A = V·s/rad; > 0
  std::vector<DetentHarmonic> detent;  ///< S-5, any list of harmonics
  // Preset values for the MuJoCo model; not used by the drive.
  double rotor_inertia = 0.36e-4;  ///< J, kg·m² (actuator armature)
  double viscous_damping = 1e-3;   ///< B, N·m·s/rad (actuator or joint damping)
  double static_friction = 0.0;    ///< Fs, N·m (joint frictionloss)
  double load_torque = 0.0;        ///< τl of the paper's setup, N·m (Kim: 0.1; a MuJoCo force)
  double rated_current = 3.0;      ///< I_rated, A: the datasheet's phase current
  /// The default id* of the current drives (`hold_current`), A: Tsui's 1.9 for the paper presets,
  /// √2·I_rated for catalogue motors (the peak of the rated RMS current: their datasheet's holding
  /// torque and temperature rise).
  double hold_current = 1.9;
};

/// Throws std::invalid_argument naming the field, its value and the rule when a value is out of
/// range (NaN included).
void Validate(const MotorParams& p);

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_MOTOR_PARAMS_H_
