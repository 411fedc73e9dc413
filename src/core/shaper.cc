#include "core/shaper.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <unsupported/Eigen/FFT>

#include "core/units.h"

namespace mjstepper {
namespace {

using std::numbers::pi;

// ζ's decay per half damped period: K = exp(−ζπ/√(1−ζ²)) (SPEC §9). An impulse at T = k·t_d/2
// has, at the design frequency, the phase kπ and the vector magnitude A·e^{ζωT} = A·K^{−k}
// (the vector diagram of Singhose, Seering & Singer, "Residual vibration reduction using vector
// diagrams to generate shaped inputs", J. Mech. Des. 116, 1994).
double HalfPeriodDecay(double zeta) { return std::exp(-zeta * pi / std::sqrt(1 - zeta * zeta)); }

// Undamped amplitudes B_k at k·t_d/2 made damped as A_k ∝ B_k·K^k: the impulse vectors at the
// design frequency, B_k·(−1)^k up to one factor, are then the undamped shaper's exactly, so its
// zeros there stay zeros. For ZV (B = [1, 1]/2) and ZVD (B = [1, 2, 1]/4) this is SPEC §9's
// damped form; for the multi-hump EI shapers it is the damped extension used here (see below).
std::vector<double> DampedHalfPeriodAmplitudes(const std::vector<double>& undamped, double zeta) {
  const double k = HalfPeriodDecay(zeta);
  std::vector<double> a(undamped.size());
  double sum = 0, scale = 1;
  for (std::size_t i = 0; i < a.size(); ++i, scale *= k) sum += a[i] = undamped[i] * scale;
  for (double& x : a) x /= sum;
  return a;
}

std::vector<double> HalfPeriodTimes(std::size_t n, double damped_period) {
  std::vector<double> t(n);
  for (std::size_t i = 0; i < n; ++i) t[i] = 0.5 * damped_period * static_cast<double>(i);
  return t;
}

// The EI shaper (Singhose, Seering & Singer, "Residual vibration reduction using vector diagrams
// to generate shaped inputs", J. Mech. Des. 116, 1994): V = Vtol at the design frequency and
// V = 0 at a frequency on each side, undamped A = [(1+V)/4, (1−V)/2, (1+V)/4] at [0, t_d/2, t_d].
// With damping the impulses move off that pattern, and we use Singhose's published curve fit in
// Vtol and ζ: A1, A3 quadratic in ζ, t2 cubic, A2 = 1 − A1 − A3, t3 = t_d (W. Singhose,
// W. Seering, N. Singer, "Input shaping for vibration reduction with specified insensitivity to
// modeling errors", Japan-USA Symp. on Flexible Automation, 1996, and Singhose's MIT thesis,
// "Command generation for flexible systems", 1997; neither could be consulted while writing
// this, so the coefficients are checked against the shaper's defining property in shaper_test:
// V(f) within 3 % of Vtol = 5 % (5 % of Vtol = 10 %) for ζ ≤ 0.2, a zero on each side, and at
// ζ = 0 the closed form to 6e-4).
InputShaper EiUnit(double zeta, double v, double damped_period) {
  const double z = zeta;
  const double a1 =
      0.24968 + 0.24961 * v + (0.80008 + 1.23328 * v) * z + (0.49599 + 3.17316 * v) * z * z;
  const double a3 =
      0.25149 + 0.21474 * v + (-0.83249 + 1.41498 * v) * z + (0.85181 - 4.90094 * v) * z * z;
  const double t2 = 0.4999 + (0.46159 * v + 8.57843 * v * v) * z +
                    (4.26169 * v - 108.644 * v * v) * z * z +
                    (1.75601 * v + 336.989 * v * v) * z * z * z;
  return {"", {a1, 1 - a1 - a3, a3}, {0, t2 * damped_period, damped_period}};
}

// The two- and three-hump EI shapers (W. Singhose, L. Porter, T. Tuttle, N. Singer, "Vibration
// reduction using multi-hump input shapers", J. Dyn. Sys. Meas. Control 119, 1997): impulses at
// k·t_d/2, undamped amplitudes in closed form. Two humps, V = 0 at the design frequency and a
// hump of height Vtol on each side, with X = (Vtol²·(√(1 − Vtol²) + 1))^{1/3}:
//   A1 = A4 = (3X² + 2X + 3Vtol²)/(16X),  A2 = A3 = 1/2 − A1.
// Three humps, V = Vtol at the design frequency and on the two side humps:
//   A1 = A5 = (1 + 3Vtol + 2√(2Vtol(Vtol + 1)))/16,  A2 = A4 = (1 − Vtol)/4,  A3 = 1 − 2(A1 + A2).
// With damping, rather than designs of the paper's for damped modes (which could not be consulted
// here), damping enters through the vector diagram (DampedHalfPeriodAmplitudes), as it does for
// ZV and ZVD: the design frequency's zero (two humps) stays exact, and the humps fall below Vtol
// as ζ grows (at ζ = 0.1 to 3.3 % and 2.8 %, the three-hump's to 3.3/2.5/2.2 %): the damped
// shaper leaves less than the tolerance, for the same duration. shaper_test checks both (and
// the undamped shapers' insensitivities against their closed forms).
std::vector<double> TwoHumpUndamped(double v) {
  const double x = std::cbrt(v * v * (std::sqrt(1 - v * v) + 1));
  const double a1 = (3 * x * x + 2 * x + 3 * v * v) / (16 * x);
  return {a1, 0.5 - a1, 0.5 - a1, a1};
}
std::vector<double> ThreeHumpUndamped(double v) {
  const double a1 = (1 + 3 * v + 2 * std::sqrt(2 * v * (v + 1))) / 16;
  const double a2 = (1 - v) / 4;
  return {a1, a2, 1 - 2 * (a1 + a2), a2, a1};
}

// The shaper at 1 Hz: every shaper's times scale as 1/f, its amplitudes not at all.
InputShaper UnitShaper(ShaperType type, double zeta, double vtol) {
  const double td = 1 / std::sqrt(1 - zeta * zeta);  // s, the damped period at 1 Hz
  const double k = HalfPeriodDecay(zeta);
  InputShaper s;
  switch (type) {
    case ShaperType::kZV:  // SPEC §9 (Singer & Seering 1990)
      s = {"", {1 / (1 + k), k / (1 + k)}, {0, td / 2}};
      break;
    case ShaperType::kZVD:  // SPEC §9 (Singer & Seering 1990)
      s = {"",
           {1 / ((1 + k) * (1 + k)), 2 * k / ((1 + k) * (1 + k)), k * k / ((1 + k) * (1 + k))},
           {0, td / 2, td}};
      break;
    case ShaperType::kMZV: {
      // Klipper's MZV (Resonance_Compensation.md, "Technical details"): a ZV shaper generalised
      // to n = 3 impulses spread over 0.75·t_d. Equal spacing 3t_d/8 puts the impulses at the
      // phases 0, 3π/4, 3π/2 of the design frequency; their vectors q_i = A_i·e^{ζωT_i} close
      // (zero vibration, Singhose et al. 1994's diagram) only as q ∝ [1, √2, 1] (the imaginary
      // part gives q1/√2 = q2, the real part q0 = q1/√2). So A ∝ [1, √2·K', K'²], with
      // K' = e^{−ζω·3t_d/8} = K^{3/4}: the constraints solved in closed form.
      const double kp = std::pow(k, 0.75);
      const double sum = 1 + std::sqrt(2.0) * kp + kp * kp;
      s = {"", {1 / sum, std::sqrt(2.0) * kp / sum, kp * kp / sum}, {0, 0.375 * td, 0.75 * td}};
      break;
    }
    case ShaperType::kEI:
      s = EiUnit(zeta, vtol, td);
      break;
    case ShaperType::kTwoHumpEI:
      s = {"", DampedHalfPeriodAmplitudes(TwoHumpUndamped(vtol), zeta), HalfPeriodTimes(4, td)};
      break;
    case ShaperType::kThreeHumpEI:
      s = {"", DampedHalfPeriodAmplitudes(ThreeHumpUndamped(vtol), zeta), HalfPeriodTimes(5, td)};
      break;
  }
  s.name = std::string(ShaperName(type));
  return s;
}

InputShaper AtFrequency(const InputShaper& unit, double frequency) {
  InputShaper s = unit;
  for (double& t : s.times) t /= frequency;
  return s;
}

// D(t) and U(t) of Smoothing: the X distance still to go and the Y distance made at t.
double ToGo(const InputShaper& s, double t, double a, double v) {
  double d = 0;
  for (std::size_t i = 0; i < s.times.size(); ++i) {
    const double u = s.times[i] - t;
    if (u > 0) d += s.amplitudes[i] * (v * u + 0.5 * a * u * u);
  }
  return d;
}
double Made(const InputShaper& s, double t, double a, double v) {
  double d = 0;
  for (std::size_t i = 0; i < s.times.size(); ++i) {
    const double u = t - s.times[i];
    if (u > 0) d += s.amplitudes[i] * (v * u + 0.5 * a * u * u);
  }
  return d;
}

void CheckSpectrum(const std::vector<double>& frequency, const std::vector<double>& psd) {
  if (frequency.size() != psd.size() || psd.empty()) {
    throw std::invalid_argument(
        fmt::format("shaper fit: {} frequencies for {} PSD values (the same number, at least one)",
                    frequency.size(), psd.size()));
  }
  for (std::size_t i = 0; i < psd.size(); ++i) {
    if (!(psd[i] >= 0) || !std::isfinite(psd[i]) || !(frequency[i] >= 0) ||
        !std::isfinite(frequency[i])) {
      throw std::invalid_argument(fmt::format(
          "shaper fit: bin {} ({} Hz, PSD {}): frequencies and PSD must be finite and >= 0", i,
          frequency[i], psd[i]));
    }
  }
}

}  // namespace

const std::vector<ShaperType>& AllShaperTypes() {
  static const std::vector<ShaperType> all = {ShaperType::kZV,        ShaperType::kMZV,
                                              ShaperType::kZVD,       ShaperType::kEI,
                                              ShaperType::kTwoHumpEI, ShaperType::kThreeHumpEI};
  return all;
}

std::string_view ShaperName(ShaperType type) {
  switch (type) {
    case ShaperType::kZV:
      return "zv";
    case ShaperType::kMZV:
      return "mzv";
    case ShaperType::kZVD:
      return "zvd";
    case ShaperType::kEI:
      return "ei";
    case ShaperType::kTwoHumpEI:
      return "2hump_ei";
    case ShaperType::kThreeHumpEI:
      return "3hump_ei";
  }
  return "";
}

ShaperType ParseShaperType(std::string_view name) {
  std::string lower(name);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (ShaperType type : AllShaperTypes()) {
    if (lower == ShaperName(type)) return type;
  }
  throw std::invalid_argument(
      fmt::format("input shaper \"{}\": expected zv, mzv, zvd, ei, 2hump_ei or 3hump_ei", name));
}

InputShaper MakeShaper(ShaperType type, double frequency, double damping, double vtol) {
  if (!(frequency > 0 && frequency <= 1e5)) {
    throw std::invalid_argument(fmt::format("input shaper {}: frequency {} Hz is not in (0, 1e5]",
                                            ShaperName(type), frequency));
  }
  if (!(damping >= 0 && damping <= kMaxShaperDamping)) {
    throw std::invalid_argument(fmt::format("input shaper {}: damping ratio {} is not in [0, {}]",
                                            ShaperName(type), damping, kMaxShaperDamping));
  }
  if (!(vtol > 0 && vtol <= 0.2)) {
    throw std::invalid_argument(fmt::format(
        "input shaper {}: vibration tolerance {} is not in (0, 0.2]", ShaperName(type), vtol));
  }
  return AtFrequency(UnitShaper(type, damping, vtol), frequency);
}

InputShaper Convolve(const InputShaper& a, const InputShaper& b) {
  std::vector<std::pair<double, double>> impulses;  // (time, amplitude)
  for (std::size_t i = 0; i < a.times.size(); ++i) {
    for (std::size_t j = 0; j < b.times.size(); ++j) {
      impulses.emplace_back(a.times[i] + b.times[j], a.amplitudes[i] * b.amplitudes[j]);
    }
  }
  std::sort(impulses.begin(), impulses.end());
  InputShaper c{a.name + "*" + b.name, {}, {}};
  for (const auto& [t, amp] : impulses) {
    if (!c.times.empty() && t - c.times.back() <= 1e-12 * std::max(1.0, t)) {
      c.amplitudes.back() += amp;  // coinciding impulses are one
    } else {
      c.times.push_back(t);
      c.amplitudes.push_back(amp);
    }
  }
  return c;
}

double RemainingVibration(const InputShaper& shaper, double frequency, double damping) {
  if (shaper.times.empty()) return 1.0;
  const double w = kTwoPi * frequency;                     // rad/s
  const double wd = w * std::sqrt(1 - damping * damping);  // rad/s
  const double tn = shaper.duration();
  double c = 0, s = 0;
  for (std::size_t i = 0; i < shaper.times.size(); ++i) {
    // A_i·e^{ζω(T_i − T_n)}: SPEC §9's e^{−ζωT_n} taken inside the sums, so nothing overflows.
    const double decay = shaper.amplitudes[i] * std::exp(damping * w * (shaper.times[i] - tn));
    c += decay * std::cos(wd * shaper.times[i]);
    s += decay * std::sin(wd * shaper.times[i]);
  }
  return std::hypot(c, s);
}

double Smoothing(const InputShaper& shaper, double accel, double corner_velocity) {
  if (!(accel >= 0) || !(corner_velocity >= 0)) {
    throw std::invalid_argument(
        fmt::format("smoothing: acceleration {} m/s² and corner velocity {} m/s must be >= 0",
                    accel, corner_velocity));
  }
  double lo = 0, hi = shaper.duration();
  if (!(hi > 0)) return 0.0;
  // U − D rises from −D(0) to U(T_n): bisect for its zero, to rounding (the bracket halves
  // 200 times at most; it stops once it no longer shrinks).
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    if (Made(shaper, mid, accel, corner_velocity) < ToGo(shaper, mid, accel, corner_velocity)) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return std::max(
      std::min(Made(shaper, lo, accel, corner_velocity), ToGo(shaper, lo, accel, corner_velocity)),
      std::min(Made(shaper, hi, accel, corner_velocity), ToGo(shaper, hi, accel, corner_velocity)));
}

double MaxAcceleration(const InputShaper& shaper, double smoothing_limit, double corner_velocity) {
  if (!(smoothing_limit > 0)) {
    throw std::invalid_argument(
        fmt::format("max acceleration: smoothing limit {} m must be > 0", smoothing_limit));
  }
  if (Smoothing(shaper, 0.0, corner_velocity) >= smoothing_limit) return 0.0;
  // Smoothing rises with the acceleration (D and U both do): bracket, then bisect.
  double lo = 0, hi = 1;  // m/s²
  while (Smoothing(shaper, hi, corner_velocity) < smoothing_limit) {
    lo = hi;
    hi *= 2;
    if (hi > 1e15) return std::numeric_limits<double>::infinity();  // a shaper of no duration
  }
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    (Smoothing(shaper, mid, corner_velocity) < smoothing_limit ? lo : hi) = mid;
  }
  return lo;
}

Spectrum Welch(const std::vector<double>& samples, double fs, std::size_t segment) {
  if (segment < 2 || samples.size() < segment || !(fs > 0) || !std::isfinite(fs)) {
    throw std::invalid_argument(fmt::format(
        "Welch: {} samples at {} Hz in segments of {}: need fs > 0, a segment >= 2 samples and at "
        "least one segment",
        samples.size(), fs, segment));
  }
  const std::size_t n = segment;
  const std::size_t step = std::max<std::size_t>(1, n / 2);  // 50 % overlap
  std::vector<double> window(n);
  double window_power = 0;  // Σ w²
  for (std::size_t k = 0; k < n; ++k) {
    window[k] = 0.5 - 0.5 * std::cos(kTwoPi * static_cast<double>(k) / static_cast<double>(n));
    window_power += window[k] * window[k];
  }
  Eigen::FFT<double> fft;
  std::vector<double> buffer(n);
  std::vector<std::complex<double>> spectrum;
  std::vector<double> sum(n / 2 + 1, 0.0);
  std::size_t segments = 0;
  for (std::size_t start = 0; start + n <= samples.size(); start += step, ++segments) {
    double mean = 0;
    for (std::size_t k = 0; k < n; ++k) mean += samples[start + k];
    mean /= static_cast<double>(n);
    for (std::size_t k = 0; k < n; ++k) buffer[k] = (samples[start + k] - mean) * window[k];
    fft.fwd(spectrum, buffer);
    for (std::size_t k = 0; k <= n / 2; ++k) sum[k] += std::norm(spectrum[k]);
  }
  // Density scaling |X_k|²/(fs·Σw²), averaged over the segments; one-sided: the negative
  // frequencies folded onto the positive, so every bin but DC and (N even) Nyquist doubles.
  Spectrum out;
  out.frequency.resize(n / 2 + 1);
  out.psd.resize(n / 2 + 1);
  const double scale = 1.0 / (fs * window_power * static_cast<double>(segments));
  for (std::size_t k = 0; k <= n / 2; ++k) {
    const bool unpaired = k == 0 || (n % 2 == 0 && k == n / 2);
    out.frequency[k] = static_cast<double>(k) * fs / static_cast<double>(n);
    out.psd[k] = sum[k] * scale * (unpaired ? 1.0 : 2.0);
  }
  return out;
}

double ShapedVibration(const InputShaper& shaper, const std::vector<double>& frequency,
                       const std::vector<double>& psd, const std::vector<double>& dampings,
                       double floor_fraction) {
  CheckSpectrum(frequency, psd);
  if (dampings.empty()) throw std::invalid_argument("shaper fit: no test damping ratios");
  if (!(floor_fraction >= 0 && floor_fraction < 1)) {
    throw std::invalid_argument(
        fmt::format("shaper fit: PSD floor {} is not a fraction in [0, 1)", floor_fraction));
  }
  for (double z : dampings) {
    if (!(z >= 0 && z < 1)) {
      throw std::invalid_argument(fmt::format("shaper fit: test damping {} is not in [0, 1)", z));
    }
  }
  const double floor = floor_fraction * *std::max_element(psd.begin(), psd.end());
  double weighted = 0, total = 0;
  for (std::size_t k = 0; k < psd.size(); ++k) {
    const double w = std::max(psd[k] - floor, 0.0);
    if (w == 0) continue;
    double worst = 0;
    for (double z : dampings) worst = std::max(worst, RemainingVibration(shaper, frequency[k], z));
    weighted += w * worst * worst;
    total += w;
  }
  if (!(total > 0)) {
    throw std::invalid_argument("shaper fit: the PSD has nothing above its floor (all zero?)");
  }
  return weighted / total;
}

std::vector<ShaperFit> FitShapers(const std::vector<double>& frequency,
                                  const std::vector<double>& psd, const FitOptions& options) {
  CheckSpectrum(frequency, psd);
  if (!(options.min_frequency > 0) || !(options.max_frequency >= options.min_frequency) ||
      !(options.frequency_step > 0) ||
      (options.max_frequency - options.min_frequency) / options.frequency_step > 1e6) {
    throw std::invalid_argument(fmt::format(
        "shaper fit: scan {}-{} Hz in steps of {} Hz: need 0 < min <= max, a step > 0 and at "
        "most a million steps",
        options.min_frequency, options.max_frequency, options.frequency_step));
  }
  if (!(options.vibration_margin >= 0) || !(options.reference_accel >= 0)) {
    throw std::invalid_argument(
        fmt::format("shaper fit: vibration margin {} and reference acceleration {} m/s² must be "
                    ">= 0",
                    options.vibration_margin, options.reference_accel));
  }
  const auto steps = static_cast<std::size_t>(
      std::floor((options.max_frequency - options.min_frequency) / options.frequency_step + 1e-9));
  std::vector<ShaperFit> fits;
  for (ShaperType type : options.types) {
    // Validates the design damping and tolerance once (the unit shaper's frequency is 1 Hz).
    const InputShaper unit = MakeShaper(type, 1.0, options.design_damping, options.vtol);
    struct Candidate {
      double frequency, vibration, smoothing;
    };
    std::vector<Candidate> scan;
    scan.reserve(steps + 1);
    double least = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i <= steps; ++i) {
      const double f = options.min_frequency + static_cast<double>(i) * options.frequency_step;
      const InputShaper s = AtFrequency(unit, f);
      const double v = ShapedVibration(s, frequency, psd, options.test_dampings, options.psd_floor);
      scan.push_back({f, v, Smoothing(s, options.reference_accel, options.corner_velocity)});
      least = std::min(least, v);
    }
    const Candidate* best = nullptr;
    for (const Candidate& c : scan) {
      if (c.vibration <= least + options.vibration_margin &&
          (best == nullptr || c.smoothing < best->smoothing)) {
        best = &c;
      }
    }
    ShaperFit fit;
    fit.type = type;
    fit.frequency = best->frequency;
    fit.shaper = AtFrequency(unit, best->frequency);
    fit.vibration = best->vibration;
    fit.smoothing = best->smoothing;
    fit.max_accel = MaxAcceleration(fit.shaper, options.smoothing_limit, options.corner_velocity);
    fits.push_back(std::move(fit));
  }
  return fits;
}

ShaperFit Recommend(const std::vector<ShaperFit>& fits, double max_vibration) {
  if (fits.empty()) throw std::invalid_argument("shaper recommendation: no fitted shapers");
  const ShaperFit* best = nullptr;
  for (const ShaperFit& f : fits) {
    if (f.vibration <= max_vibration && (best == nullptr || f.max_accel > best->max_accel)) {
      best = &f;
    }
  }
  if (best != nullptr) return *best;
  return *std::min_element(fits.begin(), fits.end(), [](const ShaperFit& a, const ShaperFit& b) {
    return a.vibration < b.vibration;
  });
}

}  // namespace mjstepper
