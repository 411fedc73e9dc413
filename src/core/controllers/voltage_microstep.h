// Open-loop voltage microstepping, Kim 2016 eq. (5), SPEC §3.
//   va = Vmax·cos(Nr·θd),   vb = Vmax·sin(Nr·θd)                                  K(5)
// No current feedback: at rest the current settles to Vmax/R along the commanded electrical angle;
// when turning, the back-EMF and L cut and delay it (the motor's own R/L filter).
#ifndef MJSTEPPER_CORE_CONTROLLERS_VOLTAGE_MICROSTEP_H_
#define MJSTEPPER_CORE_CONTROLLERS_VOLTAGE_MICROSTEP_H_

#include "core/controllers/controller.h"

namespace mjstepper {

inline constexpr AttributeSpec kAttrVoltageAmplitude{
    "voltage_amplitude", "real", "R·I_rated of the preset (2.7, 4.6, 1.1)", "V",
    "Vmax of `voltage_microstep`, K(5): at rest the current is Vmax/R, so the default rests the "
    "motor at its rated current. > 0 and ≤ `bus_voltage`."};

struct VoltageMicrostep {
  static constexpr const char* kName = "voltage_microstep";
  static constexpr const char* kSummary =
      "open-loop voltage microstepping, K(5): va = Vmax·cos(Nr·θcmd), vb = Vmax·sin(Nr·θcmd).";
  static constexpr SpeedFeedback kDefaultSpeedFeedback = SpeedFeedback::kEstimate;
  /// How HoldingStiffness() is obtained (for `mjstepper info`).
  static constexpr const char* kStiffnessFormula = "Nr·Km·I, T(1), I = Vmax/R";
  static constexpr bool kCountsSlips = true;

  double voltage_amplitude = 2.7;  ///< Vmax, V (Tsui: R·I_rated = 0.9 Ω · 3 A)

  struct State {};  // stateless
  using Input = MechanicalSample;

  static std::vector<const AttributeSpec*> Attributes() { return {&kAttrVoltageAmplitude}; }
  static VoltageMicrostep FromAttributes(const AttributeSource& a, const MotorParams& motor,
                                         const DriveConstants&) {
    return {.voltage_amplitude =
                a.Real(kAttrVoltageAmplitude, motor.resistance * motor.rated_current,
                       AttributeSource::Rule::kPositive)};
  }

  TickOutput Tick(const DriveConstants& k, const Input& in, const PowerStage& stage, State*) const {
    const PhaseVector v = voltage_amplitude * UnitPhasor(k.rotor_teeth * in.command.theta);  // K(5)
    return {.bridge = stage.Apply(v), .current_ref = v / k.resistance};                      // K(4)
  }

  /// The amplitude of the rotating voltage K(5) samples (V): the averaged fidelity applies the
  /// phasor itself, continuous (SPEC §11, drive.cc).
  double RotatingAmplitude() const { return voltage_amplitude; }

  /// Phase currents at rest, aligned with the command: Vmax/R·e^{jNrθcmd}.
  PhaseVector Rest(const DriveConstants& k, const RestInput& in, State*) const {
    return voltage_amplitude / k.resistance * UnitPhasor(k.rotor_teeth * in.theta_cmd);
  }
  double HoldingStiffness(const DriveConstants& k, PhaseVector rest_current) const {
    return OpenLoopStiffness(k, rest_current);
  }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_VOLTAGE_MICROSTEP_H_
