// Configuration attributes: one spec per attribute (name, type, default, unit, meaning) and strict
// parsing of their text values. No MuJoCo here: values arrive through a callback, so a MuJoCo
// plugin, a test or a tool can feed them.
//
// Each attribute is declared once, next to the code that reads it: the drive's own attributes in
// plugin/config.cc, a controller's in its controller file. The parser, the list of names MuJoCo is
// told, and the README's attribute table are all made from those declarations.
#ifndef MJSTEPPER_CORE_ATTRIBUTES_H_
#define MJSTEPPER_CORE_ATTRIBUTES_H_

#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "core/motor_params.h"

namespace mjstepper {

struct AttributeSpec {
  const char* name;          ///< MJCF <config key=...>
  const char* type;          ///< real, integer, name, list
  const char* default_text;  ///< as documented (may say "preset")
  const char* unit;          ///< SI unit, or "—"
  const char* meaning;       ///< one paragraph, Markdown; cites SPEC / paper equations
};

/// A bad attribute value: the message is `name = "value": rule (unit)`.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// `text` as a message quotes it (issue 33: messages echoed a 100 MB argument, and a step file's
/// terminal escapes): whole up to 60 bytes, else its first 60 (not splitting a UTF-8 character)
/// and its length; control characters as \xNN.
std::string Excerpt(std::string_view text);

/// The most bytes of a whole error message as printed or raised.
inline constexpr size_t kMaxMessage = 2000;

/// A whole error message as the command prints it and the Python package raises it (issue 33):
/// at most kMaxMessage bytes, then its length, whatever a message quotes; control characters but
/// the newline as \xNN. The one bound behind every message, beside Excerpt's for a quoted value.
std::string BoundedMessage(std::string_view text);

/// Throws; the value is quoted as Excerpt quotes it.
[[noreturn]] void ThrowBad(const AttributeSpec& spec, const std::string& value,
                           const std::string& rule);

/// Strict number parsing: the whole string (surrounding blanks allowed) must be one finite number.
/// "48", "+48" and "4.8e1" pass; "", "48V", "nan", "inf", "4,8", "+-48", "++48" fail.
bool ParseFiniteDouble(const std::string& text, double* value);

std::string Trim(const std::string& s);

/// Reads attribute values by name: nullptr or "" when absent.
using AttributeReader = std::function<const char*(const char* name)>;

/// Typed, strict access to attribute values; every failure throws ConfigError naming the
/// attribute, quoting the value and stating the rule.
class AttributeSource {
 public:
  explicit AttributeSource(AttributeReader read) : read_(std::move(read)) {}

  /// The trimmed text, or nullopt when the attribute is not set.
  std::optional<std::string> Raw(const AttributeSpec& spec) const;

  /// Rules for numbers; each is written so that NaN fails it.
  enum class Rule { kPositive, kNonNegative, kAny };

  /// The number if set (checked against `rule`), else `fallback`.
  double Real(const AttributeSpec& spec, double fallback, Rule rule) const;
  /// The number if set, in [low, high], else `fallback`.
  double Real(const AttributeSpec& spec, double fallback, double low, double high) const;
  /// An integer in [low, high] if set, else `fallback`.
  int Integer(const AttributeSpec& spec, int fallback, int low, int high) const;
  /// One of `choices` if set, else `fallback`; the error lists the choices.
  std::string Choice(const AttributeSpec& spec, const std::string& fallback,
                     const std::vector<std::string>& choices) const;
  /// Detent-style harmonic triplets "order amplitude phase; ..." or "none".
  std::optional<std::vector<DetentHarmonic>> Harmonics(const AttributeSpec& spec) const;
  /// A list of numbers separated by blanks or commas, each in [low, high], at least `min_count`
  /// and at most `max_count` of them; nullopt when the attribute is not set.
  std::optional<std::vector<double>> Reals(const AttributeSpec& spec, double low, double high,
                                           int min_count, int max_count) const;

 private:
  AttributeReader read_;
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_ATTRIBUTES_H_
