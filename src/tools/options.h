// The bounds of every numeric option of the mjstepper command, and the parsers of its compound
// values (speed lists, frame sizes, NAME=NUMBER items). One table: the command line's validators,
// its help, the README's table and the Python package's checks all come from kOptionRanges.
// No MuJoCo here (the command-line fuzzer builds it without).
#ifndef MJSTEPPER_TOOLS_OPTIONS_H_
#define MJSTEPPER_TOOLS_OPTIONS_H_

#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/attributes.h"  // Excerpt

namespace mjstepper::tools {

/// A closed range [lo, hi] in `unit`; `what` says what the option is, for the README's table.
struct OptionRange {
  const char* name;  ///< the key, e.g. "fps"; options named --NAME use it
  double lo, hi;
  const char* unit;
  const char* why;  ///< why the bound is where it is
};

/// Every range, each once; Range(name) finds one (throws std::logic_error for an unknown name).
std::span<const OptionRange> OptionRanges();
const OptionRange& Range(const std::string& name);

/// Throws std::invalid_argument "OPTION VALUE: must be in [lo, hi] unit" unless lo <= value <= hi
/// (NaN fails); `shown` is the text the user gave (default: the value).
void RequireInRange(const std::string& option, const OptionRange& range, double value,
                    const std::string& shown = "");

/// The most frames a run renders, the most runs a sweep or map makes, the most speeds a list
/// holds (more is a typing error, or hours of work nobody asked for).
inline constexpr double kMaxFrames = 1e6;
inline constexpr double kMaxRuns = 1e5;
/// The fewest timesteps a sweep's measured window holds: fewer would make a ripple and a frequency
/// out of a handful of samples.
inline constexpr int kMinMeasuredSteps = 100;

/// "10:200:2.5rpm" (from:to:step, inclusive), "50,100,150rpm", or one speed; units rpm, r/min,
/// rad/s. Every speed within Range("speed") and at most kMaxRuns of them. Throws
/// std::invalid_argument naming `option` and quoting the text.
/// With `at_carriage`, speeds may also be in mm/s or m/s (a linear axis's carriage, converted
/// with the stepper's rad per metre once its model is loaded): returned in m/s, and
/// *at_carriage says which.
std::vector<double> ParseSpeedList(const std::string& text, const std::string& option = "--speeds",
                                   bool* at_carriage = nullptr);

/// "WxH", two decimal integers each within Range("size"); throws naming --size.
void ParseSize(const std::string& text, int* width, int* height);

/// "NAME=NUMBER" items of a repeatable option, each NUMBER within `range`; throws naming the item.
std::map<std::string, double> NamedNumbers(const std::string& option, const char* form,
                                           const OptionRange& range,
                                           const std::vector<std::string>& items);

enum class JointQuantity { kPosition, kSpeed, kAcceleration };

/// "30,60deg" or "30deg,60deg" (a unit on the last applies to those without it): joint values in
/// SI (rad, rad/s, rad/s² on a hinge; m, m/s, m/s² on a slide: `linear`; unknown: either, the
/// command line's check before the model is loaded). Units: deg, rad, mm, m; deg/s, rad/s, rpm,
/// mm/s, m/s; deg/s², rad/s², mm/s², m/s² (also ^2). Every value finite and within ±1e7 (positions)
/// or ±1e4 per s (rates); `single`: exactly one value. Throws std::invalid_argument naming
/// `option`.
/// `was_linear`, when given, tells which the values were (they are one or the other).
std::vector<double> ParseJointValues(const std::string& option, const std::string& text,
                                     JointQuantity quantity, std::optional<bool> linear,
                                     bool single, bool* was_linear = nullptr);

/// The Markdown table of kOptionRanges for the README (`mjstepper tables`).
std::string OptionRangeTableMarkdown();

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_OPTIONS_H_
