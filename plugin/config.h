// The MJCF <config> attributes of mjstepper.stepper, parsed once into a DriveConfig.
// No MuJoCo here: the parser reads attribute values through a callback, so it is unit-testable.
// The attribute table (AttributeTable) is the drive's own attributes, declared in config.cc, plus
// each controller's, declared in its controller file; the parser, the names MuJoCo is told and the
// README's table (AttributeTableMarkdown, checked by a test) all come from it.
#ifndef MJSTEPPER_PLUGIN_CONFIG_H_
#define MJSTEPPER_PLUGIN_CONFIG_H_

#include <string>
#include <variant>
#include <vector>

#include "core/attributes.h"
#include "core/coupling.h"
#include "core/drive.h"

namespace mjstepper::plugin {

/// What the plugin adds to a drive's configuration: presentation, and the coupling to MuJoCo.
struct StepperConfig {
  DriveConfig drive;
  bool gauge = true;  ///< draw the load-angle gauge on the rotor (visualize callback)
  Coupling coupling = Coupling::kConsistent;  ///< the torque handed to MuJoCo (core/coupling.h)
};

/// Every attribute, each once: the drive's own, then the controllers' in registry order.
const std::vector<const AttributeSpec*>& AttributeTable();

/// Every attribute name, in AttributeTable's order (what MuJoCo is told at registration).
const std::vector<const char*>& AttributeNames();

/// The parsed configuration, or a message "name = "value": rule (unit)".
std::variant<DriveConfig, std::string> ParseConfig(const AttributeReader& read);

/// ParseConfig plus the plugin's own presentation attributes.
std::variant<StepperConfig, std::string> ParseStepperConfig(const AttributeReader& read);

/// The README's attribute table (Markdown), made from AttributeTable.
std::string AttributeTableMarkdown();

/// The README's list of drives (Markdown), made from the controller registry.
std::string DriveListMarkdown();

/// The README's table of motor presets (Markdown), made from core/presets.cc.
std::string PresetTableMarkdown();

}  // namespace mjstepper::plugin

#endif  // MJSTEPPER_PLUGIN_CONFIG_H_
