#include "core/resonance_excitation.h"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace mjstepper {

void Validate(const ResonanceTestOptions& o) {
  auto require = [](bool ok, const char* name, double value, const char* rule) {
    if (!ok) throw std::invalid_argument(fmt::format("{} = {}: {}", name, value, rule));
  };
  // Each check is written so that NaN fails it.
  require(o.min_freq >= 1 && o.min_freq <= 1000, "min_freq", o.min_freq, "must be in [1, 1000] Hz");
  require(o.max_freq > o.min_freq && o.max_freq <= 1000, "max_freq", o.max_freq,
          "must be > min_freq and <= 1000 Hz");
  require(o.accel_per_hz > 0 && o.accel_per_hz <= 10, "accel_per_hz", o.accel_per_hz,
          "must be in (0, 10] m/s² per Hz (Klipper's 75 mm/s²/Hz is 0.075)");
  require(o.hz_per_sec >= 0.01 && o.hz_per_sec <= 100, "hz_per_sec", o.hz_per_sec,
          "must be in [0.01, 100] Hz/s");
  require(o.Duration() <= 3600, "duration (max_freq - min_freq)/hz_per_sec", o.Duration(),
          "must be at most 3600 s");
}

ResonanceExcitation::ResonanceExcitation(const ResonanceTestOptions& o)
    : o_(o), frequency_(o.min_freq) {}

double ResonanceExcitation::Advance(double dt) {
  t_ += dt;
  // Into the cycle holding t (several if dt is longer than a cycle; each at least 1/max_freq).
  while (t_ - cycle_start_ >= 1 / frequency_) {
    cycle_start_ += 1 / frequency_;
    frequency_ = o_.min_freq + o_.hz_per_sec * cycle_start_;
  }
  const double u = (t_ - cycle_start_) * frequency_;  // the fraction of the cycle
  const double g = u <= 0.25   ? 2 * u * u
                   : u <= 0.75 ? 2 * u - 2 * u * u - 0.25
                               : 2 * (1 - u) * (1 - u);
  return o_.accel_per_hz / 4 / frequency_ * g;  // (V/f)·g(u), m
}

double ResonanceExcitation::Velocity() const {
  const double u = (t_ - cycle_start_) * frequency_;
  const double tri = u <= 0.25 ? 4 * u : u <= 0.75 ? 2 - 4 * u : 4 * u - 4;
  return o_.accel_per_hz / 4 * tri;  // m/s
}

}  // namespace mjstepper
