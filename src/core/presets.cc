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
//
// Heat (SPEC §8). Trinamic's manuals print a winding and a surface thermal time constant (QSH4218:
// 18/20, 20/22, 22/25 min; QSH5718-51: 22/30, -76: 30/39 min), the mass, insulation class B ("max.
// coil temperature of 130 °C", §6.2) and, for the QSH5718 family, "Temp. Rise (rated current, 2
// phase on) +80 max" (°C). No catalogue sheet here prints a thermal resistance or capacity: the
// network (ThermalSheet) is fitted to those numbers with two estimates, the same for every motor:
//   - the rise at the rated current is the +80 K of the class-B sheets (QSH5718's, and the common
//     "temperature rise 80 °C max, rated current, 2 phase on" of hybrid-stepper sheets): an upper
//     bound taken as the value, for the QSH4218 and StepperOnline rows an estimate;
//   - copper is 12 % of the motor's mass (C_w); the fit is insensitive to it (8 % or 20 % moves
//     R_wh by at most 6 %, C_h by at most 4 %).
// The fitted housing capacities are 0.8-1.2 kJ/(kg·K) of the motor's non-copper mass, more than
// steel's 0.46 or aluminium's 0.9: the manuals' time constants are long for the motors' masses
// (measured on a mounting plate, perhaps, which the housing node then includes). The
// StepperOnline rows take the time constants of the QSH4218-51 (the same 47-48 mm NEMA 17 body)
// and a mass of 0.40 kg (estimates). The rise is taken with R(T) (the power at 105 °C is 1.33
// times the one at 20 °C) from an ambient of 25 °C. Totals R_wh + R_ha: 5.2-6.7 K/W for the NEMA 17
// rows, 3.4-4.6 K/W for the NEMA 23 ones (tests/core/thermal_test.cc checks each row against its
// sheet).
struct CatalogueRow {
  const char* name;
  const char* description;
  Datasheet datasheet;
  ThermalParams thermal;  // R_wh K/W, R_ha K/W, C_w J/K, C_h J/K, fitted to `sheet`
  ThermalSheet sheet;
};
constexpr const char* kQsh4218 =
    "Trinamic QMot QSH4218 manual (NEMA 17 family), technical data table: primary";
constexpr const char* kQsh5718 =
    "Trinamic QMot QSH5718 manual (NEMA 23 family), technical data table: primary";
constexpr const char* kOmc =
    "StepperOnline product page (via klipper_tmc_autotune motor_database.cfg; J from "
    "stepper-simulator's database): secondary, detent not published";
constexpr const char* kQsh4218Heat =
    "Trinamic QMot QSH4218 manual V1.10, table 2.1 (time constants, mass; primary); +80 K at the "
    "rated current: estimate (class-B sheets' figure)";
constexpr const char* kQsh5718Heat =
    "Trinamic QMot QSH5718 manual V2.6, table 2.1 (time constants, mass, +80 K max rise; "
    "primary)";
constexpr const char* kOmcHeat =
    "estimate: QSH4218-51's time constants (same 47-48 mm body), 0.40 kg, +80 K at the rated "
    "current (class-B sheets' figure)";
// PAROL6's motors (issue 29; its BOM, BOM/PAROL6_BOM_4_4_2026.pdf, names the StepperOnline
// models; firmware constants.h's currents put them on the joints, SPEC §12): T_H, I_r, R, L from
// Source Robotics' STEPFOC docs (tested_motors.md) and klipper_tmc_autotune's motor_database.cfg,
// which agree; J from stepper-simulator's database only (unconfirmed: it swaps 17HS08's R and L);
// detent unpublished (0). Heat: QSH4218's time constants for the nearest body length (40 mm:
// QSH4218-41's 20/22 min) or extended by 2 min per body step beyond the family (60 mm: 24/28; 20
// mm: 16/18: estimates), STEPFOC's masses, the class-B +80 K at the rated current (estimate).
constexpr const char* kParol6 =
    "StepperOnline (PAROL6's BOM): T_H, I_r, R, L from Source Robotics' STEPFOC tested_motors and "
    "klipper_tmc_autotune motor_database.cfg (agree); J from stepper-simulator's database "
    "(unconfirmed); detent not published";
constexpr const char* kParol6Heat =
    "estimate: QSH4218 time constants by body length (40 mm as QSH4218-41; 20 and 60 mm "
    "extended by 2 min a step), STEPFOC's mass, +80 K at the rated current (class-B sheets' "
    "figure)";

constexpr double kMinute = 60.0;  // s
const CatalogueRow kCatalogue[] = {
    {"qsh4218_35",
     "NEMA 17, 1.8°, 1.0 A, 0.27 N·m, 34 mm (Trinamic QSH4218-35-10-027)",
     {kQsh4218, 1.8, 1.0, 0.27, 5.3, 6.6e-3, 35e-7, 0.022},
     {0.565, 5.09, 10.2, 224},
     {kQsh4218Heat, 18 * kMinute, 20 * kMinute, 80, 0.22}},
    {"qsh4218_41",
     "NEMA 17, 1.8°, 1.0 A, 0.35 N·m, 40 mm (Trinamic QSH4218-41-10-035)",
     {kQsh4218, 1.8, 1.0, 0.35, 4.5, 7.5e-3, 54e-7, 0.025},
     {0.619, 6.04, 12.9, 204},
     {kQsh4218Heat, 20 * kMinute, 22 * kMinute, 80, 0.28}},
    {"qsh4218_51",
     "NEMA 17, 1.8°, 1.0 A, 0.49 N·m, 47 mm (Trinamic QSH4218-51-10-049)",
     {kQsh4218, 1.8, 1.0, 0.49, 5.0, 8.0e-3, 68e-7, 0.028},
     {0.725, 5.27, 16.2, 266},
     {kQsh4218Heat, 22 * kMinute, 25 * kMinute, 80, 0.35}},
    {"qsh5718_51",
     "NEMA 23, 1.8°, 2.8 A, 1.01 N·m, 51 mm (Trinamic QSH5718-51-28-101)",
     {kQsh5718, 1.8, 2.8, 1.01, 0.83, 2.2e-3, 275e-7, 0.035},
     {1.17, 3.44, 30.0, 483},
     {kQsh5718Heat, 22 * kMinute, 30 * kMinute, 80, 0.65}},
    {"qsh5718_76",
     "NEMA 23, 1.8°, 2.8 A, 1.89 N·m, 76 mm (Trinamic QSH5718-76-28-189)",
     {kQsh5718, 1.8, 2.8, 1.89, 1.13, 3.6e-3, 480e-7, 0.066},
     {0.746, 2.64, 46.2, 828},
     {kQsh5718Heat, 30 * kMinute, 39 * kMinute, 80, 1.0}},
    {"17hm19_2004s",
     "NEMA 17, 0.9°, 2.0 A, 0.46 N·m, 48 mm (StepperOnline 17HM19-2004S)",
     {kOmc, 0.9, 2.0, 0.46, 1.45, 4.0e-3, 82e-7, 0.0},
     {0.624, 4.55, 18.5, 309},
     {kOmcHeat, 22 * kMinute, 25 * kMinute, 80, 0.40}},
    {"17hs19_2004s1",
     "NEMA 17, 1.8°, 2.0 A, 0.59 N·m, 48 mm (StepperOnline 17HS19-2004S1)",
     {kOmc, 1.8, 2.0, 0.59, 1.4, 3.0e-3, 82e-7, 0.0},
     {0.648, 4.71, 18.5, 298},
     {kOmcHeat, 22 * kMinute, 25 * kMinute, 80, 0.40}},
    {"17hs24_2104s",
     "NEMA 17, 1.8°, 2.1 A, 0.65 N·m, 60 mm (StepperOnline 17HS24-2104S; PAROL6 J1, J2)",
     {kParol6, 1.8, 2.1, 0.65, 1.6, 3.0e-3, 148e-7, 0.0},
     {0.600, 3.65, 23.1, 433},
     {kParol6Heat, 24 * kMinute, 28 * kMinute, 80, 0.50}},
    {"17hs16_2004s1",
     "NEMA 17, 1.8°, 2.0 A, 0.45 N·m, 40 mm (StepperOnline 17HS16-2004S1; PAROL6 J3-J5)",
     {kParol6, 1.8, 2.0, 0.45, 1.1, 2.6e-3, 54e-7, 0.0},
     {0.639, 6.18, 14.3, 198},
     {kParol6Heat, 20 * kMinute, 22 * kMinute, 80, 0.31}},
    {"17hs08_1004s",
     "NEMA 17, 1.8°, 1.0 A, 0.16 N·m, 20 mm (StepperOnline 17HS08-1004S; PAROL6 J6)",
     {kParol6, 1.8, 1.0, 0.16, 3.7, 4.5e-3, 22e-7, 0.0},
     {0.895, 7.21, 6.47, 143},
     {kParol6Heat, 16 * kMinute, 18 * kMinute, 80, 0.14}},
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
  // The current drives default to: the peak of the rated RMS current, at which the datasheet
  // states the holding torque (√2·Km·I) and its temperature rise: no default overdrives it.
  m.hold_current = std::sqrt(2.0) * d.rated_current;
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
                    .datasheet = row.datasheet,
                    .thermal = row.thermal,
                    .thermal_sheet = row.sheet};
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
