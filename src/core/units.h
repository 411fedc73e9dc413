// Unit conversions at the edges (command line, docs). Inside the core everything is SI.
#ifndef MJSTEPPER_CORE_UNITS_H_
#define MJSTEPPER_CORE_UNITS_H_

#include <numbers>

namespace mjstepper {

inline constexpr double kTwoPi = 2.0 * std::numbers::pi;

constexpr double RpmToRadPerSec(double rpm) { return rpm * kTwoPi / 60.0; }
constexpr double RadPerSecToRpm(double omega) { return omega * 60.0 / kTwoPi; }

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_UNITS_H_
