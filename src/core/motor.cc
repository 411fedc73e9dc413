#include "core/motor.h"

#include <cmath>

namespace mjstepper {

double DetentTorque(const MotorParams& p, double theta) {
  const double x = ElectricalAngle(p, theta);  // rad, S-1
  double torque = 0.0;                         // N·m
  for (const DetentHarmonic& h : p.detent) {
    torque -= h.amplitude * std::sin(h.order * x + h.phase);  // S-5
  }
  return torque;
}

}  // namespace mjstepper
