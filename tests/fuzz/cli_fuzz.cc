// libFuzzer target over the mjstepper command line: every subcommand and option, through the very
// parser the command uses (src/tools/cli.h, CommandLine::Parse). Built by tests/fuzz/run.sh with
// clang, -fsanitize=fuzzer,address,undefined; no MuJoCo (parsing needs none).
//
// One input is decoded (FuzzedDataProvider) into an argument vector: a subcommand (one of the
// parser's own, now and then an unknown word), its model (a model of the repository, or bytes), and
// a few options: names from the subcommand's own option list (CLI::App::get_options, so a new
// option is fuzzed without touching this file; now and then an unknown one), values a number in
// some spelling (NaN, inf, 1e300, denormals, hex, signs doubled, trailing bytes), a speed list, a
// profile, a size, NAME=NUMBER, or raw bytes.
// Properties (a violation traps, so libFuzzer reports it with the input):
//   1. no crash, no sanitizer report; Parse throws only CLI::ParseError or std::invalid_argument;
//   2. a std::invalid_argument names an option ("--...");
//   3. an accepted command has every number within the bounds of src/tools/options.cc (the one
//      table the parser is meant to enforce): durations, frame rates, sizes, speeds, counts, ...;
//   4. parsing writes nothing (it may read the file system, never make a file or folder).
#include <fuzzer/FuzzedDataProvider.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "cli.h"
#include "core/command_profile.h"
#include "fuzz_common.h"

namespace {

using mjstepper::tools::Command;
using mjstepper::tools::CommandKind;
using mjstepper::tools::CommandLine;
using mjstepper::fuzz::Fail;
using mjstepper::tools::Range;

const char* const kNumbers[] = {
    "0",     "-0",     "1",        "-1",      "0.5",     "30",        "1e300",   "-1e300",
    "1e-300", "4.9e-324", "1.7976931348623157e308", "nan", "-nan", "inf", "-inf", "NaN",
    "infinity", "+-1", "--1", "0x10", "1e",    ".",       "1.",        " 5",      "5 ",
    "1e6",   "1e-6",   "1e12",     "100000",  "100001",  "2147483648", "-2147483649",
    "9223372036854775808", "1e-9", "0.01",   "60",      "1000",      "8192",    "16",
    "",      "abc",    "1,2",      "4 4"};
const char* const kUnits[] = {"rpm", "r/min", "rad/s", "rad", "deg", "s", "ms", "", "x", "rpmrpm"};

std::string Number(FuzzedDataProvider& in) {
  switch (in.ConsumeIntegralInRange(0, 3)) {
    case 0:
      return in.PickValueInArray(kNumbers);
    case 1: {
      char text[64];
      std::snprintf(text, sizeof(text), in.ConsumeBool() ? "%.17g" : "%g",
                    in.ConsumeFloatingPoint<double>());
      return text;
    }
    case 2:
      return std::to_string(in.ConsumeIntegral<long>());
    default:
      return in.ConsumeRandomLengthString(24);
  }
}

std::string SpeedList(FuzzedDataProvider& in) {
  const std::string unit = in.PickValueInArray(kUnits);
  if (in.ConsumeBool()) return Number(in) + ":" + Number(in) + ":" + Number(in) + unit;
  std::string list = Number(in);
  for (int k = in.ConsumeIntegralInRange(0, 4); k > 0; --k) list += "," + Number(in);
  return list + unit;
}

std::string Profile(FuzzedDataProvider& in) {
  const char* const kNames[] = {"constant", "ramp", "trapezoid", "step", ""};
  std::string text = std::string(in.PickValueInArray(kNames)) + "(";
  for (int k = in.ConsumeIntegralInRange(1, 4); k > 0; --k) {
    text += Number(in) + in.PickValueInArray(kUnits) + (k > 1 ? "," : "");
  }
  return text + (in.ConsumeBool() ? ")" : in.ConsumeRandomLengthString(4));
}

std::string Value(FuzzedDataProvider& in, const std::string& option) {
  // Mostly what the option expects, now and then anything.
  if (in.ConsumeIntegralInRange(0, 7) == 0) return in.ConsumeRandomLengthString(40);
  if (option == "--speeds") return SpeedList(in);
  if (option == "--ctrl") return "shaft=" + Profile(in);
  if (option == "--size") return Number(in) + "x" + Number(in);
  if (option == "--mass" || option == "--load") return "payload=" + Number(in);
  if (option == "--vary") {
    std::string text = in.ConsumeBool() ? "stiffness:coupling=" : "mass:load=";
    for (int k = in.ConsumeIntegralInRange(0, 3); k >= 0; --k) text += Number(in) + ",";
    return text.substr(0, text.size() - 1);
  }
  if (option == "--set") return "shaft." + in.ConsumeRandomLengthString(12) + "=" + Number(in);
  if (option == "--log" || option == "--render" || option == "--frames" || option == "--out" ||
      option == "--plot") {
    // Paths that are never made: parsing writes nothing (property 4).
    const char* const kPaths[] = {"/nonexistent/fuzz/a", "/nonexistent/fuzz/./a",
                                  "/nonexistent/fuzz/b/../a", "/dev/null", "/"};
    return in.ConsumeBool() ? in.PickValueInArray(kPaths)
                            : "/nonexistent/fuzz/" + in.ConsumeRandomLengthString(12);
  }
  return Number(in);
}

bool In(const char* name, double value) {
  return value >= Range(name).lo && value <= Range(name).hi;
}

void Check(bool ok, const char* what, const std::vector<std::string>& argv) {
  if (ok) return;
  std::string line;
  for (const std::string& a : argv) line += "[" + a + "] ";
  Fail(what, line);
}

// Property 3: the numbers of an accepted command.
void CheckAccepted(const Command& c, const std::vector<std::string>& argv) {
  auto speeds_ok = [](const std::vector<double>& speeds) {
    if (!In("speeds", static_cast<double>(speeds.size()))) return false;
    for (double s : speeds) {
      if (!In("speed", s)) return false;
    }
    return true;
  };
  switch (c.kind) {
    case CommandKind::kRun: {
      const auto& r = c.run;
      Check(In("duration", r.duration), "run: duration out of range", argv);
      Check(In("log-every", r.log_every), "run: log-every out of range", argv);
      Check(In("fps", r.render.fps) && In("playback", r.render.playback),
            "run: fps or playback out of range", argv);
      Check(In("size", r.render.renderer.width) && In("size", r.render.renderer.height),
            "run: size out of range", argv);
      if (r.render.enabled()) {
        Check(r.duration * r.render.fps / r.render.playback <= Range("frames").hi,
              "run: too many frames", argv);
      }
      for (const auto& [name, kg] : r.masses) Check(In("mass", kg), "run: mass out of range", argv);
      for (const auto& [name, t] : r.loads) Check(In("load", t), "run: load out of range", argv);
      for (const auto& [name, text] : r.ctrl) {
        try {
          mjstepper::CommandProfile::Parse(text);
        } catch (const std::invalid_argument&) {
          Check(false, "run: an accepted --ctrl profile does not parse", argv);
        }
      }
      break;
    }
    case CommandKind::kSweep:
    case CommandKind::kMap: {
      const auto& s = c.kind == CommandKind::kSweep ? c.sweep : c.map.sweep;
      Check(speeds_ok(s.speeds), "sweep: speeds out of range", argv);
      Check(In("settle", s.settle) && In("measure", s.measure), "sweep: timing out of range",
            argv);
      Check(In("threads", s.threads), "sweep: threads out of range", argv);
      if (c.kind == CommandKind::kMap) {
        Check(!c.map.values.empty() &&
                  In("speeds", static_cast<double>(c.map.values.size() * s.speeds.size())),
              "map: no value, or too many runs", argv);
        const std::string kind = c.map.parameter.substr(0, c.map.parameter.find(':'));
        for (double v : c.map.values) {
          Check((kind == "stiffness" || kind == "mass") && In(kind.c_str(), v),
                "map: a value out of range", argv);
        }
      }
      break;
    }
    case CommandKind::kPullOut: {
      const auto& p = c.pullout;
      Check(speeds_ok(p.speeds), "pullout: speeds out of range", argv);
      Check(In("rate", p.rate) && In("max-torque", p.max_torque) &&
                p.max_torque / p.rate <= 1000,
            "pullout: rate or max torque out of range", argv);
      Check(In("threads", p.threads), "pullout: threads out of range", argv);
      break;
    }
    case CommandKind::kIdentify:
      Check(speeds_ok(c.identify.speeds), "identify: speeds out of range", argv);
      for (int order : c.identify.orders) {
        Check(In("orders", order), "identify: an order out of range", argv);
      }
      break;
    default:
      break;
  }
}

}  // namespace

const char* const mjstepper::fuzz::kTargetName = "cli_fuzz";

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  CommandLine cli;
  std::vector<CLI::App*> subcommands = cli.app().get_subcommands([](CLI::App*) { return true; });
  std::vector<std::string> argv = {"mjstepper"};
  CLI::App* sub = nullptr;
  if (in.ConsumeIntegralInRange(0, 15) == 0) {
    argv.push_back(in.ConsumeRandomLengthString(12));
  } else {
    sub = subcommands[in.ConsumeIntegralInRange<std::size_t>(0, subcommands.size() - 1)];
    argv.push_back(sub->get_name());
    // The positional argument (an existing model or CSV), mostly.
    if (sub->get_name() != "tables" && in.ConsumeIntegralInRange(0, 7) != 0) {
      argv.push_back(sub->get_name() == "plot" ? MJSTEPPER_SOURCE_DIR "/README.md"
                                                 : MJSTEPPER_SOURCE_DIR "/models/tsui_rigid.xml");
    }
  }
  for (int k = in.ConsumeIntegralInRange(0, 8); k > 0 && in.remaining_bytes() > 0; --k) {
    std::string name;
    if (sub != nullptr && in.ConsumeIntegralInRange(0, 9) != 0) {
      const std::vector<CLI::Option*> options = sub->get_options();
      const CLI::Option* option =
          options[in.ConsumeIntegralInRange<std::size_t>(0, options.size() - 1)];
      if (option->get_lnames().empty()) continue;  // a positional: given above
      name = "--" + option->get_lnames().front();
      if (option->get_type_size() == 0) {  // a flag
        argv.push_back(name);
        continue;
      }
    } else {
      name = "--" + in.ConsumeRandomLengthString(10);
    }
    const std::string value = Value(in, name);
    if (in.ConsumeIntegralInRange(0, 4) == 0) {
      argv.push_back(name + "=" + value);
    } else {
      argv.push_back(name);
      argv.push_back(value);
    }
  }

  std::vector<const char*> raw;
  for (const std::string& a : argv) raw.push_back(a.c_str());
  try {
    const Command& c = cli.Parse(static_cast<int>(raw.size()), raw.data());
    CheckAccepted(c, argv);
  } catch (const CLI::ParseError&) {
    // CLI11's own errors (unknown option, a validator's bound, --help): printed by the command.
  } catch (const std::invalid_argument& e) {
    Check(std::string(e.what()).find("--") != std::string::npos,
          "an error that names no option", argv);
  } catch (const std::exception& e) {
    Fail("Parse threw neither CLI::ParseError nor std::invalid_argument", e.what());
  }
  Check(!std::filesystem::exists("/nonexistent"), "parsing made a folder", argv);
  return 0;
}
