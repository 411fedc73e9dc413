// A virtual ADXL345 (issue 18, SPEC §9): what the accelerometer on a printer's toolhead reports of
// the acceleration MuJoCo's `accelerometer` sensor gives at its site, in the sensor's frame.
//
// Analog Devices, ADXL345 data sheet (Rev. E):
//   - output data rate up to 3200 Hz (Table 7), the bandwidth half of it; Klipper reads it at
//     3200 Hz (its `adxl345` section's default rate);
//   - full resolution: 3.9 mg/LSB in every range (Table 1, "Scale Factor ... 3.9 mg/LSB"), ranges
//     ±2, ±4, ±8, ±16 g (Klipper sets ±16 g);
//   - noise density 290 µg/√Hz on x and y, 430 µg/√Hz on z ("Noise Performance", Figure 52).
// Each output sample is the mean of the true acceleration over its sample period (a boxcar for the
// part's digital filter, which band-limits to half the data rate), plus white noise of RMS
// density·√(rate/2), rounded to the LSB and clipped to the range. The noise is seeded: a run is
// repeatable.
#ifndef MJSTEPPER_CORE_SENSORS_ADXL345_H_
#define MJSTEPPER_CORE_SENSORS_ADXL345_H_

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace mjstepper {

inline constexpr double kStandardGravity = 9.80665;  // m/s² per g

struct Adxl345Options {
  double rate = 3200;                             ///< Hz, output data rate
  double range = 16 * kStandardGravity;           ///< m/s², ± full scale
  double resolution = 0.0039 * kStandardGravity;  ///< m/s² per LSB (3.9 mg)
  std::array<double, 3> noise_density = {290e-6 * kStandardGravity, 290e-6 * kStandardGravity,
                                         430e-6 * kStandardGravity};  ///< m/s²/√Hz per axis
  std::uint64_t seed = 1;                                             ///< the noise's
};

struct AccelSample {
  double time = 0;                ///< s, the end of the sample period
  std::array<double, 3> accel{};  ///< m/s², the sensor frame
};

/// Turns accelerations given over intervals (a simulation's steps) into the part's samples.
class Adxl345 {
 public:
  explicit Adxl345(Adxl345Options options, double start_time = 0)
      : o_(options), next_(start_time + 1 / options.rate), random_(options.seed) {}

  /// The acceleration `a` (m/s²) held from t0 to t1 (s); appends every sample whose period ends
  /// in (t0, t1] to `out`.
  void Add(double t0, double t1, const std::array<double, 3>& a, std::vector<AccelSample>* out) {
    double t = t0;
    while (next_ <= t1) {
      Accumulate(a, next_ - t);
      Emit(out);
      t = next_;
      next_ += 1 / o_.rate;
    }
    Accumulate(a, t1 - t);
  }

  const Adxl345Options& options() const { return o_; }

 private:
  void Accumulate(const std::array<double, 3>& a, double dt) {
    for (int i = 0; i < 3; ++i) sum_[i] += a[i] * dt;
    span_ += dt;
  }
  void Emit(std::vector<AccelSample>* out) {
    AccelSample s{.time = next_};
    for (int i = 0; i < 3; ++i) {
      const double mean = span_ > 0 ? sum_[i] / span_ : 0.0;
      const double noisy = mean + o_.noise_density[i] * std::sqrt(o_.rate / 2) * normal_(random_);
      const double counts = std::round(noisy / o_.resolution);
      s.accel[i] = std::clamp(counts * o_.resolution, -o_.range, o_.range);
      sum_[i] = 0;
    }
    span_ = 0;
    out->push_back(s);
  }

  Adxl345Options o_;
  double next_;  // s, the end of the current sample period
  std::array<double, 3> sum_{};
  double span_ = 0;
  std::mt19937_64 random_;
  std::normal_distribution<double> normal_{0.0, 1.0};
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_SENSORS_ADXL345_H_
