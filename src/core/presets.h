// Named parameter sets of SPEC §4. Every value can be overridden by the user.
#ifndef MJSTEPPER_CORE_PRESETS_H_
#define MJSTEPPER_CORE_PRESETS_H_

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/motor_params.h"
#include "core/thermal.h"

namespace mjstepper {

/// A catalogue motor's datasheet numbers (SPEC §8), as printed, SI units.
struct Datasheet {
  const char* source = "";    ///< document, and whether primary (maker) or secondary
  double step_angle = 1.8;    ///< degrees per full step
  double rated_current = 0;   ///< I_r, A per phase
  double holding_torque = 0;  ///< T_H, N·m, two phases at I_r
  double resistance = 0;      ///< R, Ω per phase at 20 °C
  double inductance = 0;      ///< L, H per phase
  double rotor_inertia = 0;   ///< J, kg·m²
  double detent_torque = 0;   ///< T_det, N·m; 0: not published
};

/// A motor from its datasheet (SPEC §8): Km = T_H/(√2·I_r), Nr = 360°/(4·step angle),
/// Kd4 = T_det (the 4th harmonic dominates a hybrid's detent; phase 0), R, L, J as printed.
/// B = 1e-4 N·m·s/rad and Fs = 0 are documented defaults: no datasheet gives them (B is of the
/// order of 1e-5 to 1e-4 for a NEMA 17 rotor alone; an estimate, and a MuJoCo model value).
MotorParams FromDatasheet(const Datasheet& d);

/// What a catalogue motor's thermal network (ThermalParams) was fitted to (presets.cc), SI units.
/// The fit: R_wh + R_ha such that the winding's steady rise at the rated current (both phases at
/// I_r, R(T) included, ambient 25 °C) is `rated_rise`; C_w = copper_fraction·mass·385 J/(kg·K)
/// (copper's specific heat); R_wh/R_ha and C_h such that the winding and the housing reach
/// 1 − 1/e of their final rises under a held power after the two time constants.
struct ThermalSheet {
  const char* source = "";           ///< document, and which numbers are estimates
  double winding_time_constant = 0;  ///< s
  double surface_time_constant = 0;  ///< s, the housing's
  double rated_rise = 0;             ///< K
  double mass = 0;                   ///< kg, the motor's
  double copper_fraction = 0.12;     ///< of the mass (an estimate for every motor here)
};

struct Preset {
  std::string name;
  std::string description;
  MotorParams motor;
  int encoder_counts = 0;                ///< counts per revolution of the paper's encoder (S-16)
  std::optional<Datasheet> datasheet;    ///< catalogue motors: what `motor` was made from
  std::optional<ThermalParams> thermal;  ///< the heat network (SPEC §8); paper motors: none
  std::optional<ThermalSheet> thermal_sheet;  ///< what `thermal` was fitted to
};

/// `tsui2009`, `kim2016`, `bodson1993` and the catalogue motors; std::nullopt for any other name.
std::optional<Preset> FindPreset(std::string_view name);

/// The names FindPreset knows, in SPEC order.
std::vector<std::string> PresetNames();

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_PRESETS_H_
