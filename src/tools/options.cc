#include "options.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <stdexcept>
#include <string>
#include <string_view>

#include "attach.h"
#include "core/attributes.h"
#include "core/command_profile.h"
#include "core/klipper_steps.h"
#include "core/step_times.h"
#include "core/units.h"

namespace mjstepper::tools {
namespace {

// The ranges. A bound is where a value beyond it is a typing error or an absurd amount of work;
// each says why.
constexpr OptionRange kRanges[] = {
    {"duration", 1e-6, 1e6, "s", "simulated time; also at least one timestep of the model"},
    {"steps", 1, 1e12, "steps", "duration / timestep of a run"},
    {"fps", 1, 1000, "frames/s", "video frames per second of video"},
    {"playback", 1e-4, 1e4, "s/s", "simulated seconds per video second"},
    {"frames", 1, kMaxFrames, "frames", "duration · fps / playback: frames a run renders"},
    {"size", 16, 8192, "pixels", "frame width and height"},
    {"log-every", 1, 1e9, "steps", "one log row every N steps"},
    {"mass", 1e-9, 1e6, "kg", "a body's mass (--mass, mass:BODY of map)"},
    {"load", -1e4, 1e4, "N·m", "a load torque (--load)"},
    {"stiffness", 0, 1e12, "N·m/rad or N/m", "a joint's spring stiffness (stiffness:JOINT of map)"},
    {"speed", -kMaxProfileSpeed, kMaxProfileSpeed, "rad/s",
     "each speed of a list, and of a --ctrl profile (95 493 r/min)"},
    {"speeds", 1, kMaxRuns, "speeds", "how many speeds a list holds; speeds × values of a map"},
    {"settle", 0, 60, "s", "at each speed before measuring (sweep, map)"},
    {"measure", 0.01, 60, "s", "measured at each speed (sweep, map); at least 100 timesteps"},
    {"threads", 0, 256, "threads", "worker threads (0: one per core)"},
    {"rate", 1e-3, 1e4, "N·m/s", "how fast pullout's load torque rises"},
    {"max-torque", 1e-6, 1e4, "N·m", "pullout's highest load torque; max-torque / rate <= 1000 s"},
    {"orders", 1, 64, "", "detent harmonic orders identify fits, each once"},
    {"dwell", 0, 3600, "s", "size: the pause at each pose of a move"},
    {"cycles", 1, 1e6, "cycles", "size: the duty cycles the winding's heat is carried over"},
    {"pullout-points", 3, 200, "speeds", "size: speeds of each joint's simulated pull-out curve"},
    {"min-freq", 1, 1000, "Hz", "a resonance test's lowest frequency"},
    {"max-freq", 1, 1000, "Hz", "a resonance test's highest frequency"},
    {"accel-per-hz", 0.1, 10000, "mm/s² per Hz", "a resonance test's acceleration per Hz"},
    {"hz-per-sec", 0.01, 100, "Hz/s", "how fast a resonance test's frequency rises"},
    {"test-duration", 0.01, 3600, "s", "(max-freq − min-freq)/hz-per-sec: a resonance test"},
    {"accel-rate", 100, 3200, "Hz", "the ADXL345's output data rate (its range)"},
    {"accel-noise", 0, 1e5, "µg/√Hz", "the ADXL345's noise density (data sheet: 290 on X, Y)"},
    // The parsers' own bounds (issue 33: bounded before any work), from the constants the parsers
    // read (core/command_profile.h, core/step_times.h, core/klipper_steps.h).
    {"profile-text", 1, kMaxProfileText, "characters", "a --ctrl profile's text"},
    {"targets", 1, kMaxTargets, "targets", "a targets(…) profile's targets"},
    {"shaped-depth", 1, kMaxNestedShapers, "levels", "shaped(…) nested in a profile"},
    {"step-file", 1, kMaxStepFileBytes, "bytes", "a steps(FILE) list's file (a regular file)"},
    {"step-times", 1, kMaxStepTimes, "steps", "a steps(FILE) list's steps"},
    {"step-line", 0, kMaxStepLine, "characters", "a line of a steps(FILE) list"},
    {"klipper-lines", 1, kMaxKlipperDumpLines, "lines", "a --klipper dump's MCU commands"},
};

// The units a joint value may carry: SI per unit, the quantity, and whether it is linear.
struct JointUnit {
  const char* name;
  double si;  // per unit
  JointQuantity quantity;
  bool linear;
};
constexpr double kDeg = kTwoPi / 360.0;  // rad
constexpr JointUnit kJointUnits[] = {{"deg", kDeg, JointQuantity::kPosition, false},
                                     {"rad", 1, JointQuantity::kPosition, false},
                                     {"mm", 1e-3, JointQuantity::kPosition, true},
                                     {"m", 1, JointQuantity::kPosition, true},
                                     {"deg/s", kDeg, JointQuantity::kSpeed, false},
                                     {"rad/s", 1, JointQuantity::kSpeed, false},
                                     {"rpm", kTwoPi / 60, JointQuantity::kSpeed, false},
                                     {"r/min", kTwoPi / 60, JointQuantity::kSpeed, false},
                                     {"mm/s", 1e-3, JointQuantity::kSpeed, true},
                                     {"m/s", 1, JointQuantity::kSpeed, true},
                                     {"deg/s²", kDeg, JointQuantity::kAcceleration, false},
                                     {"deg/s^2", kDeg, JointQuantity::kAcceleration, false},
                                     {"rad/s²", 1, JointQuantity::kAcceleration, false},
                                     {"rad/s^2", 1, JointQuantity::kAcceleration, false},
                                     {"mm/s²", 1e-3, JointQuantity::kAcceleration, true},
                                     {"mm/s^2", 1e-3, JointQuantity::kAcceleration, true},
                                     {"m/s²", 1, JointQuantity::kAcceleration, true},
                                     {"m/s^2", 1, JointQuantity::kAcceleration, true}};

std::string Trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t") - b + 1);
}

const char* UnitsOf(JointQuantity q) {
  return q == JointQuantity::kPosition ? "deg, rad (hinge) or mm, m (slide)"
         : q == JointQuantity::kSpeed  ? "deg/s, rad/s, rpm (hinge) or mm/s, m/s (slide)"
                                       : "deg/s², rad/s² (hinge) or mm/s², m/s² (slide)";
}

}  // namespace

std::span<const OptionRange> OptionRanges() { return kRanges; }

const OptionRange& Range(const std::string& name) {
  for (const OptionRange& r : kRanges) {
    if (name == r.name) return r;
  }
  throw std::logic_error("no option range named " + name);
}

void RequireInRange(const std::string& option, const OptionRange& range, double value,
                    const std::string& shown) {
  if (value >= range.lo && value <= range.hi) return;
  throw std::invalid_argument(fmt::format("{} {}: must be in [{:g}, {:g}]{}{}", option,
                                          shown.empty() ? fmt::format("{:g}", value) : shown,
                                          range.lo, range.hi, *range.unit ? " " : "", range.unit));
}

std::vector<double> ParseSpeedList(const std::string& text, const std::string& option,
                                   bool* at_carriage) {
  // Linear in the text (issue 33: each number's bound check formatted a message quoting the whole
  // list, so 1e5 speeds took minutes): messages quote a bounded excerpt, built only on failure,
  // and the list's length is bounded before any number is read.
  const std::string shown = Excerpt(text);
  size_t unit_at = text.find_last_of("0123456789.") + 1;
  if (unit_at == 0 || unit_at > text.size()) unit_at = text.size();
  const std::string unit = text.substr(unit_at);
  const std::string_view body = std::string_view(text).substr(0, unit_at);
  const bool linear = unit == "mm/s" || unit == "m/s";
  if (linear && at_carriage == nullptr) {
    throw std::invalid_argument(fmt::format(
        "{} {}: these speeds are the rotor's: end with rpm, r/min or rad/s", option, shown));
  }
  if (unit != "rpm" && unit != "r/min" && unit != "rad/s" && !linear) {
    throw std::invalid_argument(fmt::format(
        "{} {}: end with a unit: rpm, r/min or rad/s{}", option, shown,
        at_carriage != nullptr ? " (the rotor), or mm/s, m/s (a linear axis's carriage)" : ""));
  }
  if (at_carriage != nullptr) *at_carriage = linear;
  // In SI (rad/s at the rotor, m/s at the carriage), each as its own conversion rounds it (the
  // r/min one as RpmToRadPerSec, so that a list gives the speeds it always gave, bit for bit).
  auto to_si = [&unit](double v) {
    return unit == "rpm" || unit == "r/min" ? RpmToRadPerSec(v) : unit == "mm/s" ? v * 1e-3 : v;
  };
  const OptionRange& bound = Range("speed");
  auto speed = [&](std::string_view number) {
    double v = 0;
    if (!ParseFiniteDouble(std::string(number), &v)) {
      throw std::invalid_argument(fmt::format("{} {}: \"{}\" is not a finite number", option, shown,
                                              Excerpt(std::string(number))));
    }
    v = to_si(v);
    if (!(v >= bound.lo && v <= bound.hi)) {
      RequireInRange(option, bound, v, fmt::format("{} ({}{})", shown, number, unit));
    }
    return v;
  };
  std::vector<double> speeds;
  if (body.find(':') != std::string::npos) {
    const size_t a = body.find(':'), b = body.find(':', a + 1);
    if (b == std::string::npos || body.find(':', b + 1) != std::string::npos) {
      throw std::invalid_argument(fmt::format("{} {}: expected from:to:step", option, shown));
    }
    const double from = speed(body.substr(0, a));
    const double to = speed(body.substr(a + 1, b - a - 1));
    const double step = speed(body.substr(b + 1));
    if (!(step > 0) || to < from) {
      throw std::invalid_argument(
          fmt::format("{} {}: need step > 0 and to >= from", option, shown));
    }
    const double count = std::floor((to - from) / step + 1e-9) + 1;  // finite: all are bounded
    RequireInRange(option, Range("speeds"), count, fmt::format("{} ({:g} speeds)", shown, count));
    for (long k = 0; k < static_cast<long>(count); ++k) speeds.push_back(from + k * step);
  } else {
    const double count = static_cast<double>(std::count(body.begin(), body.end(), ',')) + 1;
    RequireInRange(option, Range("speeds"), count, fmt::format("{} ({:g} speeds)", shown, count));
    speeds.reserve(static_cast<size_t>(count));
    size_t start = 0;
    while (start <= body.size()) {
      const size_t comma = body.find(',', start);
      speeds.push_back(speed(body.substr(start, comma - start)));
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
  }
  return speeds;
}

void ParseSize(const std::string& text, int* width, int* height) {
  const size_t x = text.find('x');
  auto integer = [&](const std::string& s) {
    if (s.empty() || s.size() > 6 || !std::all_of(s.begin(), s.end(), ::isdigit)) {
      throw std::invalid_argument(fmt::format("--size {}: expected WxH, e.g. 640x480", text));
    }
    const int v = std::stoi(s);
    RequireInRange("--size", Range("size"), v, text);
    return v;
  };
  if (x == std::string::npos) {
    throw std::invalid_argument(fmt::format("--size {}: expected WxH, e.g. 640x480", text));
  }
  *width = integer(text.substr(0, x));
  *height = integer(text.substr(x + 1));
}

std::map<std::string, double> NamedNumbers(const std::string& option, const char* form,
                                           const OptionRange& range,
                                           const std::vector<std::string>& items) {
  std::map<std::string, double> out;
  for (const std::string& item : items) {
    const size_t eq = item.find('=');
    double value = 0;
    if (eq == std::string::npos || eq == 0 || !ParseFiniteDouble(item.substr(eq + 1), &value)) {
      throw std::invalid_argument(fmt::format("{} {}: expected {}", option, item, form));
    }
    RequireInRange(option, range, value, item);
    out[item.substr(0, eq)] = value;
  }
  return out;
}

std::string OptionRangeTableMarkdown() {
  std::string out = "| bound | least | most | unit | what |\n|---|---|---|---|---|\n";
  for (const OptionRange& r : kRanges) {
    out += fmt::format("| `{}` | {:g} | {:g} | {} | {} |\n", r.name, r.lo, r.hi, r.unit, r.why);
  }
  return out;
}

std::vector<double> ParseJointValues(const std::string& option, const std::string& text,
                                     JointQuantity quantity, std::optional<bool> linear,
                                     bool single, bool* was_linear) {
  auto bad = [&](const std::string& why) {
    return std::invalid_argument(
        fmt::format("{}{}{}: {}", option, option.ends_with('=') ? "" : " ", text, why));
  };
  std::vector<std::string> items;
  for (size_t start = 0;;) {
    const size_t comma = text.find(',', start);
    items.push_back(Trim(text.substr(start, comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (single && items.size() != 1) throw bad("give one value");
  std::vector<double> numbers(items.size());
  std::vector<const JointUnit*> units(items.size(), nullptr);
  for (size_t i = 0; i < items.size(); ++i) {
    const std::string& item = items[i];
    const char* begin = item.data() + (!item.empty() && item[0] == '+' ? 1 : 0);
    const auto [ptr, ec] = std::from_chars(begin, item.data() + item.size(), numbers[i]);
    if (ec != std::errc() || !std::isfinite(numbers[i])) {
      throw bad(fmt::format("\"{}\" is not a number (with a unit: {})", item, UnitsOf(quantity)));
    }
    const std::string unit = Trim(std::string(ptr, item.data() + item.size()));
    if (unit.empty()) continue;
    for (const JointUnit& u : kJointUnits) {
      if (unit == u.name && u.quantity == quantity) units[i] = &u;
    }
    if (units[i] == nullptr || (linear && units[i]->linear != *linear)) {
      throw bad(fmt::format("\"{}\": the unit must be one of {}{}", item, UnitsOf(quantity),
                            linear ? (*linear ? "; this is a slide"
                                              : "; this is a hinge (for mm, declare its carriage: "
                                                "pulley_teeth or lead)")
                                   : ""));
    }
  }
  if (units.back() == nullptr) {
    throw bad(fmt::format("the last value needs a unit: {}", UnitsOf(quantity)));
  }
  const double bound = quantity == JointQuantity::kPosition ? kMaxProfileAngle
                       : quantity == JointQuantity::kSpeed  ? kMaxProfileSpeed
                                                            : kMaxProfileAcceleration;
  std::vector<double> out(items.size());
  const JointUnit* last = units.back();
  for (size_t i = items.size(); i-- > 0;) {
    if (units[i] == nullptr) units[i] = last;
    if (units[i]->linear != last->linear) throw bad("mix of angular and linear units");
    last = units[i];
    out[i] = numbers[i] * units[i]->si;
    if (!(std::abs(out[i]) <= bound)) {
      throw bad(fmt::format("\"{}\" is beyond ±{:g} in SI units", items[i], bound));
    }
    if (quantity != JointQuantity::kPosition && !(out[i] > 0)) {
      throw bad(fmt::format("\"{}\": a rate must be > 0", items[i]));
    }
  }
  if (was_linear != nullptr) *was_linear = last->linear;
  return out;
}

// `mjstepper attach`'s --stepper (attach.h); here, with the other option parsers, free of MuJoCo.
AttachStepper ParseAttachStepper(const std::string& text) {
  const size_t colon = text.find(':');
  AttachStepper s;
  s.joint = text.substr(0, colon);
  if (colon == std::string::npos || s.joint.empty()) {
    throw std::invalid_argument(
        fmt::format("--stepper {}: write JOINT:key=value,..., e.g. "
                    "L1:motor=17hs24_2104s,driver=tmc5160,gear=6.4,run_current=1.7",
                    text));
  }
  std::string rest = text.substr(colon + 1);
  size_t start = 0;
  while (start <= rest.size()) {
    const size_t comma = std::min(rest.find(',', start), rest.size());
    const std::string item = rest.substr(start, comma - start);
    start = comma + 1;
    if (item.empty()) continue;
    const size_t eq = item.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == item.size()) {
      throw std::invalid_argument(
          fmt::format("--stepper {}: '{}' is not key=value (joint '{}')", text, item, s.joint));
    }
    const std::string key = item.substr(0, eq), value = item.substr(eq + 1);
    if (key == "gear") {
      if (!ParseFiniteDouble(value, &s.gear) || s.gear == 0 || !(std::abs(s.gear) <= 1e6)) {
        throw std::invalid_argument(fmt::format(
            "--stepper {}: gear = {} for joint '{}': the rotor turns gear times the joint, a "
            "finite number, nonzero, |gear| <= 1e6",
            text, value, s.joint));
      }
    } else if (!s.config.emplace(key, value).second) {
      throw std::invalid_argument(
          fmt::format("--stepper {}: {} given twice for joint '{}'", text, key, s.joint));
    }
  }
  return s;
}

}  // namespace mjstepper::tools
