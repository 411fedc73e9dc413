// A real print's step stream: Klipper's microcontroller step commands as step lists (issue 31,
// item 6; SPEC §13). Klipper's batch mode (`klippy.py printer.cfg -i FILE.gcode -o FILE.serial -d
// klipper.dict`) writes the exact commands its MCU would receive for a G-code file, input shaping
// already applied; its `parsedump.py klipper.dict FILE.serial` prints them one per line, e.g.
//   config_stepper oid=2 step_pin=gpiochip0/gpio20 dir_pin=… invert_step=0 step_pulse_ticks=100
//   set_next_step_dir oid=2 dir=1
//   queue_step oid=2 interval=3125 count=2660 add=0
//   reset_step_clock oid=2 clock=123456
// in MCU clock ticks (CLOCK_FREQ in its data dictionary). Their meaning, as Klipper's MCU code
// runs them (src/stepper.c: command_queue_step, stepper_load_next, stepper_event_full,
// command_set_next_step_dir, command_reset_step_clock; read for the format, not copied):
//   - each stepper keeps the time T of its last step, 0 after config_stepper;
//   - reset_step_clock sets T = clock (32 bits: taken as the nearest time ≥ T − 2^31 with those
//     low bits);
//   - queue_step(interval I, count n, add a) steps at T + k·I + a·k(k−1)/2 for k = 1 … n, after
//     which T is the last of them (each command's interval counts from the previous command's last
//     step);
//   - set_next_step_dir latches a direction for every step of the queue_steps after it: dir = 1
//     steps +1 (with the printer.cfg's dir pins not inverted; a map's `reversed` flips a stepper).
// Other commands are skipped. Knows nothing of MuJoCo.
//
// The map file says which oid drives which actuator of a model:
//   # Klipper's step commands onto models/corexy.xml
//   dump out_mzv.txt          parsedump.py's output, relative to the map file
//   clock_freq 50000000       Hz: CLOCK_FREQ of the MCU's klipper.dict
//   offset 0                  s added to every step time (clock / clock_freq); optional, default 0
//   stepper stepper_a 2       an actuator's name and its stepper's oid; `reversed` after the oid
//   stepper stepper_b 5       flips its direction
// Blank lines and text from # on are skipped.
#ifndef MJSTEPPER_CORE_KLIPPER_STEPS_H_
#define MJSTEPPER_CORE_KLIPPER_STEPS_H_

#include <cstdint>
#include <istream>
#include <map>
#include <string>
#include <vector>

#include "core/step_times.h"

namespace mjstepper {

/// One stepper's steps from its MCU commands.
struct KlipperStepper {
  std::vector<std::int64_t> clocks;  ///< ticks, non-decreasing (unwrapped past 2^32)
  std::vector<double> directions;    ///< +1 or −1 per step
};

/// The largest text ParseKlipperDump reads, in lines (a queue_step carries up to 65 535 steps).
inline constexpr std::size_t kMaxKlipperDumpLines = 10000000;

/// Every configured stepper's steps (by oid) from parsedump.py's text. Throws
/// std::invalid_argument naming `source`, the line and what is wrong: a command for an oid no
/// config_stepper made, a field missing or out of its wire range (interval and clock 32 bits
/// unsigned, count 16, add 16 signed), more than kMaxStepTimes steps on a stepper.
std::map<int, KlipperStepper> ParseKlipperDump(std::istream& in, const std::string& source);

struct KlipperMap {
  std::string dump;       ///< the dump's path as written in the map (relative to the map)
  double clock_freq = 0;  ///< Hz
  double offset = 0;      ///< s
  struct Stepper {
    std::string actuator;
    int oid = 0;
    bool reversed = false;
  };
  std::vector<Stepper> steppers;
};

/// Throws std::invalid_argument naming `source`, the line and what is wrong.
KlipperMap ParseKlipperMap(std::istream& in, const std::string& source);

/// The map's dump (its path resolved against the map file's folder) as one step list per mapped
/// actuator, times clock/clock_freq + offset. Throws std::invalid_argument naming the files: an
/// oid the dump does not configure, a time outside StepTimes' range.
std::map<std::string, StepTimes> ReadKlipperSteps(const std::string& map_path);

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_KLIPPER_STEPS_H_
