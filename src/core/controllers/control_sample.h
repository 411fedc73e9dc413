// What a controller sees at one interrupt tick t_k (S-15): the command and the sampled sensors.
#ifndef MJSTEPPER_CORE_CONTROLLERS_CONTROL_SAMPLE_H_
#define MJSTEPPER_CORE_CONTROLLERS_CONTROL_SAMPLE_H_

#include "core/motor.h"

namespace mjstepper {

struct ControlSample {
  double theta_cmd = 0;  ///< θcmd(t_k), rad (rotor side)
  double omega_cmd = 0;  ///< dθcmd/dt, rad/s
  PhaseVector current;   ///< ia + j·ib sampled at t_k, A
  double theta = 0;      ///< rotor angle at t_k, rad (ideal sensor; encoders come with servo mode)
  double omega = 0;      ///< rotor speed, rad/s
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_CONTROL_SAMPLE_H_
