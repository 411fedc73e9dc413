// Helpers shared by the libFuzzer targets (config_fuzz.cc, drive_fuzz.cc): reports, fuzzed numbers
// in every spelling and exponent, fuzzed <config> attributes, and finiteness checks of a drive's
// state. Header-only; each target defines kTargetName.
#ifndef MJSTEPPER_TESTS_FUZZ_FUZZ_COMMON_H_
#define MJSTEPPER_TESTS_FUZZ_FUZZ_COMMON_H_

#include <fuzzer/FuzzedDataProvider.h>

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/drive.h"

namespace mjstepper::fuzz {

// The target's name, for reports: each target defines it.
extern const char* const kTargetName;

// A violated property: report it and trap, so that libFuzzer reports the input.
[[noreturn]] inline void Fail(const char* what, const std::string& detail) {
  std::fprintf(stderr, "\n%s: PROPERTY VIOLATED: %s\n%s\n", kTargetName, what, detail.c_str());
  std::fflush(stderr);
  __builtin_trap();
}

// Words the parsers know (and a few near misses), so that inputs get past the choices quickly.
inline constexpr const char* kWords[] = {"tsui2009",
                                         "kim2016",
                                         "bodson1993",
                                         "current_microstep",
                                         "voltage_microstep",
                                         "ideal_current",
                                         "servo",
                                         "identification",
                                         "stmms",
                                         "foc",
                                         "chopper",
                                         "spreadcycle",
                                         "stealthchop",
                                         "averaged",
                                         "switching",
                                         "substepped",
                                         "steps",
                                         "tmc2209",
                                         "tmc2130",
                                         "tmc5160",
                                         "a4988",
                                         "drv8825",
                                         "mixed",
                                         "qsh4218_51",
                                         "position",
                                         "velocity",
                                         "h_bridge",
                                         "svpwm",
                                         "estimate",
                                         "exact",
                                         "none",
                                         "trapezoid",
                                         "scurve",
                                         "on",
                                         "off",
                                         "case1",
                                         "case2",
                                         "analytic",
                                         "numeric",
                                         "",
                                         " ",
                                         "nan",
                                         "inf",
                                         "-inf",
                                         "1e999",
                                         "0x10",
                                         "4,8",
                                         "+",
                                         "-",
                                         ".",
                                         "e5",
                                         "Position",
                                         "tsui2009 ",
                                         " none",
                                         "none;"};

inline constexpr const char* kNumberFormats[] = {"%g",  "%.17g", "%e",  "%f",      "%a",
                                                 "%+g", " %g ",  "%gV", "\t%.3g\n"};

// A double with every exponent reachable: small integers, decimals, or any bit pattern.
inline double ConsumeNumber(FuzzedDataProvider& in) {
  switch (in.ConsumeIntegralInRange<int>(0, 4)) {
    case 0:
      return in.ConsumeIntegralInRange<int>(-4, 1100);
    case 1:
      return in.ConsumeIntegralInRange<int>(-100000, 100000) *
             std::pow(10.0, in.ConsumeIntegralInRange<int>(-12, 6));
    case 2:
      return in.ConsumeFloatingPointInRange<double>(-10.0, 100.0);
    case 3: {
      const double mantissa = in.ConsumeFloatingPointInRange<double>(-10.0, 10.0);
      return mantissa * std::pow(10.0, in.ConsumeIntegralInRange<int>(-320, 308));
    }
    default:
      return in.ConsumeFloatingPoint<double>();
  }
}

inline std::string FormatNumber(FuzzedDataProvider& in, double value) {
  const char* format = in.PickValueInArray(kNumberFormats);
  char text[512];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

inline std::string ConsumeHarmonics(FuzzedDataProvider& in) {
  std::string text;
  const int groups = in.ConsumeIntegralInRange<int>(0, 4);
  for (int g = 0; g < groups; ++g) {
    if (g > 0) text += in.ConsumeBool() ? "; " : ";";
    const int fields = in.ConsumeIntegralInRange<int>(2, 4);
    for (int f = 0; f < fields; ++f) {
      if (f > 0) text += ' ';
      text += f == 0 ? std::to_string(in.ConsumeIntegralInRange<int>(-1, 1001))
                     : FormatNumber(in, ConsumeNumber(in));
    }
  }
  return text;
}

inline std::string ConsumeValue(FuzzedDataProvider& in) {
  switch (in.ConsumeIntegralInRange<int>(0, 3)) {
    case 0:
      return in.PickValueInArray(kWords);
    case 1:
      return FormatNumber(in, ConsumeNumber(in));
    case 2:
      return ConsumeHarmonics(in);
    default:
      return in.ConsumeRandomLengthString(48);
  }
}

// The core state's fields by name, for reports.
#define MJSTEPPER_FIELD(f) \
  { #f, offsetof(DriveCoreState, f) / sizeof(double) }
inline constexpr std::pair<const char*, size_t> kCoreFields[] = {
    MJSTEPPER_FIELD(started),
    MJSTEPPER_FIELD(theta),
    MJSTEPPER_FIELD(theta_cmd),
    MJSTEPPER_FIELD(omega_cmd),
    MJSTEPPER_FIELD(current_a),
    MJSTEPPER_FIELD(current_b),
    MJSTEPPER_FIELD(voltage_a),
    MJSTEPPER_FIELD(voltage_b),
    MJSTEPPER_FIELD(pending_a),
    MJSTEPPER_FIELD(pending_b),
    MJSTEPPER_FIELD(pending),
    MJSTEPPER_FIELD(apply_time),
    MJSTEPPER_FIELD(next_tick),
    MJSTEPPER_FIELD(anchor_tick),
    MJSTEPPER_FIELD(anchor_time),
    MJSTEPPER_FIELD(theta_meas),
    MJSTEPPER_FIELD(omega_est),
    MJSTEPPER_FIELD(current_ref_a),
    MJSTEPPER_FIELD(current_ref_b),
    MJSTEPPER_FIELD(energy_input),
    MJSTEPPER_FIELD(energy_copper),
    MJSTEPPER_FIELD(energy_mechanical),
    MJSTEPPER_FIELD(rotor_cos),
    MJSTEPPER_FIELD(rotor_sin),
    MJSTEPPER_FIELD(slip_cell),
    MJSTEPPER_FIELD(slip_origin),
    MJSTEPPER_FIELD(last_slip_time),
    MJSTEPPER_FIELD(stallguard),
    MJSTEPPER_FIELD(stall),
    MJSTEPPER_FIELD(first_stall_time),
    MJSTEPPER_FIELD(full_step),
    MJSTEPPER_FIELD(full_step_time),
    MJSTEPPER_FIELD(full_step_theta),
    MJSTEPPER_FIELD(current_scale),
    MJSTEPPER_FIELD(coolstep_count),
    MJSTEPPER_FIELD(winding_temperature),
    MJSTEPPER_FIELD(housing_temperature),
    MJSTEPPER_FIELD(mean_offset_a),
    MJSTEPPER_FIELD(mean_offset_b),
    MJSTEPPER_FIELD(voltage_peak)};
#undef MJSTEPPER_FIELD
static_assert(std::size(kCoreFields) == sizeof(DriveCoreState) / sizeof(double));

inline std::string NonFinite(const DriveState& s, int stored) {
  const double* core = reinterpret_cast<const double*>(static_cast<const DriveCoreState*>(&s));
  std::string out = "non-finite:";
  for (const auto& [name, index] : kCoreFields) {
    if (!std::isfinite(core[index]))
      out += std::string(" ") + name + "=" + std::to_string(core[index]);
  }
  for (int i = 0; i < stored; ++i) {
    if (!std::isfinite(s.unit[i]))
      out += " unit[" + std::to_string(i) + "]=" + std::to_string(s.unit[i]);
  }
  return out;
}

inline bool AllFinite(const double* values, int count) {
  for (int i = 0; i < count; ++i) {
    if (!std::isfinite(values[i])) return false;
  }
  return true;
}

inline std::string Describe(const std::map<std::string, std::string>& attributes) {
  std::string out = "attributes:";
  for (const auto& [key, value] : attributes) out += " " + key + "=\"" + value.c_str() + "\"";
  return out;
}

// A few attribute key/value pairs: keys from `names` (now and then an unknown one, "unknown_..."),
// values a known word, a number in some spelling, a harmonic list, or raw bytes.
inline std::map<std::string, std::string> ConsumeAttributes(FuzzedDataProvider& in,
                                                            const std::vector<const char*>& names) {
  std::map<std::string, std::string> attributes;
  const int count = in.ConsumeIntegralInRange<int>(0, 10);
  for (int i = 0; i < count; ++i) {
    const size_t k = in.ConsumeIntegralInRange<size_t>(0, names.size());
    const std::string key =
        k < names.size() ? names[k] : "unknown_" + in.ConsumeRandomLengthString(6);
    attributes[key] = ConsumeValue(in);
  }
  return attributes;
}

}  // namespace mjstepper::fuzz

#endif  // MJSTEPPER_TESTS_FUZZ_FUZZ_COMMON_H_
