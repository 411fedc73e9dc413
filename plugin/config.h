// The MJCF <config> attributes of mjstepper.stepper, parsed once into a DriveConfig.
// No MuJoCo here: the parser reads attribute values through a callback, so it is unit-testable.
// Names, defaults and units are documented in plugin/README.md (a test checks every key is there).
#ifndef MJSTEPPER_PLUGIN_CONFIG_H_
#define MJSTEPPER_PLUGIN_CONFIG_H_

#include <functional>
#include <string>
#include <variant>
#include <vector>

#include "core/drive.h"

namespace mjstepper::plugin {

inline constexpr char kAttrMotor[] = "motor";                         // preset name
inline constexpr char kAttrDrive[] = "drive";                         // controller
inline constexpr char kAttrInput[] = "input";                         // position | velocity
inline constexpr char kAttrRotorTeeth[] = "rotor_teeth";              // Nr
inline constexpr char kAttrResistance[] = "resistance";               // Ω
inline constexpr char kAttrInductance[] = "inductance";               // H
inline constexpr char kAttrTorqueConstant[] = "torque_constant";      // N·m/A
inline constexpr char kAttrDetent[] = "detent";                       // "h Kdh φh; ..." or "none"
inline constexpr char kAttrBusVoltage[] = "bus_voltage";              // V
inline constexpr char kAttrVoltageAmplitude[] = "voltage_amplitude";  // V
inline constexpr char kAttrHoldCurrent[] = "hold_current";            // A
inline constexpr char kAttrKp[] = "kp";                               // V/A
inline constexpr char kAttrKi[] = "ki";                               // V/A per tick
inline constexpr char kAttrIsrPeriod[] = "isr_period";                // s
inline constexpr char kAttrComputeDelay[] = "compute_delay";          // s
inline constexpr char kAttrPowerStage[] = "power_stage";              // h_bridge | svpwm
inline constexpr char kAttrDamping[] = "damping";                     // none | all | "4 2 1"
inline constexpr char kAttrDampingDetent[] = "damping_detent";        // drive's estimates
inline constexpr char kAttrEncoderCounts[] = "encoder_counts";        // counts/rev
inline constexpr char kAttrVelocityCutoff[] = "velocity_cutoff";      // Hz
inline constexpr char kAttrPositionPeriod[] = "position_period";      // s
inline constexpr char kAttrServoKp[] = "servo_kp";                    // N·m/rad
inline constexpr char kAttrServoKi[] = "servo_ki";                    // N·m/(rad·s)
inline constexpr char kAttrServoKv[] = "servo_kv";                    // N·m·s/rad
inline constexpr char kAttrFrictionCompensation[] = "friction_compensation";  // N·m
inline constexpr char kAttrGauge[] = "gauge";                                 // on | off

/// What the plugin adds to a drive's configuration: presentation only.
struct StepperConfig {
  DriveConfig drive;
  bool gauge = true;  ///< draw the load-angle gauge on the rotor (visualize callback)
};

/// Every attribute, in the order of the README table.
const std::vector<const char*>& AttributeNames();

/// Returns the attribute's value, or nullptr / "" when the MJCF does not set it.
using AttributeReader = std::function<const char*(const char* name)>;

/// The parsed configuration, or a message "name = "value": rule (unit)".
std::variant<DriveConfig, std::string> ParseConfig(const AttributeReader& read);

/// ParseConfig plus the plugin's own presentation attributes.
std::variant<StepperConfig, std::string> ParseStepperConfig(const AttributeReader& read);

/// Strict number parsing: the whole string (surrounding blanks allowed) must be one finite number.
/// "48" and "4.8e1" pass; "", "48V", "nan", "inf", "4,8" fail.
bool ParseFiniteDouble(const std::string& text, double* value);

}  // namespace mjstepper::plugin

#endif  // MJSTEPPER_PLUGIN_CONFIG_H_
