// The STEP/DIR driver chips users own (SPEC §8): one row per chip with the numbers its datasheet
// gives, so that `driver="tmc2209"` sets the chopper, the clock, the microstep defaults and the
// current scaling of the sense resistor the way the chip does. The chopper units
// (constant_off_time.h, spread_cycle.h, stealth_chop.h) and the microstep table (step_table.h)
// take their defaults from the row; every attribute still overrides its own default.
#ifndef MJSTEPPER_CORE_CONTROLLERS_DRIVER_CHIP_H_
#define MJSTEPPER_CORE_CONTROLLERS_DRIVER_CHIP_H_

#include <array>
#include <string>
#include <vector>

#include "core/attributes.h"

namespace mjstepper {

inline constexpr AttributeSpec kAttrDriver{
    "driver", "name", "none", "—",
    "The driver chip (SPEC §8): `tmc2209`, `tmc2130`, `tmc5160` (`spreadcycle` by default, "
    "`stealthchop` on request), `a4988`, `drv8825` (`chopper`). Sets the drive, the chopper's "
    "timing, the clock, the interpolation and the sense resistor's current scaling from the "
    "chip's datasheet (see \"Driver chips\"); refuses a `bus_voltage` outside the chip's supply "
    "range, a `run_current` beyond it and `microsteps` it cannot make. `none`: the drive's own "
    "defaults."};

inline constexpr AttributeSpec kAttrSenseResistor{
    "sense_resistor", "real", "the chip's common module (0.110, 0.075, 0.068, 0.100)", "Ω",
    "The sense resistor R_S that scales the chip's current: TMC2209/2130 I_RMS = (CS+1)/32 · "
    "V_FS/(R_S + 0.02 Ω)/√2 with CS in 0..31 and V_FS 0.325 V or 0.180 V (vsense), so "
    "`run_current` is rounded to the nearest current the chip can set; TMC5160 the same with "
    "GLOBALSCALER/256 and no 0.02 Ω; A4988 / DRV8825 (analog VREF) exactly. In [0.01, 1]."};

inline constexpr AttributeSpec kAttrClockFrequency{
    "clock_frequency", "real", "the chip's (12e6; 13.2e6 on TMC2130)", "Hz",
    "`spreadcycle`, `stealthchop`: f_CLK, the TMC chip's clock, which times t_OFF, t_BLANK and "
    "the hysteresis decrement (SpreadCycle), TSTEP, the standstill detection and f_PWM "
    "(StealthChop) "
    "(internal: TMC2209 12 MHz trimmed, 11.5-12.5; TMC2130 13.2 typical, 10.1-17.2). In [4e6, "
    "2e7]."};

/// How a chip turns `run_current` into its regulated current.
enum class CurrentScaling {
  kExact,       ///< an analog reference (A4988 I = VREF/(8·R_S), DRV8825 VREF/(5·R_S))
  kCsVsense,    ///< TMC2209/2130: CS 0..31, vsense 0/1, 0.02 Ω internal (Klipper's rounding)
  kGlobalScale  ///< TMC5160: CS 31 and GLOBALSCALER 32..256
};

struct DriverChip {
  const char* name;        ///< MJCF value of `driver`
  const char* drive;       ///< the drive it selects unless `drive` is given
  const char* source;      ///< the datasheet (and Klipper's defaults) the row cites
  double min_bus_voltage;  ///< V, the bottom of the supply's operating range
  double max_bus_voltage;  ///< V, the top of the supply's operating range
  double max_current;      ///< A RMS the chip (with its module's cooling) is rated for
  double sense_resistor;   ///< Ω, R_S of the common module
  CurrentScaling scaling;
  int microsteps;          ///< the usual setting (MS pins or MRES) on printer boards
  int max_microsteps;      ///< the finest it makes; every setting is a power of two up to it
  bool interpolate;        ///< MicroPlyer (TMC) by default
  int stallguard_spread;   ///< StallGuard version in SpreadCycle (2, or 0: none)
  int stallguard_stealth;  ///< StallGuard version in StealthChop (4, or 0: none)
  // SpreadCycle / StealthChop chips (TMC):
  double clock_frequency;              ///< f_CLK, Hz; 0 for the analog chips
  double off_time_base;                ///< t_OFF = (off_time_base + 32·TOFF)/f_CLK, clocks
  std::array<double, 4> blank_clocks;  ///< TBL 0..3, clocks
  int toff, tbl, hstrt, hend;          ///< CHOPCONF defaults (Klipper's)
  // Constant-off-time chips (A4988 / DRV8825):
  double off_time;       ///< s (0: fixed-frequency PWM)
  double pwm_frequency;  ///< Hz (0: fixed off-time)
  double blank_time;     ///< s
  double fast_fraction;  ///< mixed decay's fast part
  // Standstill current reduction (TMC only; IHOLD_IRUN and TPOWERDOWN registers): the defaults
  // Klipper writes (klippy/extras/tmc2130.py, tmc2209.py, tmc5160.py).
  int iholddelay;  ///< IHOLDDELAY 0..15
  int tpowerdown;  ///< TPOWERDOWN 0..255

  /// What the chip makes of a requested `run_current` (A RMS) with sense resistor `r_sense` (Ω).
  struct Regulation {
    double current;  ///< A RMS: the request rounded to the chip's steps (CS, vsense, GLOBALSCALER)
    double most;     ///< A RMS: the most the chip, with this sense resistor, regulates
    int cs = 31;     ///< IRUN, the current scale CS 0..31 it is set with (31: analog chips)
  };
  Regulation Regulate(double run_current, double r_sense) const;
};

/// Every chip, in documentation order.
const std::vector<DriverChip>& DriverChips();

/// The chip `driver` names, or null for `none` or an unset attribute; throws ConfigError for an
/// unknown name.
const DriverChip* FindDriver(const AttributeSource& a);

/// The "Driver chips" table of the README (Markdown).
std::string DriverTableMarkdown();

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_DRIVER_CHIP_H_
