// A motion controller's STEP/DIR output as a list of step times (issue 17: "one step time per
// line, as a motion controller would emit"), for drives with input = steps: the microstep count
// at any time, and the step rate there.
//
// Format, one step per line: its time in s (non-decreasing, within [0, 1e6]), optionally
// followed by its direction, +1 (default) or −1; blank lines and lines starting with # are
// skipped. At most kMaxStepTimes lines.
#ifndef MJSTEPPER_CORE_STEP_TIMES_H_
#define MJSTEPPER_CORE_STEP_TIMES_H_

#include <cstddef>
#include <cstdint>
#include <istream>
#include <ostream>
#include <string>
#include <vector>

namespace mjstepper {

/// 10 million steps: 52 min of 1/16 microsteps at 1000 r/min; beyond, a list is a mistake.
inline constexpr std::size_t kMaxStepTimes = 10000000;
/// The longest line a list may have: a time and a direction fit in far fewer.
inline constexpr std::size_t kMaxStepLine = 256;
/// The largest file Read takes: kMaxStepTimes lines of a 20-digit time and a direction.
inline constexpr std::uintmax_t kMaxStepFileBytes = 32 * kMaxStepTimes;

/// Throws std::invalid_argument naming `path` unless it is a regular file (through symlinks; not
/// a device, a directory or a pipe) of at most `max_bytes` bytes; `what` names its content for the
/// message ("a list of step times").
void CheckTextFile(const std::string& path, std::uintmax_t max_bytes, const std::string& what);

class StepTimes {
 public:
  /// Throws std::invalid_argument naming `source`, the line and what is wrong (quoting at most
  /// its first 40 characters, control characters as '?'); a line longer than kMaxStepLine is
  /// refused without reading further.
  static StepTimes Parse(std::istream& in, const std::string& source);
  /// A list made of its steps, times (s, non-decreasing, within [0, 1e6]) and directions (+1 or
  /// −1), at most kMaxStepTimes; throws std::invalid_argument naming `source` otherwise.
  static StepTimes FromSteps(const std::vector<double>& times,
                             const std::vector<double>& directions, const std::string& source);
  /// The list in the format Parse reads, one step per line ("time direction", the time to 17
  /// significant digits, so that it reads back to the same double).
  void Write(std::ostream& out) const;
  /// Parse of a file; throws std::invalid_argument when it is not a regular file (a device, a
  /// directory, a pipe), is larger than kMaxStepFileBytes, or cannot be read.
  static StepTimes Read(const std::string& path);

  /// The signed count of steps at times <= t (s): the driver's position, in microsteps.
  double Count(double t) const;
  /// The step rate at t (s), microsteps/s: the direction of the next step over the interval
  /// from the step before t to it; 0 before the first and after the last.
  double Rate(double t) const;
  /// The first step time after t (s), or +infinity.
  double NextTime(double t) const;
  /// How many steps fall in (t0, t1] (s).
  std::size_t StepsIn(double t0, double t1) const;

  std::size_t size() const { return times_.size(); }
  double TimeAt(std::size_t k) const { return times_[k]; }    ///< s, the k-th step's time
  double CountAt(std::size_t k) const { return counts_[k]; }  ///< the count after the k-th step
  double last_time() const { return times_.empty() ? 0.0 : times_.back(); }

 private:
  std::vector<double> times_;   // s, non-decreasing
  std::vector<double> counts_;  // the count after each step
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_STEP_TIMES_H_
