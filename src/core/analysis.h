// Signal analysis used by tests, the runner's summary and studies: ripple metrics, tone fitting,
// frequency and damping of a free oscillation.
#ifndef MJSTEPPER_CORE_ANALYSIS_H_
#define MJSTEPPER_CORE_ANALYSIS_H_

#include <span>
#include <vector>

namespace mjstepper {

double Mean(std::span<const double> x);
double Rms(std::span<const double> x);  ///< root mean square about zero
double PeakToPeak(std::span<const double> x);

/// x(t) ≈ offset + amplitude·cos(2π·f·t + phase), least squares at a known frequency f (Hz).
struct Tone {
  double amplitude = 0;
  double phase = 0;  ///< rad
  double offset = 0;
};
Tone FitTone(std::span<const double> t, std::span<const double> x, double frequency);

/// Frequency (Hz) from the upward crossings of the mean, linearly interpolated; 0 if fewer than 2.
double CrossingFrequency(std::span<const double> t, std::span<const double> x);

/// The frequency (Hz) in [f_min, f_max] where x's spectrum peaks, x sampled at `sample_rate` Hz:
/// Goertzel power on a grid of step df, refined by a parabola through the peak and its neighbours.
/// The mean is removed first.
double DominantFrequency(std::span<const double> x, double sample_rate, double f_min, double f_max,
                         double df);

/// Peak-to-peak of `value` in bins of `key` of width `bin` starting at key_min: the ripple
/// envelope of a ramp against its commanded speed. Empty bins are 0.
std::vector<double> BinnedPeakToPeak(std::span<const double> key, std::span<const double> value,
                                     double key_min, double bin, int bins);

/// Damping ratio ζ of a decaying oscillation from its successive maxima about the mean
/// (logarithmic decrement over all of them): ζ = d/√(4π² + d²), d = ln(x_0/x_n)/n.
double DampingRatioFromPeaks(std::span<const double> x);

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_ANALYSIS_H_
