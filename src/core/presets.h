// Named parameter sets of SPEC §4. Every value can be overridden by the user.
#ifndef MJSTEPPER_CORE_PRESETS_H_
#define MJSTEPPER_CORE_PRESETS_H_

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/motor_params.h"

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

struct Preset {
  std::string name;
  std::string description;
  MotorParams motor;
  int encoder_counts = 0;              ///< counts per revolution of the paper's encoder (S-16)
  std::optional<Datasheet> datasheet;  ///< catalogue motors: what `motor` was made from
};

/// `tsui2009`, `kim2016`, `bodson1993` and the catalogue motors; std::nullopt for any other name.
std::optional<Preset> FindPreset(std::string_view name);

/// The names FindPreset knows, in SPEC order.
std::vector<std::string> PresetNames();

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_PRESETS_H_
