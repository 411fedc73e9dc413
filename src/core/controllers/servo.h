// Servo mode with harmonic damping, Tsui 2009 §IV (eq. 18-19), SPEC §3; and its identification
// variant, Tsui §II.C (eq. 7-8).
//
// Field-oriented at the encoder's electrical angle:  ψ = Nr·θfb,  id* = 0              T(18)
// Position loop, every `position_every` ticks (4 kHz at a 20 kHz interrupt):
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

#include "core/controllers/control_sample.h"
#include "core/controllers/dq_current_loop.h"
#include "core/controllers/harmonic_compensation.h"

namespace mjstepper {

struct ServoState {
  double position_integral = 0;  ///< ∫θerr dt, rad·s
  double iq_cmd = 0;             ///< A, held between position updates
};

struct ServoController {
  int rotor_teeth = 50;
  double torque_constant = 0.3;     ///< Km the drive assumes, N·m/A
  double kp = 1.0;                  ///< N·m/rad
  double ki = 10.0;                 ///< N·m/(rad·s)
  double kv = 0.01;                 ///< N·m·s/rad
  double friction = 0.029;          ///< Fs the drive compensates, N·m
  double position_period = 250e-6;  ///< Tp, s
  bool identification = false;      ///< T(7)-(8): position loop off
  HarmonicCompensation damping;
  DqCurrentLoop loop;

  BridgeOutput Update(const ControlSample& in, const PowerStage& stage, PhaseVector* integral_dq,
                      ServoState* state) const;
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_SERVO_H_
