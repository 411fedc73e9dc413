// A declared carriage (pulley_teeth, lead: core/transmission.h) against the model: what the plugin
// checks at load and what the tools read for the log's carriage columns (issue 32, item 3).
#ifndef MJSTEPPER_PLUGIN_CARRIAGE_H_
#define MJSTEPPER_PLUGIN_CARRIAGE_H_

#include <mujoco/mujoco.h>

#include <string>

#include "core/transmission.h"

namespace mjstepper::plugin {

/// A declared pulley's pitch radius must match the belt's coefficient within this fraction.
inline constexpr double kCarriageTolerance = 1e-3;

/// A belt written into the model: a fixed tendon that winds `hinge` with a slide joint in it
/// (models/belt_axis.xml: x − r·θ).
struct Belt {
  int tendon = -1;  ///< -1: none
  double coef = 0;  ///< the tendon's coefficient on the hinge, m per rad
};

/// The first fixed tendon that winds joint `hinge` with a slide joint in it.
Belt BeltOf(const mjModel* m, int hinge);

/// Why actuator a's declared carriage does not fit its transmission, "" when it does (or none is
/// declared): it must turn a hinge joint, and a belt that hinge winds must have the pulley's pitch
/// radius as its coefficient, within kCarriageTolerance.
std::string CarriageMismatch(const mjModel* m, int a, const Transmission& t);

}  // namespace mjstepper::plugin

#endif  // MJSTEPPER_PLUGIN_CARRIAGE_H_
