// The signals a user reads of one drive, in a fixed order: the sensor output layout of the plugin
// and the column order of the runner's log. Names and units are part of the public interface.
#ifndef MJSTEPPER_CORE_SIGNALS_H_
#define MJSTEPPER_CORE_SIGNALS_H_

#include <array>

#include "core/drive.h"

namespace mjstepper {

struct SignalInfo {
  const char* name;
  const char* unit;
  const char* meaning;
};

/// Index of each signal in SignalTable and SignalValues.
enum SignalIndex : int {
  kCurrentA,
  kCurrentB,
  kVoltageA,
  kVoltageB,
  kCurrentD,
  kCurrentQ,
  kThetaCmd,
  kOmegaCmd,
  kTorqueEm,
  kTorqueDetent,
  kTorqueTotal,
  kLoadAngle,
  kLostSteps,
  kEnergyInput,
  kEnergyCopper,
  kEnergyMechanical,
  kThetaMeas,
  kOmegaEst,
  kNumSignals
};

/// Name, unit and meaning of each signal, in output order.
const std::array<SignalInfo, kNumSignals>& SignalTable();

/// The values of SignalTable's signals for one drive: its signals plus its energy counters.
std::array<double, kNumSignals> SignalValues(const DriveSignals& s, const DriveState& state);

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_SIGNALS_H_
