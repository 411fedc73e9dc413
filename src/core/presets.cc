#include "core/presets.h"

#include <cmath>
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
  p.motor.rated_current = 3.0;      // A
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
  p.motor.load_torque = 0.1;    // N·m, Kim §5
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

// Catalogue motors (issue 17, item 4), each row as its datasheet prints it. Trinamic's QMot
// manuals (QSH4218 and QSH5718 families, ADI/Trinamic) are primary: every field is printed there,
// R at 20 °C, inertia in g·cm² (× 1e-7 kg·m²), detent torque in N·m. StepperOnline publishes no
// inertia or detent in the pages reachable here: its two 0.9° rows are secondary (R, L, T_H, I_r
// from the product pages as collected in klipper_tmc_autotune's motor_database.cfg; J from the
// stepper-simulator database built from the Voron community's sheets), detent unpublished (0).
struct CatalogueRow {
  const char* name;
  const char* description;
  Datasheet datasheet;
};
constexpr const char* kQsh4218 =
    "Trinamic QMot QSH4218 manual (NEMA 17 family), technical data table: primary";
constexpr const char* kQsh5718 =
    "Trinamic QMot QSH5718 manual (NEMA 23 family), technical data table: primary";
constexpr const char* kOmc =
    "StepperOnline product page (via klipper_tmc_autotune motor_database.cfg; J from "
    "stepper-simulator's database): secondary, detent not published";
const CatalogueRow kCatalogue[] = {
    {"qsh4218_35",
     "NEMA 17, 1.8°, 1.0 A, 0.27 N·m, 34 mm (Trinamic QSH4218-35-10-027)",
     {kQsh4218, 1.8, 1.0, 0.27, 5.3, 6.6e-3, 35e-7, 0.022}},
    {"qsh4218_41",
     "NEMA 17, 1.8°, 1.0 A, 0.35 N·m, 40 mm (Trinamic QSH4218-41-10-035)",
     {kQsh4218, 1.8, 1.0, 0.35, 4.5, 7.5e-3, 54e-7, 0.025}},
    {"qsh4218_51",
     "NEMA 17, 1.8°, 1.0 A, 0.49 N·m, 47 mm (Trinamic QSH4218-51-10-049)",
     {kQsh4218, 1.8, 1.0, 0.49, 5.0, 8.0e-3, 68e-7, 0.028}},
    {"qsh5718_51",
     "NEMA 23, 1.8°, 2.8 A, 1.01 N·m, 51 mm (Trinamic QSH5718-51-28-101)",
     {kQsh5718, 1.8, 2.8, 1.01, 0.83, 2.2e-3, 275e-7, 0.035}},
    {"qsh5718_76",
     "NEMA 23, 1.8°, 2.8 A, 1.89 N·m, 76 mm (Trinamic QSH5718-76-28-189)",
     {kQsh5718, 1.8, 2.8, 1.89, 1.13, 3.6e-3, 480e-7, 0.066}},
    {"17hm19_2004s",
     "NEMA 17, 0.9°, 2.0 A, 0.46 N·m, 48 mm (StepperOnline 17HM19-2004S)",
     {kOmc, 0.9, 2.0, 0.46, 1.45, 4.0e-3, 82e-7, 0.0}},
    {"17hs19_2004s1",
     "NEMA 17, 1.8°, 2.0 A, 0.59 N·m, 48 mm (StepperOnline 17HS19-2004S1)",
     {kOmc, 1.8, 2.0, 0.59, 1.4, 3.0e-3, 82e-7, 0.0}},
};

}  // namespace

MotorParams FromDatasheet(const Datasheet& d) {
  MotorParams m;
  m.rotor_teeth = static_cast<int>(std::lround(360.0 / (4 * d.step_angle)));  // S-1
  m.resistance = d.resistance;
  m.inductance = d.inductance;
  m.torque_constant = d.holding_torque / (std::sqrt(2.0) * d.rated_current);  // SPEC §1
  if (d.detent_torque > 0) m.detent = {{.order = 4, .amplitude = d.detent_torque, .phase = 0}};
  m.rotor_inertia = d.rotor_inertia;
  m.viscous_damping = 1e-4;  // N·m·s/rad: not on datasheets (FromDatasheet)
  m.static_friction = 0.0;
  m.rated_current = d.rated_current;
  return m;
}

std::optional<Preset> FindPreset(std::string_view name) {
  if (name == "tsui2009") return Tsui2009();
  if (name == "kim2016") return Kim2016();
  if (name == "bodson1993") return Bodson1993();
  for (const CatalogueRow& row : kCatalogue) {
    if (name == row.name) {
      return Preset{.name = row.name,
                    .description = row.description,
                    .motor = FromDatasheet(row.datasheet),
                    .datasheet = row.datasheet};
    }
  }
  return std::nullopt;
}

std::vector<std::string> PresetNames() {
  std::vector<std::string> names = {"tsui2009", "kim2016", "bodson1993"};
  for (const CatalogueRow& row : kCatalogue) names.emplace_back(row.name);
  return names;
}

}  // namespace mjstepper
