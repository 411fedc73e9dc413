// Current-controlled microstepping with open-loop harmonic damping, Tsui 2009 §III.A, SPEC §3.
//
// Park frame at the commanded electrical angle, open loop in position (S-12):
//   ψ = Nr·θcmd
//   id* = I_hold                                                               T(12)
//   iq* = (1/Km)·Σh Kdh·sin(h·Nr·θcmd + φh)   (0 with no harmonic enabled)      T(13)
// then the PI current loop of T(9)-(11) in that frame (dq_current_loop.h).
// `IdealCurrent` is the same setpoint forced on the windings at every instant (no loop, no R/L).
#ifndef MJSTEPPER_CORE_CONTROLLERS_CURRENT_MICROSTEP_H_
#define MJSTEPPER_CORE_CONTROLLERS_CURRENT_MICROSTEP_H_

#include <cmath>
#include <numbers>

#include "core/controllers/controller.h"
#include "core/controllers/dq_current_loop.h"
#include "core/controllers/harmonic_compensation.h"
#include "core/controllers/step_table.h"

namespace mjstepper {

inline constexpr AttributeSpec kAttrHoldCurrent{
    "hold_current", "real", "1.9 (paper presets); √2·rated current (catalogue presets)", "A",
    "id* of `current_microstep` and `ideal_current`, T(12); > 0. A catalogue motor defaults to the "
    "peak of its rated RMS current, at which its datasheet states the holding torque and the "
    "temperature rise, so that no default overdrives it."};

/// The T(12)-(13) setpoint shared by the PI drive and the ideal current source.
struct MicrostepSetpoint {
  double hold_current = 1.9;     ///< I_hold, A, T(12)
  HarmonicCompensation damping;  ///< T(13); empty: no damping
  int microsteps = 0;            ///< per full step; 0: continuous

  /// The setpoint's electrical angle ψ: Nr·θcmd (S-12), rounded to the microstep grid.
  double Angle(const DriveConstants& k, double theta_cmd) const {
    const double psi = k.rotor_teeth * theta_cmd;
    if (microsteps == 0) return psi;
    const double step = std::numbers::pi / 2 / microsteps;  // electrical rad per microstep
    return step * std::round(psi / step);
  }
  /// id* + j·iq* at the commanded angle, T(12)-(13).
  PhaseVector Dq(const DriveConstants& k, double theta_cmd) const {
    return {hold_current, damping.Torque(k.rotor_teeth * theta_cmd) / k.torque_constant};
  }
  /// The same in the phase frame (S-10 at ψ).
  PhaseVector Phase(const DriveConstants& k, double theta_cmd) const {
    return FromDq(Dq(k, theta_cmd), Angle(k, theta_cmd));
  }
  static MicrostepSetpoint FromAttributes(const AttributeSource& a, const MotorParams& motor) {
    return {.hold_current =
                a.Real(kAttrHoldCurrent, motor.hold_current, AttributeSource::Rule::kPositive),
            .damping = HarmonicCompensation::FromAttributes(a, motor),
            .microsteps = a.Integer(kAttrMicrosteps, 0, 0, 4096)};
  }
};

struct CurrentMicrostep {
  static constexpr const char* kName = "current_microstep";
  static constexpr const char* kSummary =
      "PI current loop in the commanded frame, T(9)-(12), with the open-loop damping of T(13) "
      "when `damping` is set.";
  static constexpr SpeedFeedback kDefaultSpeedFeedback = SpeedFeedback::kEstimate;
  /// How HoldingStiffness() is obtained (for `mjstepper info`).
  static constexpr const char* kStiffnessFormula = "Nr·Km·I, T(1)";
  static constexpr bool kCountsSlips = true;

  MicrostepSetpoint setpoint;
  DqCurrentLoop loop;

  struct State {
    double integral_d = 0;  ///< V, PI integrator s, d axis
    double integral_q = 0;  ///< V, q axis
  };
  using Input = Sample;

  static std::vector<const AttributeSpec*> Attributes() {
    return {&kAttrHoldCurrent, &kAttrMicrosteps, &kAttrKp,
            &kAttrKi,          &kAttrDamping,    &kAttrDampingDetent};
  }
  static CurrentMicrostep FromAttributes(const AttributeSource& a, const MotorParams& motor,
                                         const DriveConstants&) {
    return {.setpoint = MicrostepSetpoint::FromAttributes(a, motor),
            .loop = DqCurrentLoop::FromAttributes(a)};
  }

  TickOutput Tick(const DriveConstants& k, const Input& in, const PowerStage& stage,
                  State* s) const {
    const PhaseVector park = UnitPhasor(setpoint.Angle(k, in.command.theta));  // ψ = Nr·θcmd
    const PhaseVector target = setpoint.Dq(k, in.command.theta);
    PhaseVector integral(s->integral_d, s->integral_q);
    const BridgeOutput out = loop.Update(target, park, in.current, stage, &integral);
    s->integral_d = integral.real();
    s->integral_q = integral.imag();
    return {.bridge = out, .current_ref = park * target};
  }

  /// Currents on the setpoint at θcmd, and the integrator that holds them against R.
  PhaseVector Rest(const DriveConstants& k, const RestInput& in, State* s) const {
    const PhaseVector integral = k.resistance * setpoint.Dq(k, in.theta_cmd);  // V
    s->integral_d = integral.real();
    s->integral_q = integral.imag();
    return setpoint.Phase(k, in.theta_cmd);
  }
  double HoldingStiffness(const DriveConstants& k, PhaseVector rest_current) const {
    return OpenLoopStiffness(k, rest_current);
  }
};

/// An ideal current source: the windings carry the T(12)-(13) setpoint at every instant. The
/// drive runs no ticks and integrates no windings for it (kIdealSource).
struct IdealCurrent {
  static constexpr const char* kName = "ideal_current";
  static constexpr const char* kSummary =
      "the currents equal the `current_microstep` setpoint at every instant (no winding "
      "dynamics, no bus limit): the reference for what the loop should achieve.";
  static constexpr SpeedFeedback kDefaultSpeedFeedback = SpeedFeedback::kEstimate;
  /// How HoldingStiffness() is obtained (for `mjstepper info`).
  static constexpr const char* kStiffnessFormula = "Nr·Km·I, T(1)";
  static constexpr bool kCountsSlips = true;
  static constexpr bool kIdealSource = true;

  MicrostepSetpoint setpoint;

  struct State {};
  using Input = MechanicalSample;

  static std::vector<const AttributeSpec*> Attributes() {
    return {&kAttrHoldCurrent, &kAttrMicrosteps, &kAttrDamping, &kAttrDampingDetent};
  }
  static IdealCurrent FromAttributes(const AttributeSource& a, const MotorParams& motor,
                                     const DriveConstants&) {
    return {.setpoint = MicrostepSetpoint::FromAttributes(a, motor)};
  }

  /// Not called by the drive (no ticks); the voltage that would hold the setpoint at rest.
  TickOutput Tick(const DriveConstants& k, const Input& in, const PowerStage&, State*) const {
    const PhaseVector i = setpoint.Phase(k, in.command.theta);
    return {.bridge = {.voltage = k.resistance * i}, .current_ref = i};
  }
  PhaseVector Rest(const DriveConstants& k, const RestInput& in, State*) const {
    return setpoint.Phase(k, in.theta_cmd);
  }
  double HoldingStiffness(const DriveConstants& k, PhaseVector rest_current) const {
    return OpenLoopStiffness(k, rest_current);
  }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_CURRENT_MICROSTEP_H_
