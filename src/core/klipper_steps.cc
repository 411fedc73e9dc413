#include "core/klipper_steps.h"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string_view>

namespace mjstepper {
namespace {

// The largest parsedump text and map file ReadKlipperSteps opens.
constexpr std::uintmax_t kMaxKlipperDumpBytes = 100 * kMaxKlipperDumpLines;
constexpr std::uintmax_t kMaxKlipperMapBytes = 1 << 20;
constexpr std::size_t kMaxLine = 4096;

// A line quoted in a message: at most 60 characters, control characters as '?'.
std::string Quote(std::string_view line) {
  std::string out(line.substr(0, 60));
  for (char& c : out) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  }
  return line.size() > 60 ? out + "…" : out;
}

[[noreturn]] void Bad(const std::string& source, long line_number, std::string_view line,
                      const std::string& what) {
  throw std::invalid_argument(
      fmt::format("{}:{}: {} (\"{}\")", source, line_number, what, Quote(line)));
}

// The integer value of field `name=` among a command's words, within [lo, hi].
std::int64_t Field(const std::vector<std::string_view>& words, std::string_view name,
                   std::int64_t lo, std::int64_t hi, const std::string& source, long n,
                   std::string_view line) {
  for (std::string_view w : words) {
    if (w.size() <= name.size() || w.substr(0, name.size()) != name || w[name.size()] != '=') {
      continue;
    }
    const std::string_view text = w.substr(name.size() + 1);
    std::int64_t value = 0;
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (error != std::errc() || end != text.data() + text.size() || value < lo || value > hi) {
      Bad(source, n, line, fmt::format("{} must be an integer in [{}, {}]", name, lo, hi));
    }
    return value;
  }
  Bad(source, n, line, fmt::format("no {}=", name));
}

std::vector<std::string_view> Words(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

// Reads a line of at most kMaxLine characters into `line`; false at the end. A longer line is
// refused without reading further.
bool GetLine(std::istream& in, std::string* line, const std::string& source, long n) {
  line->clear();
  char c;
  bool any = false;
  while (in.get(c)) {
    any = true;
    if (c == '\n') return true;
    if (line->size() >= kMaxLine) {
      Bad(source, n, *line, fmt::format("a line longer than {} characters", kMaxLine));
    }
    line->push_back(c);
  }
  return any;
}

}  // namespace

std::map<int, KlipperStepper> ParseKlipperDump(std::istream& in, const std::string& source) {
  constexpr std::int64_t kU32 = std::numeric_limits<std::uint32_t>::max();
  constexpr std::int64_t kWrap = std::int64_t{1} << 32;
  struct State {
    KlipperStepper steps;
    std::int64_t last = 0;  // ticks, T: the last step's time (unwrapped)
    double direction = -1;  // the latched direction (Klipper's dir=0 until set)
  };
  std::map<int, State> steppers;
  std::string line;
  long n = 0;
  while (GetLine(in, &line, source, n + 1)) {
    if (++n > static_cast<long>(kMaxKlipperDumpLines)) {
      Bad(source, n, line, fmt::format("more than {} lines", kMaxKlipperDumpLines));
    }
    const std::vector<std::string_view> words = Words(line);
    if (words.empty()) continue;
    const std::string_view command = words[0];
    const bool known = command == "config_stepper" || command == "queue_step" ||
                       command == "set_next_step_dir" || command == "reset_step_clock";
    if (!known) continue;  // other commands (pins, endstops, …) do not step
    const int oid = static_cast<int>(Field(words, "oid", 0, 255, source, n, line));
    if (command == "config_stepper") {
      steppers[oid] = State{};
      continue;
    }
    const auto it = steppers.find(oid);
    if (it == steppers.end()) {
      Bad(source, n, line, fmt::format("oid {} is no stepper (no config_stepper before)", oid));
    }
    State& s = it->second;
    if (command == "set_next_step_dir") {
      s.direction = Field(words, "dir", 0, 1, source, n, line) == 1 ? 1.0 : -1.0;
    } else if (command == "reset_step_clock") {
      // The MCU's clock is 32 bits: the time nearest T − 2^31 or later with these low bits.
      const std::int64_t low = Field(words, "clock", 0, kU32, source, n, line);
      const std::int64_t from = s.last - kWrap / 2;
      std::int64_t t = from - (((from % kWrap) + kWrap) % kWrap) + low;
      if (t < from) t += kWrap;
      s.last = t;
    } else {  // queue_step
      const std::int64_t interval = Field(words, "interval", 0, kU32, source, n, line);
      const std::int64_t count = Field(words, "count", 1, 65535, source, n, line);
      const std::int64_t add = Field(words, "add", -32768, 32767, source, n, line);
      if (s.steps.clocks.size() + static_cast<std::size_t>(count) > kMaxStepTimes) {
        Bad(source, n, line, fmt::format("oid {} steps more than {} times", oid, kMaxStepTimes));
      }
      std::int64_t step = interval;  // ticks: this step's interval
      for (std::int64_t k = 0; k < count; ++k) {
        if (step < 0) Bad(source, n, line, "the steps' interval falls below 0 (add too negative)");
        s.last += step;
        s.steps.clocks.push_back(s.last);
        s.steps.directions.push_back(s.direction);
        step += add;
      }
    }
  }
  std::map<int, KlipperStepper> out;
  for (auto& [oid, s] : steppers) out.emplace(oid, std::move(s.steps));
  return out;
}

KlipperMap ParseKlipperMap(std::istream& in, const std::string& source) {
  KlipperMap map;
  std::string line;
  long n = 0;
  bool has_dump = false, has_clock = false;
  while (GetLine(in, &line, source, n + 1)) {
    ++n;
    const std::string_view text = std::string_view(line).substr(0, line.find('#'));
    const std::vector<std::string_view> words = Words(text);
    if (words.empty()) continue;
    auto number = [&](std::string_view w, double lo, double hi, const char* what) {
      double value = 0;
      const auto [end, error] = std::from_chars(w.data(), w.data() + w.size(), value);
      if (error != std::errc() || end != w.data() + w.size() || !(value >= lo && value <= hi)) {
        Bad(source, n, line, fmt::format("{} must be a number in [{:g}, {:g}]", what, lo, hi));
      }
      return value;
    };
    if (words[0] == "dump" && words.size() == 2) {
      map.dump = std::string(words[1]);
      has_dump = true;
    } else if (words[0] == "clock_freq" && words.size() == 2) {
      map.clock_freq = number(words[1], 1e3, 1e10, "clock_freq (Hz)");
      has_clock = true;
    } else if (words[0] == "offset" && words.size() == 2) {
      map.offset = number(words[1], -1e6, 1e6, "offset (s)");
    } else if (words[0] == "stepper" && (words.size() == 3 || words.size() == 4)) {
      if (words.size() == 4 && words[3] != "reversed") {
        Bad(source, n, line, "after the oid only `reversed` may follow");
      }
      const double oid = number(words[2], 0, 255, "oid");
      if (oid != std::floor(oid)) Bad(source, n, line, "oid must be an integer");
      const KlipperMap::Stepper s{.actuator = std::string(words[1]),
                                  .oid = static_cast<int>(oid),
                                  .reversed = words.size() == 4};
      for (const KlipperMap::Stepper& other : map.steppers) {
        if (other.actuator == s.actuator) {
          Bad(source, n, line, fmt::format("actuator {} is mapped twice", s.actuator));
        }
      }
      map.steppers.push_back(s);
    } else {
      Bad(source, n, line,
          "expected `dump PATH`, `clock_freq HZ`, `offset S` or `stepper ACTUATOR OID [reversed]`");
    }
  }
  if (!has_dump || !has_clock || map.steppers.empty()) {
    throw std::invalid_argument(fmt::format(
        "{}: a Klipper map needs `dump PATH`, `clock_freq HZ` and at least one `stepper ACTUATOR "
        "OID` line",
        source));
  }
  return map;
}

std::map<std::string, StepTimes> ReadKlipperSteps(const std::string& map_path) {
  CheckTextFile(map_path, kMaxKlipperMapBytes, "a Klipper map");
  std::ifstream map_file(map_path);
  if (!map_file) throw std::invalid_argument(fmt::format("{}: cannot be read", map_path));
  const KlipperMap map = ParseKlipperMap(map_file, map_path);
  const std::filesystem::path dump =
      std::filesystem::path(map_path).parent_path() / std::filesystem::path(map.dump);
  CheckTextFile(dump.string(), kMaxKlipperDumpBytes, "Klipper's parsedump.py output");
  std::ifstream dump_file(dump);
  if (!dump_file) throw std::invalid_argument(fmt::format("{}: cannot be read", dump.string()));
  const std::map<int, KlipperStepper> steppers = ParseKlipperDump(dump_file, dump.string());
  std::map<std::string, StepTimes> out;
  for (const KlipperMap::Stepper& s : map.steppers) {
    const auto it = steppers.find(s.oid);
    if (it == steppers.end()) {
      throw std::invalid_argument(fmt::format(
          "{}: stepper {} has oid {}, which {} does not configure (no config_stepper oid={})",
          map_path, s.actuator, s.oid, dump.string(), s.oid));
    }
    std::vector<double> times(it->second.clocks.size()), directions = it->second.directions;
    for (std::size_t k = 0; k < times.size(); ++k) {
      times[k] = static_cast<double>(it->second.clocks[k]) / map.clock_freq + map.offset;
      if (s.reversed) directions[k] = -directions[k];
    }
    out.emplace(s.actuator,
                StepTimes::FromSteps(times, directions,
                                     fmt::format("{} (oid {} of {})", map_path, s.oid, map.dump)));
  }
  return out;
}

}  // namespace mjstepper
