// The signals a user reads of one drive, in a fixed order: the sensor output layout of the plugin,
// the column order and header of the runner's log, the Python tools' names and units, and the
// README's signal table all come from SignalTable(). Names and units are public interface.
#ifndef MJSTEPPER_CORE_SIGNALS_H_
#define MJSTEPPER_CORE_SIGNALS_H_

#include <array>
#include <string>

#include "core/drive.h"

namespace mjstepper {

struct SignalInfo {
  const char* name;
  const char* unit;
  const char* meaning;
  double DriveSignals::*field;  ///< where the value lives
};

inline constexpr int kNumSignals = 31;

/// Name, unit, meaning and field of each signal, in output order.
const std::array<SignalInfo, kNumSignals>& SignalTable();

/// The index of the signal `name` in SignalTable (a compile-time-checked lookup for tools).
int SignalIndex(const std::string& name);

/// The values of SignalTable's signals, in its order.
std::array<double, kNumSignals> SignalValues(const DriveSignals& s);

/// The README's signal table (Markdown), made from SignalTable.
std::string SignalTableMarkdown();

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_SIGNALS_H_
