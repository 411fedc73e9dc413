// Writes the Python package's tables (python/mjstepper reads them as mjstepper/_tables.py) from
// the one signal table (core/signals.cc), the attribute table (plugin/config.cc AttributeTable)
// and the presets (core/presets.cc), at build time:
//   mjstepper_package_tables MUJOCO_VERSION > _tables.py
#include <fmt/format.h>

#include <string>

#include "config.h"
#include "core/presets.h"
#include "core/signals.h"
#include "options.h"

namespace {

// A Python string literal.
std::string Quote(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

}  // namespace

int main(int argc, char** argv) {
  using mjstepper::MotorParams;
  if (argc != 2) {
    fmt::print(stderr, "usage: mjstepper_package_tables MUJOCO_VERSION\n");
    return 2;
  }
  fmt::print("# Generated at build time by src/tools/package_tables.cc; do not edit.\n");
  fmt::print("MUJOCO_VERSION = {}\n\n", Quote(argv[1]));
  fmt::print("# (name, unit, meaning) of each value of a signal sensor, in sensordata order.\n");
  fmt::print("SIGNALS = (\n");
  for (const mjstepper::SignalInfo& s : mjstepper::SignalTable()) {
    fmt::print("    ({}, {}, {}),\n", Quote(s.name), Quote(s.unit), Quote(s.meaning));
  }
  fmt::print(")\n\n");
  fmt::print("# (name, type, default, unit, meaning) of each plugin attribute (MJCF <config>),\n");
  fmt::print("# in the plugin's order; type is real, integer, name or list.\n");
  fmt::print("ATTRIBUTES = (\n");
  for (const mjstepper::AttributeSpec* a : mjstepper::plugin::AttributeTable()) {
    fmt::print("    ({}, {}, {}, {}, {}),\n", Quote(a->name), Quote(a->type),
               Quote(a->default_text), Quote(a->unit), Quote(a->meaning));
  }
  fmt::print(")\n\n");
  fmt::print("# (least, most, unit) of each bounded option of the mjstepper command\n");
  fmt::print("# (src/tools/options.cc); the Python package's arguments share them.\n");
  fmt::print("OPTION_RANGES = {{\n");
  for (const mjstepper::tools::OptionRange& r : mjstepper::tools::OptionRanges()) {
    fmt::print("    {}: ({:.17g}, {:.17g}, {}),\n", Quote(r.name), r.lo, r.hi, Quote(r.unit));
  }
  fmt::print("}}\n");
  fmt::print("MIN_MEASURED_STEPS = {}\n\n", mjstepper::tools::kMinMeasuredSteps);
  fmt::print("# Each preset's parameters as (value, unit).\n");
  fmt::print("PRESETS = {{\n");
  for (const std::string& name : mjstepper::PresetNames()) {
    const mjstepper::Preset preset = *mjstepper::FindPreset(name);
    const MotorParams& m = preset.motor;
    fmt::print("    {}: {{\n", Quote(name));
    fmt::print("        \"description\": ({}, \"\"),\n", Quote(preset.description));
    const std::pair<const char*, std::pair<double, const char*>> values[] = {
        {"rotor_teeth", {static_cast<double>(m.rotor_teeth), ""}},
        {"resistance", {m.resistance, "Ω"}},
        {"inductance", {m.inductance, "H"}},
        {"torque_constant", {m.torque_constant, "N·m/A"}},
        {"rotor_inertia", {m.rotor_inertia, "kg·m²"}},
        {"viscous_damping", {m.viscous_damping, "N·m·s/rad"}},
        {"static_friction", {m.static_friction, "N·m"}},
        {"rated_current", {m.rated_current, "A"}},
        {"load_torque", {m.load_torque, "N·m"}},
        {"encoder_counts", {static_cast<double>(preset.encoder_counts), "counts/rev"}},
    };
    for (const auto& [key, value] : values) {
      fmt::print("        {}: ({:.17g}, {}),\n", Quote(key), value.first, Quote(value.second));
    }
    if (preset.thermal) {  // the heat network (SPEC §8), under the attributes' names
      const mjstepper::ThermalParams& t = *preset.thermal;
      const std::pair<const char*, std::pair<double, const char*>> heat[] = {
          {"thermal_resistance_winding", {t.resistance_winding, "K/W"}},
          {"thermal_resistance_housing", {t.resistance_housing, "K/W"}},
          {"heat_capacity_winding", {t.capacity_winding, "J/K"}},
          {"heat_capacity_housing", {t.capacity_housing, "J/K"}},
      };
      for (const auto& [key, value] : heat) {
        fmt::print("        {}: ({:.17g}, {}),\n", Quote(key), value.first, Quote(value.second));
      }
    }
    fmt::print("        \"detent\": (({}), \"order, N·m, rad\"),\n", [&] {
      std::string list;
      for (const mjstepper::DetentHarmonic& h : m.detent) {
        list += fmt::format("({}, {:.17g}, {:.17g}), ", h.order, h.amplitude, h.phase);
      }
      return list;
    }());
    fmt::print("    }},\n");
  }
  fmt::print("}}\n");
  return 0;
}
