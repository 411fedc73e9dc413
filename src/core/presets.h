// Named parameter sets of SPEC §4. Every value can be overridden by the user.
#ifndef MJSTEPPER_CORE_PRESETS_H_
#define MJSTEPPER_CORE_PRESETS_H_

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/motor_params.h"

namespace mjstepper {

struct Preset {
  std::string name;
  std::string description;
  MotorParams motor;
  int encoder_counts = 0;    ///< counts per revolution of the paper's encoder (S-16)
};

/// `tsui2009`, `kim2016`, `bodson1993`; std::nullopt for any other name.
std::optional<Preset> FindPreset(std::string_view name);

/// The names FindPreset knows, in SPEC order.
std::vector<std::string> PresetNames();

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_PRESETS_H_
