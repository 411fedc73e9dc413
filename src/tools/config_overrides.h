// Per-run changes to a stepper's <config>, e.g. "shaft.damping=4 2 1", applied to the MJCF text
// before MuJoCo parses it (tinyxml2), so that one model can be run or swept with any drive and any
// damping selection.
#ifndef MJSTEPPER_TOOLS_CONFIG_OVERRIDES_H_
#define MJSTEPPER_TOOLS_CONFIG_OVERRIDES_H_

#include <string>
#include <vector>

namespace mjstepper::tools {

struct ConfigOverride {
  std::string actuator;  ///< actuator name
  std::string key;       ///< plugin attribute
  std::string value;
};

/// Parses "ACTUATOR.KEY=VALUE"; throws std::invalid_argument quoting the text.
ConfigOverride ParseOverride(const std::string& text);

/// The model file's text with each override set on the actuator's own <plugin> config, or on the
/// named <instance> it uses (which then changes for every actuator sharing it). Throws
/// std::runtime_error naming what was not found.
std::string ApplyOverrides(const std::string& path, const std::vector<ConfigOverride>& overrides);

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_CONFIG_OVERRIDES_H_
