// Servo mode with harmonic damping, Tsui 2009 §IV (eq. 18-19), SPEC §3; and its identification
// variant, Tsui §II.C (eq. 7-8).
//
// Field-oriented at the encoder's electrical angle:  ψ = Nr·θfb,  id* = 0              T(18)
// Position loop, every `position_period` (4 kHz at a 20 kHz interrupt):
//   θerr = θcmd − θfb,   ωerr = ωcmd − ωfb,   I[n] = I[n−1] + θerr·Tp
//   iq* = (1/Km)·[Kv·ωerr + Kp·θerr + Ki·I + Σh Kdh·sin(h·Nr·θfb + φh) + Fs·sgn(ωcmd)]  T(19)
// held between position updates; the PI current loop of T(9)-(11) runs every tick.
// Identification (position loop off): iq* = (1/Km)·[Σh Kdh·sin(h·Nr·θfb + φh) + Fs·sgn(ωfb)],
// updated every tick, while something else turns the shaft                             T(7)-(8)
// SI gains (SPEC §3; the paper's are in undisclosed DSP units): Kp = 1.0 N·m/rad,
// Ki = 10 N·m/(rad·s), Kv = 0.01 N·m·s/rad. On the Tsui rotor (J = 0.36e-4 kg·m², B = 0.001) with
// the 32 Hz velocity filter and 175 µs of sampling delay the loop crosses over at 41 Hz with 26° of
// phase margin and 20.7 dB of gain margin; closed-loop bandwidth 67 Hz (docs/servo.md).
#ifndef MJSTEPPER_CORE_CONTROLLERS_SERVO_H_
#define MJSTEPPER_CORE_CONTROLLERS_SERVO_H_

#include "core/controllers/controller.h"
#include "core/controllers/current_microstep.h"
#include "core/controllers/dq_current_loop.h"
#include "core/controllers/harmonic_compensation.h"

namespace mjstepper {

inline constexpr AttributeSpec kAttrPositionPeriod{
    "position_period", "real", "250e-6", "s",
    "Servo position-loop period (4 kHz); a whole multiple of `isr_period`."};
inline constexpr AttributeSpec kAttrServoKp{"servo_kp", "real", "1.0", "N·m/rad",
                                            "Servo position gain Kp, T(19) (SI set of SPEC §3)."};
inline constexpr AttributeSpec kAttrServoKi{"servo_ki", "real", "10", "N·m/(rad·s)",
                                            "Servo integral gain Ki, T(19)."};
inline constexpr AttributeSpec kAttrServoKv{"servo_kv", "real", "0.01", "N·m·s/rad",
                                            "Servo velocity gain Kv, T(19)."};
inline constexpr AttributeSpec kAttrFrictionCompensation{
    "friction_compensation", "real", "preset Fs (0.029)", "N·m",
    "Fs the servo adds as Fs·sgn(ωcmd) (T(19)) and identification as Fs·sgn(ωest) (T(8))."};

/// sgn(v) of T(8) and T(19): −1, 0 or 1.
inline double Sign(double v) { return (v > 0) - (v < 0); }

struct Servo {
  static constexpr const char* kName = "servo";
  static constexpr const char* kSummary =
      "Tsui's servo with damping, T(18)-(19): encoder feedback, position loop every "
      "`position_period`, current loop every interrupt.";
  static constexpr SpeedFeedback kDefaultSpeedFeedback = SpeedFeedback::kEstimate;
  /// How HoldingStiffness() is obtained (for `mjstepper info`).
  static constexpr const char* kStiffnessFormula = "Kp, the position loop (T(19))";
  static constexpr bool kCountsSlips = false;

  double kp = 1.0;                  ///< N·m/rad
  double ki = 10.0;                 ///< N·m/(rad·s)
  double kv = 0.01;                 ///< N·m·s/rad
  double friction = 0.029;          ///< Fs the drive compensates, N·m
  double position_period = 250e-6;  ///< Tp, s
  long ticks_per_position = 5;      ///< Tp/T
  HarmonicCompensation damping;
  DqCurrentLoop loop;

  struct State {
    double integral_d = 0;         ///< V, PI integrator, d axis
    double integral_q = 0;         ///< V, q axis
    double position_integral = 0;  ///< ∫θerr dt, rad·s
    double iq_cmd = 0;             ///< A, held between position updates
    /// A, the iq* before the last update: the averaged form applies it until the update's
    /// voltage reaches the winding, D after its tick (unused when switching).
    double iq_previous = 0;
  };
  using Input = Sample;

  static std::vector<const AttributeSpec*> Attributes();
  static Servo FromAttributes(const AttributeSource& a, const MotorParams& motor,
                              const DriveConstants& k);
  TickOutput Tick(const DriveConstants& k, const Input& in, const PowerStage& stage,
                  State* s) const;
  /// The position update of T(19), at the ticks k with k % ticks_per_position = 0: sets the
  /// held iq*.
  void Position(const DriveConstants& k, const Input& in, State* s) const;
  /// For the averaged form (averaged_current_loop.h): the iq* held between updates (A), beside
  /// a setpoint that is otherwise empty (T(18): id* = 0; the damping is in iq*).
  double HeldIq(const DriveConstants&, const Input&, const State& s) const { return s.iq_cmd; }
  const MicrostepSetpoint& LoopSetpoint() const {
    static const MicrostepSetpoint kNone{.hold_current = 0, .damping = {}, .microsteps = 0};
    return kNone;
  }
  /// At rest on its command the servo asks for no torque.
  PhaseVector Rest(const DriveConstants&, const RestInput&, State*) const { return 0; }
  /// The position loop's spring, Kp (T(19)).
  double HoldingStiffness(const DriveConstants&, PhaseVector) const { return kp; }
};

struct Identification {
  static constexpr const char* kName = "identification";
  static constexpr const char* kSummary =
      "T(7)-(8), the servo with the position loop off (compensation only) while something else "
      "turns the shaft.";
  static constexpr SpeedFeedback kDefaultSpeedFeedback = SpeedFeedback::kEstimate;
  /// How HoldingStiffness() is obtained (for `mjstepper info`).
  static constexpr const char* kStiffnessFormula = "nothing holds the rotor in identification mode";
  static constexpr bool kCountsSlips = false;

  double friction = 0.029;  ///< Fs the drive compensates, N·m
  /// T(8)'s harmonics as a frame setpoint: id* = 0, iq* = Σh Kdh·sin(h·Nr·θfb + φh)/Km.
  MicrostepSetpoint setpoint{.hold_current = 0, .damping = {}, .microsteps = 0};
  DqCurrentLoop loop;

  struct State {
    double integral_d = 0;  ///< V
    double integral_q = 0;  ///< V
  };
  using Input = Sample;

  static std::vector<const AttributeSpec*> Attributes();
  static Identification FromAttributes(const AttributeSource& a, const MotorParams& motor,
                                       const DriveConstants& k);
  TickOutput Tick(const DriveConstants& k, const Input& in, const PowerStage& stage,
                  State* s) const;
  /// For the averaged form (averaged_current_loop.h): T(8)'s friction share of iq*, Fs·sgn(ωfb)/Km
  /// (A), beside the setpoint's harmonics.
  double HeldIq(const DriveConstants& k, const Input& in, const State&) const {
    return friction * Sign(in.feedback.omega) / k.torque_constant;
  }
  const MicrostepSetpoint& LoopSetpoint() const { return setpoint; }
  PhaseVector Rest(const DriveConstants&, const RestInput&, State*) const { return 0; }
  /// No position loop: nothing holds the rotor.
  double HoldingStiffness(const DriveConstants&, PhaseVector) const { return 0; }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_SERVO_H_
