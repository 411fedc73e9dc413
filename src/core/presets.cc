#include "core/presets.h"

#include <numbers>

namespace mjstepper {
namespace {

// SPEC §4, row `tsui2009`: hybrid 1.8°, 3 A, 1.27 N·m; Tsui 2009 Table I and §II.
Preset Tsui2009() {
  Preset p;
  p.name = "tsui2009";
  p.description = "hybrid 1.8 deg, 3 A, 1.27 N·m (Tsui, Cheung, Yuen 2009)";
  p.motor.rotor_teeth = 50;
  p.motor.resistance = 0.9;       // Ω
  p.motor.inductance = 2.2e-3;    // H
  p.motor.torque_constant = 0.3;  // N·m/A
  p.motor.detent = {{.order = 4, .amplitude = 0.006, .phase = 0.0},
                    {.order = 2, .amplitude = 0.014, .phase = std::numbers::pi},
                    {.order = 1, .amplitude = 0.011, .phase = std::numbers::pi / 2}};
  p.motor.rotor_inertia = 0.36e-4;  // kg·m²
  p.motor.viscous_damping = 1e-3;   // N·m·s/rad
  p.motor.static_friction = 0.029;  // N·m
  p.motor.rated_current = 3.0;  // A
  p.encoder_counts = 4000;
  return p;
}

// SPEC §4, row `kim2016`: PK268-02B class, reconstructed (Kim's Table 1 is lost); no detent.
Preset Kim2016() {
  Preset p;
  p.name = "kim2016";
  p.description =
      "PM stepper, PK268-02B class, 2 A, about 1.35 N·m (Kim et al. 2016, reconstructed)";
  p.motor.rotor_teeth = 50;
  p.motor.resistance = 2.3;
  p.motor.inductance = 9.0e-3;
  p.motor.torque_constant = 0.48;
  p.motor.rotor_inertia = 4.8e-5;
  p.motor.viscous_damping = 1e-3;
  p.motor.rated_current = 2.0;  // A
  p.motor.load_torque = 0.1;  // N·m, Kim §5
  p.encoder_counts = 32000;
  return p;
}

// SPEC §4, row `bodson1993`: classic PM stepper.
Preset Bodson1993() {
  Preset p;
  p.name = "bodson1993";
  p.description = "classic PM stepper (Bodson et al. 1993)";
  p.motor.rotor_teeth = 50;
  p.motor.resistance = 0.55;
  p.motor.inductance = 1.5e-3;
  p.motor.torque_constant = 0.19;
  p.motor.rotor_inertia = 4.5e-5;
  p.motor.viscous_damping = 8e-4;
  p.motor.rated_current = 2.0;  // A, reconstructed (SPEC §4)
  return p;
}

}  // namespace

std::optional<Preset> FindPreset(std::string_view name) {
  if (name == "tsui2009") return Tsui2009();
  if (name == "kim2016") return Kim2016();
  if (name == "bodson1993") return Bodson1993();
  return std::nullopt;
}

std::vector<std::string> PresetNames() { return {"tsui2009", "kim2016", "bodson1993"}; }

}  // namespace mjstepper
