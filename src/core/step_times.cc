#include "core/step_times.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include "core/attributes.h"

namespace mjstepper {

StepTimes StepTimes::Parse(std::istream& in, const std::string& source) {
  StepTimes s;
  std::string line;
  long number = 0;
  double count = 0;
  // At most kMaxStepLine + 1 characters of each line are kept: a longer one is refused.
  auto next_line = [&]() -> bool {
    line.clear();
    for (int c = in.get(); c != std::char_traits<char>::eof(); c = in.get()) {
      if (c == '\n') return true;
      if (line.size() <= kMaxStepLine) line.push_back(static_cast<char>(c));
    }
    return !line.empty();
  };
  while (next_line()) {
    ++number;
    const std::string text = Trim(line);
    if (text.empty() || text[0] == '#') continue;
    auto bad = [&](const std::string& why) {
      std::string quoted = text.substr(0, 40);  // a line's start, printable
      for (char& c : quoted) {
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
      }
      if (text.size() > 40) quoted += "...";
      return std::invalid_argument(fmt::format("{}:{}: \"{}\": {}", source, number, quoted, why));
    };
    if (line.size() > kMaxStepLine) {
      throw bad(fmt::format("a line longer than {} characters", kMaxStepLine));
    }
    std::istringstream fields(text);
    std::string time_text, direction_text, extra;
    fields >> time_text >> direction_text >> extra;
    double time = 0, direction = 1;
    if (!ParseFiniteDouble(time_text, &time) || !(time >= 0 && time <= 1e6)) {
      throw bad("a step time is a number of seconds in [0, 1e6]");
    }
    if (!direction_text.empty() &&
        (!ParseFiniteDouble(direction_text, &direction) || (direction != 1 && direction != -1))) {
      throw bad("the direction after the time is +1 or -1");
    }
    if (!extra.empty()) throw bad("expected a time and at most a direction");
    if (!s.times_.empty() && time < s.times_.back()) {
      throw bad(fmt::format("step times must not decrease (the step before is at {:g} s)",
                            s.times_.back()));
    }
    if (s.times_.size() >= kMaxStepTimes) {
      throw bad(fmt::format("more than {} steps", kMaxStepTimes));
    }
    count += direction;
    s.times_.push_back(time);
    s.counts_.push_back(count);
  }
  if (in.bad()) {  // a read that failed (issue 33: /proc/self/mem read as an empty list)
    throw std::invalid_argument(fmt::format(
        "{}: cannot be read (a read failed after line {}: not a text file)", source, number));
  }
  if (s.times_.empty()) {
    throw std::invalid_argument(fmt::format("{}: no step times (one time in s per line)", source));
  }
  return s;
}

StepTimes StepTimes::FromSteps(const std::vector<double>& times,
                               const std::vector<double>& directions, const std::string& source) {
  if (times.size() != directions.size() || times.empty() || times.size() > kMaxStepTimes) {
    throw std::invalid_argument(fmt::format("{}: {} steps (1 to {} with a direction each)", source,
                                            times.size(), kMaxStepTimes));
  }
  StepTimes s;
  double count = 0;
  for (std::size_t k = 0; k < times.size(); ++k) {
    if (!(times[k] >= 0 && times[k] <= 1e6) || (k > 0 && times[k] < times[k - 1]) ||
        (directions[k] != 1 && directions[k] != -1)) {
      throw std::invalid_argument(fmt::format(
          "{}: step {} at {:g} s, direction {:g}: times rise within [0, 1e6], directions are ±1",
          source, k + 1, times[k], directions[k]));
    }
    count += directions[k];
    s.times_.push_back(times[k]);
    s.counts_.push_back(count);
  }
  return s;
}

void StepTimes::Write(std::ostream& out) const {
  double count = 0;
  for (std::size_t k = 0; k < times_.size(); ++k) {
    out << fmt::format("{:.17g} {}\n", times_[k], counts_[k] > count ? "1" : "-1");
    count = counts_[k];
  }
}

void CheckTextFile(const std::string& path, std::uintmax_t max_bytes, const std::string& what) {
  std::error_code error;
  const auto status = std::filesystem::status(path, error);  // (through symlinks)
  if (error || !std::filesystem::exists(status)) {
    throw std::invalid_argument(fmt::format("{}: cannot be read", path));
  }
  if (!std::filesystem::is_regular_file(status)) {
    throw std::invalid_argument(
        fmt::format("{}: not a regular file ({} is a text file)", path, what));
  }
  const std::uintmax_t bytes = std::filesystem::file_size(path, error);
  if (error || bytes > max_bytes) {
    throw std::invalid_argument(
        fmt::format("{}: larger than {} bytes, the most {} may have", path, max_bytes, what));
  }
}

StepTimes StepTimes::Read(const std::string& path) {
  CheckTextFile(path, kMaxStepFileBytes, "a list of step times");
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(fmt::format("{}: cannot be read", path));
  return Parse(in, path);
}

double StepTimes::Count(double t) const {
  const auto it = std::upper_bound(times_.begin(), times_.end(), t);
  return it == times_.begin() ? 0.0 : counts_[it - times_.begin() - 1];
}

double StepTimes::NextTime(double t) const {
  const auto it = std::upper_bound(times_.begin(), times_.end(), t);
  return it == times_.end() ? std::numeric_limits<double>::infinity() : *it;
}

std::size_t StepTimes::StepsIn(double t0, double t1) const {
  if (!(t1 > t0)) return 0;
  return static_cast<std::size_t>(std::upper_bound(times_.begin(), times_.end(), t1) -
                                  std::upper_bound(times_.begin(), times_.end(), t0));
}

double StepTimes::Rate(double t) const {
  const auto it = std::upper_bound(times_.begin(), times_.end(), t);
  if (it == times_.begin() || it == times_.end()) return 0.0;
  const std::size_t next = it - times_.begin();
  const double interval = times_[next] - times_[next - 1];  // s
  // Every step at the next time (steps may share a time): the last of them.
  const std::size_t last = std::upper_bound(it, times_.end(), times_[next]) - times_.begin() - 1;
  const double direction = counts_[last] - counts_[next - 1];
  return interval > 0 ? direction / interval : 0.0;
}

}  // namespace mjstepper
