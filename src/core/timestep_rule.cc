#include "core/timestep_rule.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "core/units.h"

namespace mjstepper {
namespace {

// The double nearest mantissa·10^exponent (mantissa 100..999), as printing and reading it give.
double Decimal(long mantissa, int exponent) {
  return std::strtod(fmt::format("{}e{}", mantissa, exponent).c_str(), nullptr);
}

}  // namespace

bool PassesMode(double omega, double timestep, double max_omega_h) {
  return timestep <= max_omega_h / omega;
}

double RoundDown3(double x) {
  if (!(x > 0) || std::isinf(x)) return x;
  int exponent = static_cast<int>(std::floor(std::log10(x))) - 2;
  long mantissa = std::lround(std::floor(x / std::pow(10.0, exponent)));
  // log10 and the division may be off by one unit either way: settle on the largest <= x.
  if (mantissa >= 1000) mantissa /= 10, ++exponent;
  if (mantissa < 100) mantissa = mantissa * 10 + 9, --exponent;
  while (Decimal(mantissa, exponent) > x) {
    if (--mantissa < 100) mantissa = 999, --exponent;
  }
  while (true) {
    long up = mantissa + 1;
    int up_exponent = exponent;
    if (up >= 1000) up = 100, ++up_exponent;
    if (Decimal(up, up_exponent) > x) break;
    mantissa = up, exponent = up_exponent;
  }
  return Decimal(mantissa, exponent);
}

std::string FormatOmegaH(double omega_h, double limit) {
  for (int digits = 3; digits < 17; ++digits) {
    const std::string text = fmt::format("{:.{}g}", omega_h, digits);
    if (omega_h == limit || text != fmt::format("{:.{}g}", limit, digits)) return text;
  }
  return fmt::format("{}", omega_h);
}

bool TimestepVerdict::refuse() const {
  return std::any_of(failed.begin(), failed.end(), [](const FailedCheck& c) { return c.stepper; });
}

TimestepVerdict JudgeTimestep(const std::vector<RuleMode>& modes, double timestep,
                              double max_omega_h) {
  TimestepVerdict v;
  v.timestep = timestep;
  v.max_omega_h = max_omega_h;
  v.largest_timestep = std::numeric_limits<double>::infinity();
  for (const RuleMode& mode : modes) {
    if (!(mode.omega > 0)) continue;
    const double largest = max_omega_h / mode.omega;  // s
    v.largest_timestep = std::min(v.largest_timestep, largest);
    if (!PassesMode(mode.omega, timestep, max_omega_h)) {
      v.failed.push_back({.name = mode.name,
                          .frequency = mode.omega / kTwoPi,
                          .omega_h = mode.omega * timestep,
                          .largest_timestep = largest,
                          .stepper = mode.stepper});
    }
  }
  std::stable_sort(v.failed.begin(), v.failed.end(),
                   [](const FailedCheck& a, const FailedCheck& b) {
                     return a.stepper != b.stepper ? a.stepper : a.frequency > b.frequency;
                   });
  v.suggestion = RoundDown3(v.largest_timestep);
  return v;
}

std::string TimestepVerdict::Message(const std::string& subject,
                                     const std::string& separator) const {
  if (failed.empty()) return "";
  std::string text = fmt::format(
      "{}: timestep {:g} s is too coarse for {} mode(s) (ω·h <= {:g} each, with each stepper's T' "
      "plus its detent's worst case Σ h·Nr·Kdh)",
      subject, timestep, failed.size(), max_omega_h);
  for (const FailedCheck& c : failed) {
    text += fmt::format("{}{}{}: {:.1f} Hz, ω·h = {} > {:g}, its largest timestep {:.3g} s",
                        separator, c.stepper ? "" : "non-stepper ", c.name, c.frequency,
                        FormatOmegaH(c.omega_h, max_omega_h), max_omega_h,
                        RoundDown3(c.largest_timestep));
  }
  text += fmt::format("{}use timestep <= {:.3g} s (passes every mode)", separator, suggestion);
  if (ringing_timestep < suggestion) {
    text += fmt::format(
        "{}after a move with STEP/DIR input, timestep <= {:.3g} s keeps its ringing within 5 % "
        "of a fine reference (ω·h <= {:g} on the fastest stepper mode, {:.1f} Hz)",
        separator, ringing_timestep, kRingingOmegaTimesStep, ringing_frequency);
  }
  if (!refuse()) {
    text +=
        "; no stepper takes part in these modes, so the model's own springs decide (not "
        "refused)";
  }
  return text;
}

std::string TimestepVerdict::Summary(const std::string& subject) const {
  if (failed.empty()) return "";
  const FailedCheck& worst = *std::max_element(
      failed.begin(), failed.end(),
      [](const FailedCheck& a, const FailedCheck& b) { return a.omega_h < b.omega_h; });
  return fmt::format(
      "{}: timestep {:g} s is too coarse for {} mode(s) (ω·h <= {:g} each; the fastest, {}, "
      "{:.1f} Hz, ω·h = {}): use timestep <= {:.3g} s{}{} (`mjstepper info` lists every mode)",
      subject, timestep, failed.size(), max_omega_h, worst.name, worst.frequency,
      FormatOmegaH(worst.omega_h, max_omega_h), suggestion,
      ringing_timestep < suggestion
          ? fmt::format(", <= {:.3g} s for a move's ringing with STEP/DIR input", ringing_timestep)
          : "",
      refuse() ? "" : "; no stepper takes part in these modes (not refused)");
}

void JudgeRinging(TimestepVerdict* v, double fastest_stepper_omega) {
  if (!(fastest_stepper_omega > 0)) return;
  v->ringing_timestep = RoundDown3(kRingingOmegaTimesStep / fastest_stepper_omega);
  v->ringing_frequency = fastest_stepper_omega / kTwoPi;
}

std::string TimestepVerdict::RingingNote(const std::string& subject) const {
  if (!ringing_exceeded()) return "";
  return fmt::format(
      "{}: after a move with STEP/DIR input, timestep {:g} s (ω·h = {:.3g} on the fastest stepper "
      "mode, {:.1f} Hz) may leave its ringing more than 5 % off a fine reference's; timestep <= "
      "{:.3g} s (ω·h <= {:g}) keeps it within 5 % where the ringing is a small remainder of the "
      "move's kicks (the CoreXY's), while a larger ringing (the bed-slinger's Y move) holds to "
      "ω·h = {:g} (docs/coupling.md, \"The CoreXY's ringing against the step grid\")",
      subject, timestep, kTwoPi * ringing_frequency * timestep, ringing_frequency, ringing_timestep,
      kRingingOmegaTimesStep, kRingingOmegaTimesStepLargeRing);
}

}  // namespace mjstepper
