// Open-loop voltage microstepping, Kim 2016 eq. (5), SPEC §3.
//   va = Vmax·cos(Nr·θd),   vb = Vmax·sin(Nr·θd)                                  K(5)
// No current feedback: at rest the current settles to Vmax/R along the commanded electrical angle;
// when turning, the back-EMF and L cut and delay it (the motor's own R/L filter).
#ifndef MJSTEPPER_CORE_CONTROLLERS_VOLTAGE_MICROSTEP_H_
#define MJSTEPPER_CORE_CONTROLLERS_VOLTAGE_MICROSTEP_H_

#include "core/controllers/control_sample.h"
#include "core/power_stage.h"

namespace mjstepper {

struct VoltageMicrostepController {
  int rotor_teeth = 50;           ///< Nr
  double voltage_amplitude = 24;  ///< Vmax, V

  /// The stage voltage for the tick; stateless.
  BridgeOutput Update(const ControlSample& in, const PowerStage& stage) const {
    return stage.Apply(voltage_amplitude * UnitPhasor(rotor_teeth * in.theta_cmd));  // K(5)
  }

  /// Phase currents of the drive at rest, aligned with the command: Vmax/R·e^{jNrθcmd}.
  PhaseVector RestCurrent(double theta_cmd, double resistance) const {
    return voltage_amplitude / resistance * UnitPhasor(rotor_teeth * theta_cmd);
  }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_VOLTAGE_MICROSTEP_H_
