// Input shaping (SPEC §9, issue 18): impulse sequences convolved with a motion command so that a
// lightly damped mode (a printer's belt axis) is left ringing less; the vibration a shaper leaves,
// the smoothing it adds to a toolhead's path, fitting one to a measured resonance spectrum, and
// that spectrum from an accelerometer log (Welch's method). Knows nothing of MuJoCo.
//
// A shaper is impulses A_i at times T_i (Σ A_i = 1, T_0 = 0); the shaped command is
// u_s(t) = Σ A_i·u(t − T_i). Every shaper here is designed for a frequency f (Hz) and a damping
// ratio ζ; its times scale as 1/f and its amplitudes depend on ζ (and Vtol) only.
//
//   zv        2 impulses over t_d/2, zero vibration at f           (Singer & Seering 1990)
//   mzv       3 impulses over 0.75·t_d, zero vibration at f        (Klipper's "modified ZV")
//   zvd       3 impulses over t_d, zero vibration and slope at f   (Singer & Seering 1990)
//   ei        3 impulses over t_d, V = Vtol at f, zero on each side (Singhose et al. 1994/1996)
//   2hump_ei  4 impulses over about 1.5/f, two humps of V ≤ Vtol  (Singhose et al. 1997, damped
//   3hump_ei  5 impulses over about 2/f, three humps of V ≤ Vtol   as Klipper defines them)
// with t_d = 1/(f·√(1−ζ²)) the damped period. shaper.cc gives each formula and its source.
//
// Two measures of the path a shaper smooths: Klipper's `smoothing` and `max_accel`
// (KlipperSmoothing, KlipperMaxAccel: its definitions, the numbers its calibrate_shaper.py prints
// beside a shaper's config lines), and this project's own corner deviation (CornerDeviation: how
// far the shaped path of a toolhead cuts a square corner, a length one can see on a part).
#ifndef MJSTEPPER_CORE_SHAPER_H_
#define MJSTEPPER_CORE_SHAPER_H_

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace mjstepper {

enum class ShaperType { kZV, kMZV, kZVD, kEI, kTwoHumpEI, kThreeHumpEI };

/// ζ a shaper is designed for when none is given: Klipper's default, "a good all-round value"
/// for printers (Klipper docs, Resonance_Compensation.md, "Technical details").
inline constexpr double kDefaultShaperDamping = 0.1;
/// The EI family's vibration tolerance: 5 %, a twenty-fold reduction (Singhose et al.'s usual
/// design value; the tolerance Klipper's EI shapers are tuned to, same page).
inline constexpr double kDefaultVibrationTolerance = 0.05;
/// The largest design damping accepted: the EI curve fit holds V(f) within 15 % of Vtol up to it
/// (measured over Vtol ∈ [0.02, 0.2]; beyond, the fit is extrapolated).
inline constexpr double kMaxShaperDamping = 0.3;
/// Klipper's default square_corner_velocity, 5 mm/s (Resonance_Compensation.md, "Selecting
/// max_accel": raising it raises the smoothing): the speed kept through a 90° corner.
inline constexpr double kSquareCornerVelocity = 0.005;  // m/s
/// Klipper's smoothing target for max_accel, 0.12 mm (shaper_calibrate.py, find_shaper_max_accel:
/// TARGET_SMOOTHING, "just some empirically chosen value which produces good projections for
/// max_accel without much smoothing"). Also the corner deviation taken as acceptable
/// (MaxAccelForCornerDeviation): a quarter of a 0.4-0.45 mm extrusion width.
inline constexpr double kDefaultSmoothingLimit = 1.2e-4;  // m
/// The acceleration Klipper prints its smoothing at: 5000 mm/s² (_get_shaper_smoothing's default).
inline constexpr double kKlipperSmoothingAccel = 5.0;  // m/s²

struct InputShaper {
  std::string name;
  std::vector<double> amplitudes;  ///< Σ = 1, all > 0
  std::vector<double> times;       ///< s, increasing, times[0] = 0
  double duration() const { return times.empty() ? 0.0 : times.back(); }
};

/// All six, in the order above.
const std::vector<ShaperType>& AllShaperTypes();
/// "zv", "mzv", "zvd", "ei", "2hump_ei", "3hump_ei".
std::string_view ShaperName(ShaperType type);
/// The names above, any case; throws std::invalid_argument listing them.
ShaperType ParseShaperType(std::string_view name);

/// The shaper of `type` for a mode at `frequency` Hz (> 0, ≤ 1e5) and damping ratio `damping`
/// (ζ ∈ [0, kMaxShaperDamping]); `vtol` (∈ (0, 0.2]) is the EI family's vibration tolerance.
/// Throws std::invalid_argument beyond those ranges.
InputShaper MakeShaper(ShaperType type, double frequency, double damping = kDefaultShaperDamping,
                       double vtol = kDefaultVibrationTolerance);

/// The shaper of two in series, a·b: impulses A_i·B_j at T_i + T_j (for two modes; its
/// vibration is the product of the two, V_ab = V_a·V_b).
InputShaper Convolve(const InputShaper& a, const InputShaper& b);

/// SPEC §9's remaining vibration (Singer & Seering 1990): the amplitude a mode of `frequency` Hz
/// and damping ratio `damping` is left ringing with when a command ends, shaped, relative to the
/// same command unshaped (each measured as its command ends). 1 for no shaper.
double RemainingVibration(const InputShaper& shaper, double frequency, double damping);

/// Klipper's smoothing of `shaper` (m) at acceleration `accel` (m/s²) and square corner velocity
/// `scv` (m/s), by its definition (shaper_calibrate.py, _get_shaper_smoothing): with the impulses
/// about their centre t_s = Σ A_i·T_i / Σ A_i,
///   offset_90  = √2 · Σ_{T_i ≥ t_s} A_i·(scv + accel/2·(T_i − t_s))·(T_i − t_s) / Σ A_i,
///   offset_180 = Σ A_i·accel/2·(T_i − t_s)² / Σ A_i,
/// and the smoothing is the larger. Klipper's docs call these "abstract projected values".
double KlipperSmoothing(const InputShaper& shaper, double accel = kKlipperSmoothingAccel,
                        double scv = kSquareCornerVelocity);

/// Klipper's max_accel (m/s²) for `shaper`: the largest acceleration whose KlipperSmoothing at
/// `scv` stays at or below `target` (m; Klipper's 0.12 mm), found by Klipper by bisection to
/// 1e-8 mm/s² (find_shaper_max_accel). Both offsets are linear in the acceleration, so it is
/// their bounds' smaller, in closed form; 0 when the corner velocity alone reaches `target`.
/// (Klipper prints it rounded to 100 mm/s².)
double KlipperMaxAccel(const InputShaper& shaper, double scv = kSquareCornerVelocity,
                       double target = kDefaultSmoothingLimit);

/// This project's corner deviation of `shaper`, m: how far the shaped path of a toolhead cuts a
/// square corner. Both axes shaped alike; the toolhead decelerates at `accel` (m/s²) along X to
/// `corner_velocity` (m/s) at the corner, switches to Y at that speed and accelerates at `accel`
/// (the ramps longer than the shaper). The shaped position is Σ A_i·x(t − T_i); its distance from
/// the unshaped L is min(D(t), U(t)), with D(t) = Σ_{T_i>t} A_i·[v·(T_i − t) + a·(T_i − t)²/2] the
/// X distance still to go and U(t) = Σ_{T_i<t} A_i·[v·(t − T_i) + a·(t − T_i)²/2] the Y distance
/// made; D falls and U rises, so the largest deviation is where they cross (found by bisection).
/// For a symmetric shaper and v = 0 it is a·σ²/4, σ² = Σ A_i·(T_i − T̄)² the variance of the
/// impulse times (T̄ = Σ A_i·T_i): on any constant-acceleration segment the shaped path is the
/// unshaped one delayed by T̄ and offset by a·σ²/2 along the acceleration. Not Klipper's
/// smoothing: for the same shaper it is 0.6-0.7 of it.
double CornerDeviation(const InputShaper& shaper, double accel,
                       double corner_velocity = kSquareCornerVelocity);

/// The acceleration (m/s²) at which CornerDeviation equals `limit` (m); 0 when the corner
/// velocity alone already deviates that much.
double MaxAccelForCornerDeviation(const InputShaper& shaper, double limit = kDefaultSmoothingLimit,
                                  double corner_velocity = kSquareCornerVelocity);

/// A one-sided power spectral density.
struct Spectrum {
  std::vector<double> frequency;  ///< Hz, k·fs/N for k = 0 … N/2
  std::vector<double> psd;        ///< (input unit)²/Hz, e.g. (mm/s²)²/Hz for Klipper's logs
};

/// Welch's method: Hann-windowed segments of `segment` samples (periodic Hann, the DFT-even
/// window), overlapping by half, each detrended by its mean (an accelerometer's gravity and
/// offset), averaged periodograms scaled as a density, one-sided (every bin but 0 and N/2
/// doubled), so that Σ psd·fs/N is the window-weighted mean square of the detrended samples.
/// `fs` in Hz. Throws std::invalid_argument for fewer samples than a segment or a segment < 2.
Spectrum Welch(const std::vector<double>& samples, double fs, std::size_t segment);

/// The vibration energy `shaper` leaves over a measured spectrum, as a fraction of the
/// unshaped: Σ w(f)·max_ζ V(f, ζ)² / Σ w(f), ζ over `dampings`, with weights
/// w = max(psd − floor_fraction·max(psd), 0). V² because the PSD is power (amplitude²).
double ShapedVibration(const InputShaper& shaper, const std::vector<double>& frequency,
                       const std::vector<double>& psd, const std::vector<double>& dampings,
                       double floor_fraction);

struct FitOptions {
  double min_frequency = 5;     ///< Hz, the shaper frequencies scanned …
  double max_frequency = 200;   ///< Hz
  double frequency_step = 0.2;  ///< Hz
  double design_damping = kDefaultShaperDamping;
  /// SPEC §9's test damping ratios: a printer's ζ is unknown, so the worst of these counts.
  std::vector<double> test_dampings = {0.075, 0.1, 0.15};
  double vtol = kDefaultVibrationTolerance;
  /// The PSD below this fraction of its highest bin is not counted (ShapedVibration): the
  /// flanks of a resonance sweep there are the printer following its own command and sensor
  /// noise, not ringing, and a shaper passes them unchanged (V → 1 far below its frequency).
  /// Counted, they outweigh the peak and drag every fit to the lowest frequencies scanned (a
  /// synthetic 40 Hz mode, ζ = 0.1: 3hump_ei's least-vibration frequency fell from 47 to 5.6 Hz).
  double psd_floor = 0.05;
  /// Per type, the frequencies whose vibration is within this much of the type's least count
  /// as equally good, and the one with the least smoothing among them is taken: 0.0005, five
  /// hundredths of a percent of the vibration energy. (0.0025, the EI tolerance 5 % squared, let
  /// the least-smoothing pick drift up the flank: MZV 4.9 % above the CoreXY's 61.2 Hz X mode and
  /// EI 23 % above the bed-slinger's 50.4 Hz Y mode; 0.0005 keeps them within 2.3 %.)
  double vibration_margin = 0.0005;
  double smoothing_limit = kDefaultSmoothingLimit;  ///< m, Klipper's target for max_accel
  double corner_velocity = kSquareCornerVelocity;   ///< m/s, Klipper's scv
  /// m/s², ShaperFit::smoothing's and corner_deviation's (Klipper's 5000 mm/s²)
  double reference_accel = kKlipperSmoothingAccel;
  std::vector<ShaperType> types = AllShaperTypes();
};

struct ShaperFit {
  InputShaper shaper;
  ShaperType type = ShaperType::kZV;
  double frequency = 0;         ///< Hz
  double vibration = 0;         ///< ShapedVibration, the remaining fraction of the vibration energy
  double smoothing = 0;         ///< m, KlipperSmoothing at FitOptions::reference_accel
  double max_accel = 0;         ///< m/s², KlipperMaxAccel for FitOptions::smoothing_limit
  double corner_deviation = 0;  ///< m, CornerDeviation at FitOptions::reference_accel
};

/// For each type, scans the shaper frequency and keeps the least-smoothing (KlipperSmoothing;
/// highest) frequency whose vibration is within `vibration_margin` of the type's least. `frequency`
/// and `psd` as Welch gives them (the same length, psd ≥ 0 and not all 0); throws
/// std::invalid_argument.
std::vector<ShaperFit> FitShapers(const std::vector<double>& frequency,
                                  const std::vector<double>& psd, const FitOptions& options = {});

/// The vibration energy a recommended shaper may leave: 1 % (10 % in amplitude, the "vibration
/// reduction 10x" of Klipper's shaper table, Resonance_Compensation.md).
inline constexpr double kRecommendVibration = 0.01;

/// The fit with the largest max_accel (the least smoothing) among those leaving at most
/// `max_vibration`; if none does, the one leaving the least vibration. Throws on an empty list.
ShaperFit Recommend(const std::vector<ShaperFit>& fits, double max_vibration = kRecommendVibration);

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_SHAPER_H_
