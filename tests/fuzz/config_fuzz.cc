// libFuzzer target over the stepper plugin's <config> attributes (plugin/config.h) and the
// `--ctrl ACTUATOR=PROFILE` grammar (core/command_profile.h). Built by tests/fuzz/run.sh with
// clang, -fsanitize=fuzzer,address,undefined; no MuJoCo.
//
// One input is decoded (FuzzedDataProvider) into
//   - a few attribute key/value pairs: keys from AttributeNames() (now and then an unknown one),
//     values a known word, a number in some spelling, a harmonic list, or raw bytes;
//   - a profile text, from the grammar's pieces or raw bytes: constant, ramp, trapezoid,
//     targets(…) (now and then beyond its bound of targets), steps(FILE) and shaped(…) nested to
//     six levels (two beyond its bound), FILE a step file written from the input (times, signs,
//     comments, garbage) or a path that is no regular file (issue 33: the new surfaces);
//   - a timestep, a rotor start angle and speed, and a command.
// Properties (a violation traps, so libFuzzer reports it with the input):
//   1. no crash, no sanitizer report, no exception escaping either parser;
//   2. the config parser asks only for names in AttributeNames();
//   3. a config rejection reads `name = "value": rule`, `name` an attribute, `value` the text given
//      for it (trimmed, or the same number respelled) or, when it was not given, its default;
//   4. a profile rejection is std::invalid_argument with a non-empty message of at most 1000
//      bytes quoting the profile (or, for a step file's own error, naming the file);
//   5. an accepted config builds a Drive, and unless the plugin would refuse it (more than
//      kMaxInterruptsPerStep interrupts per timestep, core/drive.h), resting and advancing it
//      five timesteps with the command the plugin gives (Drive::CommandFrom) leaves every state
//      double, the torque and the signals finite.
#include <fuzzer/FuzzedDataProvider.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "config.h"
#include "core/command_profile.h"
#include "core/drive.h"
#include "core/signals.h"
#include "fuzz_common.h"

const char* const mjstepper::fuzz::kTargetName = "config_fuzz";

namespace {

using mjstepper::CommandProfile;
using mjstepper::Drive;
using mjstepper::DriveConfig;
using mjstepper::DriveCoreState;
using mjstepper::DriveState;
using mjstepper::InputMode;
using mjstepper::fuzz::AllFinite;
using mjstepper::fuzz::ConsumeAttributes;
using mjstepper::fuzz::ConsumeNumber;
using mjstepper::fuzz::Describe;
using mjstepper::fuzz::Fail;
using mjstepper::fuzz::FormatNumber;
using mjstepper::fuzz::NonFinite;
using mjstepper::plugin::AttributeNames;
using mjstepper::plugin::AttributeTable;
using mjstepper::plugin::ParseStepperConfig;
using mjstepper::plugin::StepperConfig;

constexpr const char* kProfileNames[] = {"constant", "ramp", "trapezoid", "", "Ramp", "const"};
constexpr const char* kUnits[] = {"rpm", "r/min", "rad/s", "rad", "deg",
                                  "s",   "ms",    "",      "m",   " rpm"};

constexpr const char* kShapers[] = {"zv",       "mzv", "zvd", "ei",  "2hump_ei",
                                    "3hump_ei", "ZV",  "",    "zvdd"};
constexpr const char* kSpecialStepFiles[] = {
    "/dev/zero", "/proc/self/mem", "/nonexistent/steps", "/tmp", "", "/dev/null"};

// The scratch step file steps(…) names, in a folder of its own made once and removed at exit.
const std::string& StepFilePath() {
  static const std::string path = [] {
    static char dir[] = "/tmp/mjstepper_config_fuzz_XXXXXX";
    const char* made = mkdtemp(dir);
    if (made == nullptr) Fail("cannot make a scratch folder", dir);
    std::atexit([] {
      std::error_code ignored;
      std::filesystem::remove_all(dir, ignored);
    });
    return std::string(made) + "/steps.txt";
  }();
  return path;
}

// A step file's text (step_times.h): rising times, some with a direction, comments, blank lines,
// any number, garbage; LF or CRLF.
std::string ConsumeStepFileText(FuzzedDataProvider& in) {
  std::string text;
  double t = 0;  // s
  const int lines = in.ConsumeIntegralInRange<int>(0, 24);
  for (int i = 0; i < lines; ++i) {
    switch (in.ConsumeIntegralInRange<int>(0, 6)) {
      case 0:
      case 1:
        t += in.ConsumeFloatingPointInRange<double>(0.0, 0.01);
        text += FormatNumber(in, t);
        break;
      case 2:
        t += in.ConsumeFloatingPointInRange<double>(0.0, 0.01);
        text += FormatNumber(in, t) + (in.ConsumeBool() ? " -1" : in.ConsumeBool() ? " +1" : " 2");
        break;
      case 3:
        text += "# a comment";
        break;
      case 4:
        break;  // blank
      case 5:
        text += FormatNumber(in, ConsumeNumber(in));
        break;
      default:
        text += in.ConsumeRandomLengthString(16);
    }
    text += in.ConsumeIntegralInRange<int>(0, 7) == 0 ? "\r\n" : "\n";
  }
  return text;
}

std::string ConsumeProfileText(FuzzedDataProvider& in, int depth = 0) {
  const int kind = in.ConsumeIntegralInRange<int>(0, 11);
  if (kind == 0) return in.ConsumeRandomLengthString(64);
  if (kind <= 2 && depth < 6) {  // shaped(PROFILE, TYPE F Hz [ζ])
    std::string text = "shaped(" + ConsumeProfileText(in, depth + 1) + ", " +
                       in.PickValueInArray(kShapers) + " " + FormatNumber(in, ConsumeNumber(in)) +
                       (in.ConsumeBool() ? "Hz" : "");
    if (in.ConsumeBool()) text += " " + FormatNumber(in, ConsumeNumber(in));
    return text + (in.ConsumeIntegralInRange<int>(0, 15) != 0 ? ")" : "");
  }
  if (kind == 3) {  // targets(ANGLE[@TIME], ...), now and then beyond kMaxTargets
    const bool many = in.ConsumeIntegralInRange<int>(0, 31) == 0;
    const int count =
        many ? static_cast<int>(mjstepper::kMaxTargets) + in.ConsumeIntegralInRange<int>(-1, 1)
             : in.ConsumeIntegralInRange<int>(0, 8);
    std::string text = "targets(";
    for (int i = 0; i < count; ++i) {
      if (i > 0) text += ",";
      if (many) {
        text += "0rad";
        continue;
      }
      text += FormatNumber(in, ConsumeNumber(in)) + in.PickValueInArray(kUnits);
      if (in.ConsumeBool())
        text += "@" + FormatNumber(in, ConsumeNumber(in)) + in.PickValueInArray(kUnits);
    }
    return text + ")";
  }
  if (kind == 4) {  // steps(FILE): a file written now, or a path that is no regular file
    std::string path = in.PickValueInArray(kSpecialStepFiles);
    if (in.ConsumeIntegralInRange<int>(0, 3) != 0) {
      path = StepFilePath();
      std::FILE* f = std::fopen(path.c_str(), "wb");
      if (f == nullptr) Fail("cannot write the scratch step file", path);
      const std::string text = ConsumeStepFileText(in);
      std::fwrite(text.data(), 1, text.size(), f);
      std::fclose(f);
    }
    return "steps(" + path + ")";
  }
  std::string text = in.PickValueInArray(kProfileNames);
  if (in.ConsumeIntegralInRange<int>(0, 15) != 0) text += '(';
  const int args = in.ConsumeIntegralInRange<int>(0, 5);
  for (int i = 0; i < args; ++i) {
    if (i > 0) text += in.ConsumeBool() ? ", " : ",";
    text += FormatNumber(in, ConsumeNumber(in));
    text += in.PickValueInArray(kUnits);
  }
  if (in.ConsumeIntegralInRange<int>(0, 15) != 0) text += ')';
  if (in.ConsumeIntegralInRange<int>(0, 15) == 0) text += in.ConsumeRandomLengthString(8);
  return text;
}

// Property 3: a rejection names the attribute and quotes its value (Excerpt) or its default.
// `given`: what the reader returned for each name (NUL ends a value, as in C).
void CheckRejection(const std::string& message, const std::map<std::string, std::string>& given) {
  const std::string context = "message: " + message + "\n" + Describe(given);
  const size_t eq = message.find(" = \"");
  if (eq == std::string::npos)
    Fail("config rejection not of the form name = \"value\": rule", context);
  const std::string name = message.substr(0, eq);
  const mjstepper::AttributeSpec* spec = nullptr;
  for (const mjstepper::AttributeSpec* s : AttributeTable()) {
    if (name == s->name) spec = s;
  }
  if (spec == nullptr) Fail("config rejection names no attribute", context);
  const std::string rest = message.substr(eq + 4);
  const auto it = given.find(name);
  // Given means a non-empty C string (AttributeSource::Raw); the parser quotes it trimmed.
  const bool was_given = it != given.end() && it->second.c_str()[0] != '\0';
  const std::string value = was_given ? mjstepper::Trim(it->second.c_str()) : "";
  if (!was_given) {
    // Not given: the rule is about this attribute's default, quoted as documented or as the
    // number it came to (voltage_amplitude's R·I_rated, say).
    const std::string expected = std::string(spec->default_text) + "\": ";
    const size_t close = rest.find("\": ");
    double quoted = 0;
    if (rest.compare(0, expected.size(), expected) != 0 &&
        !(close != std::string::npos &&
          mjstepper::ParseFiniteDouble(rest.substr(0, close), &quoted))) {
      Fail("config rejection of an attribute not given quotes neither its default nor a number",
           context);
    }
    return;
  }
  // Quoted as a bounded excerpt with its control characters escaped (issue 33).
  const std::string shown = mjstepper::Excerpt(value);
  if (rest.compare(0, shown.size() + 3, shown + "\": ") == 0) return;
  // The value respelled as a number (e.g. "5.0" quoted as "5")?
  const size_t close = rest.find("\": ");
  double quoted = 0, written = 0;
  if (close != std::string::npos && mjstepper::ParseFiniteDouble(rest.substr(0, close), &quoted) &&
      mjstepper::ParseFiniteDouble(value, &written) && quoted == written) {
    return;
  }
  Fail("config rejection does not quote the value given", context);
}

void CheckProfile(const std::string& text, std::optional<double> rad_per_metre) {
  try {
    const CommandProfile profile = CommandProfile::Parse(text, rad_per_metre);
    // Exercised for UB only: an absurd accepted profile may overflow to inf (the plugin then
    // holds).
    for (double t : {-1.0, 0.0, 1e-4, 0.3, 1.0, 1e3}) {
      (void)profile.Speed(t);
      (void)profile.Angle(t);
      (void)profile.ControlForStep(t, 1e-3, InputMode::kVelocity, 0.0);
      (void)profile.ControlForStep(t, 1e-3, InputMode::kPosition, 0.0);
    }
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    if (message.empty()) Fail("empty profile rejection", "profile: " + text);
    // A step file's own error names the file (step_times.h: "FILE:LINE: rule", "FILE: not a
    // regular file"), quoted as Excerpt quotes it.
    const size_t steps = text.find("steps(");
    const std::string file =
        steps == std::string::npos
            ? ""
            : text.substr(steps + 6,
                          text.find(')', steps) - std::min(text.find(')', steps), steps + 6));
    const bool names_file =
        steps != std::string::npos && message.rfind(mjstepper::Excerpt(file), 0) == 0;
    if (message.rfind("profile \"", 0) != 0 && !names_file) {
      Fail("profile rejection does not quote the profile",
           "profile: " + text + "\nmessage: " + message);
    }
    if (message.size() > 1000) {  // every quote an Excerpt (issue 33)
      Fail("profile rejection of more than 1000 bytes", "profile: " + text.substr(0, 200));
    }
  }
}

void CheckDrive(const StepperConfig& config, FuzzedDataProvider& in,
                const std::string& profile_text, const std::map<std::string, std::string>& given) {
  constexpr double kTimesteps[] = {50e-6, 1e-3, 2e-3, 10e-6, 1e-6, 0.01};
  const double h = in.PickValueInArray(kTimesteps);                   // s
  if (!mjstepper::InterruptsFit(h, config.drive.isr_period)) return;  // the plugin refuses it
  const double theta0 = in.ConsumeFloatingPointInRange<double>(-100.0, 100.0);   // rad
  const double omega = in.ConsumeFloatingPointInRange<double>(-1000.0, 1000.0);  // rad/s
  const double ctrl = in.ConsumeFloatingPointInRange<double>(-1000.0, 1000.0);   // rad or rad/s
  std::optional<CommandProfile> profile;
  try {
    profile = CommandProfile::Parse(profile_text);
  } catch (const std::invalid_argument&) {
  }

  const Drive drive(config.drive);  // the parser validated it: this must not throw
  const int stored = drive.layout().controller + drive.layout().profile;
  const DriveConfig& c = drive.config();
  auto context = [&](int step) {
    char line[256];
    std::snprintf(line, sizeof line,
                  "h = %.17g, theta0 = %.17g, omega = %.17g, ctrl = %.17g, "
                  "step %d\nprofile: ",
                  h, theta0, omega, ctrl, step);
    return line + profile_text + "\n" + Describe(given);
  };
  auto check = [&](const DriveState& s, double theta, int step) {
    if (!AllFinite(reinterpret_cast<const double*>(static_cast<const DriveCoreState*>(&s)),
                   sizeof(DriveCoreState) / sizeof(double)) ||
        !AllFinite(s.unit.data(), stored)) {
      Fail("non-finite drive state from an accepted config",
           context(step) + "\n" + NonFinite(s, stored));
    }
    if (!std::isfinite(drive.Torque(s, theta))) {
      Fail("non-finite torque from an accepted config", context(step));
    }
    const auto signals = mjstepper::SignalValues(drive.Signals(s, theta));
    if (!AllFinite(signals.data(), static_cast<int>(signals.size()))) {
      Fail("non-finite signal from an accepted config", context(step));
    }
  };

  // The command of a step: the profile's (as the runner gives it), else the fuzzed ctrl.
  auto ctrl_at = [&](double t) {
    return profile ? profile->ControlForStep(t, h, c.input, theta0) : ctrl;
  };
  DriveState state = drive.Rest(0.0, theta0, drive.CommandFrom(ctrl_at(0.0), nullptr, theta0));
  check(state, theta0, 0);
  double theta = theta0;
  for (int step = 1; step <= 5; ++step) {
    const double t0 = (step - 1) * h;
    const double t1 = step * h;
    const double command = drive.CommandFrom(ctrl_at(t0), &state, theta);
    theta = theta0 + omega * t1;
    drive.Advance(&state, t0, t1, theta, command);
    check(state, theta, step);
    // The stored form the plugin keeps between steps.
    std::array<double, sizeof(DriveState) / sizeof(double)> values{};
    drive.Store(state, values.data());
    state = drive.Load(values.data());
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider in(data, size);
  const std::vector<const char*>& names = AttributeNames();

  const std::map<std::string, std::string> attributes = ConsumeAttributes(in, names);
  const std::string profile_text = ConsumeProfileText(in);

  // Property 2 and the reader MuJoCo gives: the value's C string, or nullptr.
  auto read = [&](const char* name) -> const char* {
    bool known = false;
    for (const char* n : names) known = known || std::strcmp(n, name) == 0;
    if (!known) Fail("the parser read a name not in AttributeNames()", name);
    const auto it = attributes.find(name);
    return it == attributes.end() ? nullptr : it->second.c_str();
  };
  // Only what the parser can see: an unknown key is MuJoCo's to refuse.
  std::map<std::string, std::string> given;
  for (const auto& [key, value] : attributes) {
    if (key.rfind("unknown_", 0) != 0) given[key] = value;
  }

  const std::variant<StepperConfig, std::string> parsed = ParseStepperConfig(read);
  if (const std::string* error = std::get_if<std::string>(&parsed)) {
    CheckRejection(*error, given);
  }
  // A hinge (no linear units), a capstan's 157.08 rad/m and an extreme negative gear.
  for (const std::optional<double> rad_per_metre :
       {std::optional<double>(), std::optional(157.08), std::optional(-1e6)}) {
    CheckProfile(profile_text, rad_per_metre);
  }
  if (const StepperConfig* config = std::get_if<StepperConfig>(&parsed)) {
    CheckDrive(*config, in, profile_text, given);
  }
  return 0;
}
