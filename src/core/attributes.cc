#include "core/attributes.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>

namespace mjstepper {
namespace {

// The magnitudes a number attribute may have besides 0: products and quotients of a few of them
// then stay far inside the doubles' range, so no accepted config overflows the drive's arithmetic
// (the fuzzer, tests/fuzz, found R = 4e-269 Ω, L = 1e-320 H, Km = 2.5e185 N·m/A or kp = 1.7e308 V/A
// turning the drive's state to NaN in its first steps).
constexpr double kSmallestMagnitude = 1e-12;
constexpr double kLargestMagnitude = 1e12;
constexpr const char* kMagnitudeRule = "must be 0 or between 1e-12 and 1e12 in magnitude";

bool SaneMagnitude(double v) {
  return v == 0 || (std::abs(v) >= kSmallestMagnitude && std::abs(v) <= kLargestMagnitude);
}

}  // namespace

namespace {

// The first `limit` bytes of `text` (not splitting a UTF-8 character), then its length when cut;
// control characters as \xNN, but for newlines where `lines` allows them.
std::string Bounded(std::string_view text, size_t limit, bool lines) {
  size_t shown = std::min(text.size(), limit);
  while (shown < text.size() && shown > 0 &&
         (static_cast<unsigned char>(text[shown]) & 0xC0) == 0x80) {
    --shown;  // not inside a UTF-8 character
  }
  std::string out;
  out.reserve(shown + 16);
  for (const char c : text.substr(0, shown)) {
    const auto byte = static_cast<unsigned char>(c);
    if ((byte < 0x20 || byte == 0x7f) && !(lines && c == '\n')) {
      out += fmt::format("\\x{:02x}", byte);
    } else {
      out += c;
    }
  }
  if (shown < text.size()) out += fmt::format("… ({} characters)", text.size());
  return out;
}

}  // namespace

std::string Excerpt(std::string_view text) {
  constexpr size_t kShown = 60;  // bytes of a long text a message quotes
  return Bounded(text, kShown, /*lines=*/false);
}

std::string BoundedMessage(std::string_view text) {
  return Bounded(text, kMaxMessage, /*lines=*/true);
}

void ThrowBad(const AttributeSpec& spec, const std::string& value, const std::string& rule) {
  throw ConfigError(fmt::format("{} = \"{}\": {}", spec.name, Excerpt(value), rule));
}

std::string Trim(const std::string& s) {
  const size_t begin = s.find_first_not_of(" \t\n\r");
  if (begin == std::string::npos) return "";
  const size_t end = s.find_last_not_of(" \t\n\r");
  return s.substr(begin, end - begin + 1);
}

bool ParseFiniteDouble(const std::string& text, double* value) {
  const std::string t = Trim(text);
  if (t.empty()) return false;
  const char* begin = t.data();
  const char* end = t.data() + t.size();
  // from_chars rejects a leading '+': skip one, but then no second sign ("+-1" is no number).
  if (*begin == '+') {
    ++begin;
    if (begin == end || *begin == '-' || *begin == '+') return false;
  }
  const auto [ptr, ec] = std::from_chars(begin, end, *value);
  return ec == std::errc() && ptr == end && std::isfinite(*value);
}

std::optional<std::string> AttributeSource::Raw(const AttributeSpec& spec) const {
  const char* value = read_(spec.name);
  if (value == nullptr || value[0] == '\0') return std::nullopt;
  return Trim(value);
}

double AttributeSource::Real(const AttributeSpec& spec, double fallback, Rule rule) const {
  const std::optional<std::string> raw = Raw(spec);
  if (!raw) return fallback;
  double value = 0;
  if (!ParseFiniteDouble(*raw, &value)) {
    ThrowBad(spec, *raw, fmt::format("not a finite number; write e.g. 1.5 (unit: {})", spec.unit));
  }
  if (rule == Rule::kPositive && !(value > 0)) {
    ThrowBad(spec, *raw, fmt::format("must be > 0 ({})", spec.unit));
  }
  if (rule == Rule::kNonNegative && !(value >= 0)) {
    ThrowBad(spec, *raw, fmt::format("must be >= 0 ({})", spec.unit));
  }
  if (!SaneMagnitude(value)) {
    ThrowBad(spec, *raw, fmt::format("{} ({})", kMagnitudeRule, spec.unit));
  }
  return value;
}

double AttributeSource::Real(const AttributeSpec& spec, double fallback, double low,
                             double high) const {
  const std::optional<std::string> raw = Raw(spec);
  if (!raw) return fallback;
  const double value = Real(spec, fallback, Rule::kAny);
  if (!(value >= low && value <= high)) {
    ThrowBad(spec, *raw, fmt::format("must be in [{:g}, {:g}] ({})", low, high, spec.unit));
  }
  return value;
}

int AttributeSource::Integer(const AttributeSpec& spec, int fallback, int low, int high) const {
  const std::optional<std::string> raw = Raw(spec);
  if (!raw) return fallback;
  double value = 0;
  if (!ParseFiniteDouble(*raw, &value) || value != std::floor(value) || value < low ||
      value > high) {
    ThrowBad(spec, *raw, fmt::format("must be an integer in [{}, {}] ({})", low, high, spec.unit));
  }
  return static_cast<int>(value);
}

std::string AttributeSource::Choice(const AttributeSpec& spec, const std::string& fallback,
                                    const std::vector<std::string>& choices) const {
  const std::optional<std::string> raw = Raw(spec);
  if (!raw) return fallback;
  for (const std::string& c : choices) {
    if (*raw == c) return c;
  }
  ThrowBad(spec, *raw, fmt::format("must be one of: {}", fmt::join(choices, ", ")));
}

std::optional<std::vector<DetentHarmonic>> AttributeSource::Harmonics(
    const AttributeSpec& spec) const {
  const std::optional<std::string> raw = Raw(spec);
  if (!raw) return std::nullopt;
  if (*raw == "none") return std::vector<DetentHarmonic>{};
  const char* rule =
      "expected \"none\" or triplets \"order amplitude phase\" (-, N·m, rad) separated by "
      "';', e.g. \"4 0.006 0; 2 0.014 3.1416\"";
  std::vector<DetentHarmonic> harmonics;
  std::stringstream groups(*raw);
  std::string group;
  while (std::getline(groups, group, ';')) {
    std::stringstream fields(Trim(group));
    std::string field;
    std::vector<double> values;
    while (fields >> field) {
      double v = 0;
      if (!ParseFiniteDouble(field, &v)) ThrowBad(spec, *raw, rule);
      values.push_back(v);
    }
    if (values.size() != 3) ThrowBad(spec, *raw, rule);
    if (values[0] < 1 || values[0] != std::floor(values[0]) || values[0] > 1000) {
      ThrowBad(spec, *raw, "harmonic order must be an integer in [1, 1000]");
    }
    if (values[1] < 0) ThrowBad(spec, *raw, "amplitude must be >= 0 (N·m)");
    if (!SaneMagnitude(values[1]) || !SaneMagnitude(values[2])) {
      ThrowBad(spec, *raw, fmt::format("amplitude and phase {} (N·m, rad)", kMagnitudeRule));
    }
    harmonics.push_back(
        {.order = static_cast<int>(values[0]), .amplitude = values[1], .phase = values[2]});
  }
  if (harmonics.empty()) ThrowBad(spec, *raw, rule);
  return harmonics;
}

std::optional<std::vector<double>> AttributeSource::Reals(const AttributeSpec& spec, double low,
                                                          double high, int min_count,
                                                          int max_count) const {
  const std::optional<std::string> raw = Raw(spec);
  if (!raw) return std::nullopt;
  const std::string rule =
      fmt::format("expected {} to {} numbers in [{:g}, {:g}] separated by blanks or commas ({})",
                  min_count, max_count, low, high, spec.unit);
  std::string text = *raw;
  std::replace(text.begin(), text.end(), ',', ' ');
  std::stringstream fields(text);
  std::string field;
  std::vector<double> values;
  while (fields >> field) {
    double v = 0;
    if (!ParseFiniteDouble(field, &v) || !(v >= low && v <= high)) ThrowBad(spec, *raw, rule);
    values.push_back(v);
    if (static_cast<int>(values.size()) > max_count) ThrowBad(spec, *raw, rule);
  }
  if (static_cast<int>(values.size()) < min_count) ThrowBad(spec, *raw, rule);
  return values;
}

}  // namespace mjstepper
