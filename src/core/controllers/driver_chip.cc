#include "core/controllers/driver_chip.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace mjstepper {
namespace {

// TMC2209/2130 current scaling (TMC2209 datasheet Rev. 1.09 §9 "Selecting sense resistor and
// current"; TMC2130 Rev. 1.15 §9): I_RMS = (CS+1)/32 · V_FS/(R_S + 0.02 Ω) · 1/√2, with
// V_FS = 0.325 V (vsense = 0) or 0.180 V (vsense = 1); the 0.02 Ω is the chip's internal path.
constexpr double kFullScaleHigh = 0.325, kFullScaleLow = 0.180;  // V
constexpr double kInternalSense = 0.02;                          // Ω

double CsCurrent(int cs, double full_scale, double r_sense) {
  return (cs + 1) / 32.0 * full_scale / (r_sense + kInternalSense) / std::sqrt(2.0);
}

// The CS (0..31) nearest to `current` (A RMS) at a full scale.
int NearestCs(double current, double full_scale, double r_sense) {
  const double exact = 32.0 * current * std::sqrt(2.0) * (r_sense + kInternalSense) / full_scale;
  return std::clamp(static_cast<int>(std::lround(exact)) - 1, 0, 31);
}

// TMC5160 (datasheet Rev. 1.14 §9): I_RMS = GLOBALSCALER/256 · (CS+1)/32 · V_FS/R_S · 1/√2,
// V_FS = 0.325 V, GLOBALSCALER 32..256 (its register's 0 is 256; below 32 not for operation).
double ScaledCurrent(int globalscaler, int cs, double r_sense) {
  return globalscaler / 256.0 * (cs + 1) / 32.0 * kFullScaleHigh / r_sense / std::sqrt(2.0);
}

}  // namespace

const std::vector<DriverChip>& DriverChips() {
  static const std::vector<DriverChip> chips = {
      {.name = "tmc2209",
       .drive = "spreadcycle",
       .source = "Trinamic TMC2209 datasheet Rev. 1.09: 4.75-29 V, MRES 1-256 microsteps, 2 A RMS "
                 "(2.8 A peak), f_CLK "
                 "12 MHz, t_OFF = (24 + 32·TOFF)/f_CLK, TBL 16/24/32/40 clocks, StallGuard4 in "
                 "StealthChop only; BigTreeTech "
                 "module R_S 0.110 Ω; Klipper's CHOPCONF defaults TOFF 3, HSTRT 5, HEND 0, TBL 2, "
                 "IHOLDDELAY 8, TPOWERDOWN 20",
       .min_bus_voltage = 4.75,
       .max_bus_voltage = 29,
       .max_current = 2.0,
       .sense_resistor = 0.110,
       .scaling = CurrentScaling::kCsVsense,
       .microsteps = 16,
       .max_microsteps = 256,
       .interpolate = true,
       .stallguard_spread = 0,
       .stallguard_stealth = 4,
       .clock_frequency = 12e6,
       .off_time_base = 24,
       .blank_clocks = {16, 24, 32, 40},
       .toff = 3,
       .tbl = 2,
       .hstrt = 5,
       .hend = 0,
       .off_time = 0,
       .pwm_frequency = 0,
       .blank_time = 0,
       .fast_fraction = 0,
       .iholddelay = 8,
       .tpowerdown = 20},
      {.name = "tmc2130",
       .drive = "spreadcycle",
       .source = "Trinamic TMC2130 datasheet Rev. 1.15: 4.75-46 V, MRES 1-256 microsteps, 1.2 A "
                 "RMS (QFN; 2.5 A peak), "
                 "f_CLK 13.2 MHz typical, t_OFF = (12 + 32·TOFF)/f_CLK, TBL 16/24/36/54 clocks, "
                 "StallGuard2 in SpreadCycle; module R_S 0.110 Ω; Klipper's defaults TOFF 4, HSTRT "
                 "0, HEND 7, TBL 1, IHOLDDELAY 8, TPOWERDOWN 0",
       .min_bus_voltage = 4.75,
       .max_bus_voltage = 46,
       .max_current = 1.2,
       .sense_resistor = 0.110,
       .scaling = CurrentScaling::kCsVsense,
       .microsteps = 16,
       .max_microsteps = 256,
       .interpolate = true,
       .stallguard_spread = 2,
       .stallguard_stealth = 0,
       .clock_frequency = 13.2e6,
       .off_time_base = 12,
       .blank_clocks = {16, 24, 36, 54},
       .toff = 4,
       .tbl = 1,
       .hstrt = 0,
       .hend = 7,
       .off_time = 0,
       .pwm_frequency = 0,
       .blank_time = 0,
       .fast_fraction = 0,
       .iholddelay = 8,
       .tpowerdown = 0},
      {.name = "tmc5160",
       .drive = "spreadcycle",
       .source = "Trinamic TMC5160 datasheet Rev. 1.14: 8-60 V, MRES 1-256 microsteps, external "
                 "MOSFETs (up to 20 A; "
                 "3 A RMS here, the BigTreeTech module's rating), f_CLK 12 MHz, t_OFF = "
                 "(24 + 32·TOFF)/f_CLK, TBL 16/24/36/54 clocks, StallGuard2 in SpreadCycle, R_S "
                 "0.075 Ω; Klipper's defaults "
                 "TOFF 3, HSTRT 5, HEND 2, TBL 2, IHOLDDELAY 6, TPOWERDOWN 10",
       .min_bus_voltage = 8,
       .max_bus_voltage = 60,
       .max_current = 3.0,
       .sense_resistor = 0.075,
       .scaling = CurrentScaling::kGlobalScale,
       .microsteps = 16,
       .max_microsteps = 256,
       .interpolate = true,
       .stallguard_spread = 2,
       .stallguard_stealth = 0,
       .clock_frequency = 12e6,
       .off_time_base = 24,
       .blank_clocks = {16, 24, 36, 54},
       .toff = 3,
       .tbl = 2,
       .hstrt = 5,
       .hend = 2,
       .off_time = 0,
       .pwm_frequency = 0,
       .blank_time = 0,
       .fast_fraction = 0,
       .iholddelay = 6,
       .tpowerdown = 10},
      {.name = "a4988",
       .drive = "chopper",
       .source = "Allegro A4988 datasheet (A4988-DS Rev. 7): 8-35 V, MS1-MS3 full to 1/16 step, ±2 "
                 "A (1.41 A RMS), fixed "
                 "off-time 30 µs, blank 1 µs, mixed decay fast for 31.25 % of t_off, I_TripMax = "
                 "VREF/(8·R_S); Pololu module R_S 0.068 Ω",
       .min_bus_voltage = 8,
       .max_bus_voltage = 35,
       .max_current = 2.0 / std::sqrt(2.0),
       .sense_resistor = 0.068,
       .scaling = CurrentScaling::kExact,
       .microsteps = 16,
       .max_microsteps = 16,
       .interpolate = false,
       .stallguard_spread = 0,
       .stallguard_stealth = 0,
       .clock_frequency = 0,
       .off_time_base = 0,
       .blank_clocks = {0, 0, 0, 0},
       .toff = 0,
       .tbl = 0,
       .hstrt = 0,
       .hend = 0,
       .off_time = 30e-6,
       .pwm_frequency = 0,
       .blank_time = 1e-6,
       .fast_fraction = 0.3125,
       .iholddelay = 0,
       .tpowerdown = 0},
      {.name = "drv8825",
       .drive = "chopper",
       .source = "TI DRV8825 datasheet (SLVSA73F): 8.2-45 V, MODE0-2 full to 1/32 step, 2.5 A full "
                 "scale (1.77 A RMS), "
                 "fixed-frequency PWM 30 kHz, blank 3.75 µs, mixed decay fast until 75 % of the "
                 "PWM cycle, I_CHOP = VREF/(5·R_S); Pololu module R_S 0.100 Ω",
       .min_bus_voltage = 8.2,
       .max_bus_voltage = 45,
       .max_current = 2.5 / std::sqrt(2.0),
       .sense_resistor = 0.100,
       .scaling = CurrentScaling::kExact,
       .microsteps = 16,
       .max_microsteps = 32,
       .interpolate = false,
       .stallguard_spread = 0,
       .stallguard_stealth = 0,
       .clock_frequency = 0,
       .off_time_base = 0,
       .blank_clocks = {0, 0, 0, 0},
       .toff = 0,
       .tbl = 0,
       .hstrt = 0,
       .hend = 0,
       .off_time = 0,
       .pwm_frequency = 30e3,
       .blank_time = 3.75e-6,
       .fast_fraction = 0.75,
       .iholddelay = 0,
       .tpowerdown = 0},
  };
  return chips;
}

const DriverChip* FindDriver(const AttributeSource& a) {
  const std::optional<std::string> raw = a.Raw(kAttrDriver);
  if (!raw || *raw == "none") return nullptr;
  std::vector<std::string> names = {"none"};
  for (const DriverChip& chip : DriverChips()) {
    if (*raw == chip.name) return &chip;
    names.push_back(chip.name);
  }
  ThrowBad(kAttrDriver, *raw, fmt::format("must be one of: {}", fmt::join(names, ", ")));
}

DriverChip::Regulation DriverChip::Regulate(double run_current, double r_sense) const {
  switch (scaling) {
    case CurrentScaling::kExact:
      return {.current = run_current, .most = max_current};
    case CurrentScaling::kCsVsense: {
      // The nearest current of either full scale (Klipper picks the same way, vsense first).
      const int cs_low = NearestCs(run_current, kFullScaleLow, r_sense);
      const int cs_high = NearestCs(run_current, kFullScaleHigh, r_sense);
      const double low = CsCurrent(cs_low, kFullScaleLow, r_sense);
      const double high = CsCurrent(cs_high, kFullScaleHigh, r_sense);
      const bool pick_low = std::abs(low - run_current) <= std::abs(high - run_current);
      return {.current = pick_low ? low : high,
              .most = std::min(max_current, CsCurrent(31, kFullScaleHigh, r_sense)),
              .cs = pick_low ? cs_low : cs_high};
    }
    case CurrentScaling::kGlobalScale: {
      const double exact = 256.0 * run_current * std::sqrt(2.0) * r_sense / kFullScaleHigh;
      const int gs = std::clamp(static_cast<int>(std::lround(exact)), 32, 256);
      const double per_cs = ScaledCurrent(gs, 31, r_sense) / 32;  // A per CS step
      const int cs = std::clamp(static_cast<int>(std::lround(run_current / per_cs)) - 1, 0, 31);
      return {.current = ScaledCurrent(gs, cs, r_sense),
              .most = std::min(max_current, ScaledCurrent(256, 31, r_sense)),
              .cs = cs};
    }
  }
  return {.current = run_current, .most = max_current};
}

std::string DriverTableMarkdown() {
  std::string out =
      "| `driver` | drive | bus (V) | current (A RMS) | R_S (Ω) | microsteps (powers of two) | "
      "chopper defaults | "
      "source |\n"
      "|---|---|---|---|---|---|---|---|\n";
  for (const DriverChip& c : DriverChips()) {
    const std::string chopper =
        c.clock_frequency > 0 ? fmt::format("f_CLK {:g} MHz, TOFF {}, TBL {}, HSTRT {}, HEND {}",
                                            c.clock_frequency / 1e6, c.toff, c.tbl, c.hstrt, c.hend)
        : c.pwm_frequency > 0
            ? fmt::format("PWM {:g} kHz, blank {:g} µs, fast {:g} %", c.pwm_frequency / 1e3,
                          c.blank_time * 1e6, c.fast_fraction * 100)
            : fmt::format("t_off {:g} µs, blank {:g} µs, fast {:g} %", c.off_time * 1e6,
                          c.blank_time * 1e6, c.fast_fraction * 100);
    out += fmt::format("| `{}` | `{}` | {:g}-{:g} | ≤ {:.3g} | {:g} | {} (1-{}){} | {} | {} |\n",
                       c.name, c.drive, c.min_bus_voltage, c.max_bus_voltage, c.max_current,
                       c.sense_resistor, c.microsteps, c.max_microsteps,
                       c.interpolate ? ", MicroPlyer to 256" : "", chopper, c.source);
  }
  return out;
}

}  // namespace mjstepper
