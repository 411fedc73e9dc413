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
// reduction using multi-hump input shapers", J. Dyn. Sys. Meas. Control 119, 1997: undamped,
// V = 0 at the design frequency and a hump of Vtol on each side, or V = Vtol there and on two
// side humps), damped as Klipper defines them (klippy/extras/shaper_defs.py,
// get_2hump_ei_shaper and get_3hump_ei_shaper, "updated definitions" of 2025-09-16 in its
// Config_Changes.md), so that a frequency fitted here is the same shaper in Klipper (issue 31):
// each impulse's amplitude and its time in units of 1/f are cubics in ζ, at Vtol = 5 %,
//   A_i = Σ_j a_ij·ζ^j,  T_i = Σ_j t_ij·ζ^j / f,
// with the coefficients below (Klipper's published numbers, facts of its definition; the
// amplitudes are used divided by their sum, as Klipper's kinematics use them). Checked against
// Klipper's own shapers at 20-150 Hz and ζ 0-0.2 in tests/core/klipper_shaper_test.cc.
struct HumpCoefficients {
  double amplitude[4], time[4];  // ζ^0 … ζ^3
};
constexpr HumpCoefficients kTwoHump[] = {
    {{0.16054, 0.76699, 2.26560, -1.22750}, {0, 0, 0, 0}},
    {{0.33911, 0.45081, -2.58080, 1.73650}, {0.49890, 0.16270, -0.54262, 6.16180}},
    {{0.34089, -0.61533, -0.68765, 0.42261}, {0.99748, 0.18382, -1.58270, 8.17120}},
    {{0.15997, -0.60246, 1.00280, -0.93145}, {1.49920, -0.09297, -0.28338, 1.85710}}};
constexpr HumpCoefficients kThreeHump[] = {
    {{0.11275, 0.76632, 3.29160, -1.44380}, {0, 0, 0, 0}},
    {{0.23698, 0.61164, -2.57850, 4.85220}, {0.49974, 0.23834, 0.44559, 12.4720}},
    {{0.30008, -0.19062, -2.14560, 0.13744}, {0.99849, 0.29808, -2.36460, 23.3990}},
    {{0.23775, -0.73297, 0.46885, -2.08650}, {1.49870, 0.10306, -2.01390, 17.0320}},
    {{0.11244, -0.45439, 0.96382, -1.46000}, {1.99960, -0.28231, 0.61536, 5.40450}}};

// The multi-hump shaper at 1 Hz from its coefficients.
template <std::size_t N>
InputShaper MultiHumpUnit(const HumpCoefficients (&c)[N], double zeta) {
  auto cubic = [zeta](const double(&k)[4]) {
    return k[0] + zeta * (k[1] + zeta * (k[2] + zeta * k[3]));
  };
  InputShaper s;
  double sum = 0;
  for (const HumpCoefficients& impulse : c) {
    s.amplitudes.push_back(cubic(impulse.amplitude));
    s.times.push_back(cubic(impulse.time));
    sum += s.amplitudes.back();
  }
  for (double& a : s.amplitudes) a /= sum;
  return s;
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
      s = MultiHumpUnit(kTwoHump, zeta);
      break;
    case ShaperType::kThreeHumpEI:
      s = MultiHumpUnit(kThreeHump, zeta);
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
  const bool multi_hump = type == ShaperType::kTwoHumpEI || type == ShaperType::kThreeHumpEI;
  if (multi_hump && vtol != kDefaultVibrationTolerance) {
    throw std::invalid_argument(fmt::format(
        "input shaper {}: vibration tolerance {}: the multi-hump designs are fitted at {} only",
        ShaperName(type), vtol, kDefaultVibrationTolerance));
  }
  // Klipper's max_damping_ratio for the three-hump design, the range of its fit.
  constexpr double kThreeHumpMaxDamping = 0.2;
  if (type == ShaperType::kThreeHumpEI && damping > kThreeHumpMaxDamping) {
    throw std::invalid_argument(
        fmt::format("input shaper 3hump_ei: damping ratio {} is not in [0, {}] (its design's fit)",
                    damping, kThreeHumpMaxDamping));
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

namespace {

// Klipper's two offsets (KlipperSmoothing) at acceleration a are c0 + c1·a (the 90° turn) and
// c2·a (the 180° one), m.
struct KlipperOffsets {
  double c0 = 0, c1 = 0, c2 = 0;
};
KlipperOffsets KlipperOffsetsOf(const InputShaper& shaper, double scv) {
  double sum = 0, centre = 0;
  for (std::size_t i = 0; i < shaper.times.size(); ++i) {
    sum += shaper.amplitudes[i];
    centre += shaper.amplitudes[i] * shaper.times[i];
  }
  KlipperOffsets o;
  if (!(sum > 0)) return o;
  centre /= sum;  // s, t_s
  for (std::size_t i = 0; i < shaper.times.size(); ++i) {
    const double a = shaper.amplitudes[i] / sum, dt = shaper.times[i] - centre;  // s
    if (shaper.times[i] >= centre) {
      o.c0 += std::sqrt(2.0) * a * scv * dt;
      o.c1 += std::sqrt(2.0) * a * 0.5 * dt * dt;
    }
    o.c2 += a * 0.5 * dt * dt;
  }
  return o;
}

}  // namespace

double KlipperSmoothing(const InputShaper& shaper, double accel, double scv) {
  if (!(accel >= 0) || !(scv >= 0)) {
    throw std::invalid_argument(fmt::format(
        "smoothing: acceleration {} m/s² and square corner velocity {} m/s must be >= 0", accel,
        scv));
  }
  const KlipperOffsets o = KlipperOffsetsOf(shaper, scv);
  return std::max(o.c0 + o.c1 * accel, o.c2 * accel);
}

double KlipperMaxAccel(const InputShaper& shaper, double scv, double target) {
  if (!(target > 0) || !(scv >= 0)) {
    throw std::invalid_argument(fmt::format(
        "max_accel: smoothing target {} m must be > 0 and square corner velocity {} m/s >= 0",
        target, scv));
  }
  const KlipperOffsets o = KlipperOffsetsOf(shaper, scv);
  if (o.c0 > target) return 0.0;  // Klipper's: the test at 1e-9 mm/s² fails
  const double turn = o.c1 > 0 ? (target - o.c0) / o.c1 : std::numeric_limits<double>::infinity();
  const double reverse = o.c2 > 0 ? target / o.c2 : std::numeric_limits<double>::infinity();
  return std::min(turn, reverse);
}

double CornerDeviation(const InputShaper& shaper, double accel, double corner_velocity) {
  if (!(accel >= 0) || !(corner_velocity >= 0)) {
    throw std::invalid_argument(fmt::format(
        "corner deviation: acceleration {} m/s² and corner velocity {} m/s must be >= 0", accel,
        corner_velocity));
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

double MaxAccelForCornerDeviation(const InputShaper& shaper, double smoothing_limit,
                                  double corner_velocity) {
  if (!(smoothing_limit > 0)) {
    throw std::invalid_argument(
        fmt::format("max acceleration: corner deviation limit {} m must be > 0", smoothing_limit));
  }
  if (CornerDeviation(shaper, 0.0, corner_velocity) >= smoothing_limit) return 0.0;
  // The deviation rises with the acceleration (D and U both do): bracket, then bisect.
  double lo = 0, hi = 1;  // m/s²
  while (CornerDeviation(shaper, hi, corner_velocity) < smoothing_limit) {
    lo = hi;
    hi *= 2;
    if (hi > 1e15) return std::numeric_limits<double>::infinity();  // a shaper of no duration
  }
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    (CornerDeviation(shaper, mid, corner_velocity) < smoothing_limit ? lo : hi) = mid;
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
      scan.push_back({f, v, KlipperSmoothing(s, options.reference_accel, options.corner_velocity)});
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
    fit.max_accel = KlipperMaxAccel(fit.shaper, options.corner_velocity, options.smoothing_limit);
    fit.corner_deviation =
        CornerDeviation(fit.shaper, options.reference_accel, options.corner_velocity);
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
