#include "core/analysis.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/units.h"

namespace mjstepper {

double Mean(std::span<const double> x) {
  return x.empty() ? 0.0 : std::accumulate(x.begin(), x.end(), 0.0) / x.size();
}

double Rms(std::span<const double> x) {
  if (x.empty()) return 0.0;
  double sum = 0;
  for (double v : x) sum += v * v;
  return std::sqrt(sum / x.size());
}

double PeakToPeak(std::span<const double> x) {
  if (x.empty()) return 0.0;
  const auto [lo, hi] = std::minmax_element(x.begin(), x.end());
  return *hi - *lo;
}

Tone FitTone(std::span<const double> t, std::span<const double> x, double frequency) {
  // x ≈ c0 + c1·cos(wt) + c2·sin(wt), normal equations.
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  const double w = kTwoPi * frequency;
  for (size_t k = 0; k < t.size(); ++k) {
    const Eigen::Vector3d row(1.0, std::cos(w * t[k]), std::sin(w * t[k]));
    a += row * row.transpose();
    b += row * x[k];
  }
  const Eigen::Vector3d c = a.ldlt().solve(b);
  // c1·cos + c2·sin = A·cos(wt + φ) with A·cos φ = c1, −A·sin φ = c2.
  return {.amplitude = std::hypot(c[1], c[2]), .phase = std::atan2(-c[2], c[1]), .offset = c[0]};
}

double CrossingFrequency(std::span<const double> t, std::span<const double> x) {
  const double mean = Mean(x);
  std::vector<double> crossings;
  for (size_t k = 1; k < x.size(); ++k) {
    const double a = x[k - 1] - mean, b = x[k] - mean;
    if (a < 0 && b >= 0) crossings.push_back(t[k - 1] + (t[k] - t[k - 1]) * (-a) / (b - a));
  }
  if (crossings.size() < 2) return 0.0;
  return (crossings.size() - 1) / (crossings.back() - crossings.front());
}

double DominantFrequency(std::span<const double> x, double sample_rate, double f_min, double f_max,
                         double df) {
  const double mean = Mean(x);
  std::vector<double> power;
  for (double f = f_min; f <= f_max + 1e-9 * df; f += df) {
    // Goertzel: s[n] = x[n] + 2·cos(w)·s[n−1] − s[n−2]; |X|² = s1² + s2² − 2·cos(w)·s1·s2.
    const double coefficient = 2 * std::cos(kTwoPi * f / sample_rate);
    double s1 = 0, s2 = 0;
    for (double v : x) {
      const double s0 = (v - mean) + coefficient * s1 - s2;
      s2 = s1;
      s1 = s0;
    }
    power.push_back(s1 * s1 + s2 * s2 - coefficient * s1 * s2);
  }
  if (power.empty()) return 0.0;
  const size_t k = std::max_element(power.begin(), power.end()) - power.begin();
  double offset = 0;
  if (k > 0 && k + 1 < power.size()) {
    const double a = power[k - 1], b = power[k], c = power[k + 1];
    const double denominator = a - 2 * b + c;
    if (denominator < 0) offset = 0.5 * (a - c) / denominator;
  }
  return f_min + (k + offset) * df;
}

std::vector<double> BinnedPeakToPeak(std::span<const double> key, std::span<const double> value,
                                     double key_min, double bin, int bins) {
  std::vector<double> lo(bins, 1e300), hi(bins, -1e300);
  for (size_t k = 0; k < key.size(); ++k) {
    const int b = static_cast<int>(std::floor((key[k] - key_min) / bin));
    if (b < 0 || b >= bins) continue;
    lo[b] = std::min(lo[b], value[k]);
    hi[b] = std::max(hi[b], value[k]);
  }
  std::vector<double> p2p(bins, 0.0);
  for (int b = 0; b < bins; ++b) p2p[b] = hi[b] >= lo[b] ? hi[b] - lo[b] : 0.0;
  return p2p;
}

double DampingRatioFromPeaks(std::span<const double> x) {
  const double mean = Mean(x);
  std::vector<double> peaks;
  for (size_t k = 1; k + 1 < x.size(); ++k) {
    if (x[k] - mean > 0 && x[k] >= x[k - 1] && x[k] > x[k + 1]) peaks.push_back(x[k] - mean);
  }
  if (peaks.size() < 2) return 0.0;
  const double d = std::log(peaks.front() / peaks.back()) / (peaks.size() - 1);
  return d / std::sqrt(kTwoPi * kTwoPi + d * d);
}

}  // namespace mjstepper
