// What a controller sees at one interrupt tick t_k (S-15): the command and the sampled sensors.
#ifndef MJSTEPPER_CORE_CONTROLLERS_CONTROL_SAMPLE_H_
#define MJSTEPPER_CORE_CONTROLLERS_CONTROL_SAMPLE_H_

#include "core/motor.h"

namespace mjstepper {

struct ControlSample {
  double theta_cmd = 0;        ///< θcmd(t_k), rad (rotor side)
  double omega_cmd = 0;        ///< dθcmd/dt, rad/s
  PhaseVector current;         ///< ia + j·ib sampled at t_k, A (ideal current sensors)
  double theta_fb = 0;         ///< encoder angle θmeas(t_k), rad (S-16)
  double omega_fb = 0;         ///< velocity estimate, rad/s (S-17)
  bool position_tick = false;  ///< this tick also runs the position loop (servo modes)
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_CONTROL_SAMPLE_H_
