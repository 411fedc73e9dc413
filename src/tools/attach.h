// `mjstepper attach`: steppers onto any robot (issue 29, item 2). Takes an MJCF or URDF robot
// (MuJoCo's own parser reads both) and, for each named joint, a stepper spec: the motor preset,
// the driver chip or drive, the gear ratio and any other attribute of the plugin (currents,
// microsteps, hold current, efficiency, ...). Writes an MJCF with, through MjSpec (MuJoCo's own
// model editing, no text edits):
//   - the plugin declared, and on each named joint a stepper actuator (named after the joint)
//     with its <config>s, its gear, and the motor's rotor inertia as the actuator's armature
//     (MuJoCo reflects it through gear²);
//   - the integrator implicitfast and the timestep the rule recommends (core/timestep_rule.h: the
//     largest that resolves every mode a stepper takes part in, rounded down to 3 digits);
//   - a keyframe "start" at the robot's qpos0, where the drives start at rest.
// Errors name the joint and the fix (an unknown joint lists the robot's hinge and slide joints; a
// bad attribute is the plugin's own message, which names the attribute and its value).
#ifndef MJSTEPPER_TOOLS_ATTACH_H_
#define MJSTEPPER_TOOLS_ATTACH_H_

#include <map>
#include <string>
#include <vector>

namespace mjstepper::tools {

struct AttachStepper {
  std::string joint;                          ///< the robot's hinge or slide joint
  double gear = 1;                            ///< rotor angle / joint angle
  std::map<std::string, std::string> config;  ///< the plugin's attributes (motor, driver, ...)
};

struct AttachOptions {
  std::string robot;                    ///< MJCF or URDF path
  std::vector<AttachStepper> steppers;  ///< one per joint
  std::string out;                      ///< the MJCF written (whole, OutputFile)
  /// Where the robot's meshes are, when its file names do not say (a URDF's package:// URIs): each
  /// mesh is then its file's base name in this folder. Empty: as the robot says.
  std::string meshdir;
};

struct AttachResult {
  std::string out;                  ///< the file written
  double timestep = 0;              ///< s, the rule's recommendation written into it
  std::vector<std::string> joints;  ///< the joints given steppers, in the order asked
};

/// Parses one --stepper value, "JOINT:key=value,key=value,..." (gear=N sets the gear; every other
/// key is a plugin attribute). Throws std::invalid_argument naming the value and what is wrong.
AttachStepper ParseAttachStepper(const std::string& text);

/// Throws std::invalid_argument / std::runtime_error with a message that names the joint and the
/// fix. The output is written whole or not at all.
AttachResult Attach(const AttachOptions& options);

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_ATTACH_H_
