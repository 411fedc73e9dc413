// Test helper: a Klipper raw accelerometer log (`run --accel-log`, resonance.h) read back.
#ifndef MJSTEPPER_TESTS_TOOLS_ACCEL_LOG_H_
#define MJSTEPPER_TESTS_TOOLS_ACCEL_LOG_H_

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>

namespace mjstepper::tools {

/// The ADXL345's x, y, z (mm/s²) by sample time in units of 0.1 µs, from a Klipper raw log.
inline std::map<long, std::array<double, 3>> ReadAccelLog(const std::string& path) {
  std::ifstream in(path);
  std::map<long, std::array<double, 3>> out;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    double t = 0, x = 0, y = 0, z = 0;
    if (std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf", &t, &x, &y, &z) == 4) {
      out[std::lround(t * 1e7)] = {x, y, z};
    }
  }
  return out;
}

/// RMS over [t0, t1) s of axis `axis` of `moved` less `still` sample by sample (the same run with
/// the motors still: the sensor's own noise, the same seed and sample times), mm/s².
inline double RingingRms(const std::map<long, std::array<double, 3>>& moved,
                         const std::map<long, std::array<double, 3>>& still, int axis, double t0,
                         double t1) {
  double sum2 = 0;
  int n = 0;
  for (const auto& [at, a] : moved) {
    const double t = at * 1e-7;
    const auto quiet = still.find(at);
    if (t < t0 || t >= t1 || quiet == still.end()) continue;
    const double d = a[axis] - quiet->second[axis];
    sum2 += d * d, ++n;
  }
  return n > 0 ? std::sqrt(sum2 / n) : 0.0;
}

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TESTS_TOOLS_ACCEL_LOG_H_
