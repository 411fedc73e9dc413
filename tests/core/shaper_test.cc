#include "core/shaper.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/command_profile.h"
#include "core/units.h"

namespace mjstepper {
namespace {

using std::numbers::pi;
using ::testing::HasSubstr;

double DampedPeriod(double f, double zeta) { return 1 / (f * std::sqrt(1 - zeta * zeta)); }

// The band of frequency ratios r = f/f_design around 1 over which V(r·f) <= limit, on a grid of
// 1e-4: {low, high}.
std::pair<double, double> Band(const InputShaper& s, double f, double zeta, double limit) {
  const double step = 1e-4;
  double lo = 1, hi = 1;
  while (lo > step && RemainingVibration(s, (lo - step) * f, zeta) <= limit) lo -= step;
  while (hi < 3 && RemainingVibration(s, (hi + step) * f, zeta) <= limit) hi += step;
  return {lo, hi};
}

// The largest V over the ratios [lo, hi] (grid of 1e-4).
double MaxV(const InputShaper& s, double f, double zeta, double lo, double hi) {
  double m = 0;
  for (double r = lo; r <= hi; r += 1e-4) m = std::max(m, RemainingVibration(s, r * f, zeta));
  return m;
}

// The least V over the ratios [lo, hi] (grid of 1e-4).
double MinV(const InputShaper& s, double f, double zeta, double lo, double hi) {
  double m = 1e9;
  for (double r = lo; r <= hi; r += 1e-4) m = std::min(m, RemainingVibration(s, r * f, zeta));
  return m;
}

// SPEC §9's closed forms, to rounding (1e-15): the code computes exactly these expressions.
TEST(Shaper, ZvAndZvdAreSpecClosedForms) {
  const double f = 40, zeta = 0.1;
  const double k = std::exp(-zeta * pi / std::sqrt(1 - zeta * zeta));
  const double td = DampedPeriod(f, zeta);
  const InputShaper zv = MakeShaper(ShaperType::kZV, f, zeta);
  ASSERT_EQ(zv.amplitudes.size(), 2u);
  EXPECT_NEAR(zv.amplitudes[0], 1 / (1 + k), 1e-15);
  EXPECT_NEAR(zv.amplitudes[1], k / (1 + k), 1e-15);
  EXPECT_NEAR(zv.times[1], td / 2, 1e-15);
  const InputShaper zvd = MakeShaper(ShaperType::kZVD, f, zeta);
  ASSERT_EQ(zvd.amplitudes.size(), 3u);
  EXPECT_NEAR(zvd.amplitudes[0], 1 / ((1 + k) * (1 + k)), 1e-15);
  EXPECT_NEAR(zvd.amplitudes[1], 2 * k / ((1 + k) * (1 + k)), 1e-15);
  EXPECT_NEAR(zvd.amplitudes[2], k * k / ((1 + k) * (1 + k)), 1e-15);
  EXPECT_NEAR(zvd.times[1], td / 2, 1e-15);
  EXPECT_NEAR(zvd.times[2], td, 1e-15);
  EXPECT_EQ(zvd.name, "zvd");
}

// Every shaper: Σ A = 1 (1e-12, rounding), positive impulses at increasing times from 0, and its
// duration in damped periods (ZV 1/2, MZV 3/4, ZVD 1, EI 1: 1e-12 relative; 2HUMP about 3/2 and
// 3HUMP about 2: Klipper's fits in ζ give 1.427-1.499 and 1.966-2.000, so 5 %).
TEST(Shaper, AmplitudesSumToOneAndDurationsAreTheTypes) {
  const double durations[] = {0.5, 0.75, 1.0, 1.0, 1.5, 2.0};  // AllShaperTypes' order
  for (double zeta : {0.0, 0.1, 0.2, 0.3}) {
    for (size_t t = 0; t < AllShaperTypes().size(); ++t) {
      const ShaperType type = AllShaperTypes()[t];
      if (type == ShaperType::kThreeHumpEI && zeta > 0.2) {  // beyond its design's fit
        EXPECT_THROW(MakeShaper(type, 55, zeta), std::invalid_argument);
        continue;
      }
      const bool fitted = type == ShaperType::kTwoHumpEI || type == ShaperType::kThreeHumpEI;
      const InputShaper s = MakeShaper(type, 55, zeta);
      SCOPED_TRACE(s.name + " zeta " + std::to_string(zeta));
      double sum = 0;
      for (double a : s.amplitudes) {
        EXPECT_GT(a, 0);
        sum += a;
      }
      EXPECT_NEAR(sum, 1, 1e-12);
      EXPECT_EQ(s.times.front(), 0);
      for (size_t i = 1; i < s.times.size(); ++i) EXPECT_GT(s.times[i], s.times[i - 1]);
      EXPECT_NEAR(s.duration() / DampedPeriod(55, zeta) / durations[t], 1, fitted ? 0.05 : 1e-12);
      EXPECT_EQ(ParseShaperType(ShaperName(type)), type);
    }
  }
  EXPECT_EQ(ParseShaperType("2HUMP_EI"), ShaperType::kTwoHumpEI);
  EXPECT_THROW(ParseShaperType("zvdd"), std::invalid_argument);
  EXPECT_THROW(MakeShaper(ShaperType::kZV, 0), std::invalid_argument);
  EXPECT_THROW(MakeShaper(ShaperType::kZV, 40, 0.5), std::invalid_argument);
  EXPECT_THROW(MakeShaper(ShaperType::kEI, 40, 0.1, 0.5), std::invalid_argument);
}

// ZV, MZV and ZVD are built to leave nothing at their frequency (1e-12: rounding); ZVD also has
// zero slope there, so 0.1 % off it leaves ~(π/2·0.001)² ≈ 2.5e-6 (< 1e-5), while ZV, without
// that constraint, leaves ~π/2·0.001 ≈ 1.6e-3 (> 1e-3).
TEST(Shaper, ZeroVibrationShapersLeaveNoneAtTheirFrequency) {
  for (double zeta : {0.0, 0.05, 0.1, 0.2}) {
    SCOPED_TRACE(zeta);
    for (ShaperType type : {ShaperType::kZV, ShaperType::kMZV, ShaperType::kZVD}) {
      EXPECT_LT(RemainingVibration(MakeShaper(type, 40, zeta), 40, zeta), 1e-12);
    }
    EXPECT_LT(RemainingVibration(MakeShaper(ShaperType::kZVD, 40, zeta), 40.04, zeta), 1e-5);
    EXPECT_GT(RemainingVibration(MakeShaper(ShaperType::kZV, 40, zeta), 40.04, zeta), 1e-3);
  }
  EXPECT_EQ(RemainingVibration(InputShaper{"none", {1.0}, {0.0}}, 40, 0.1), 1.0);
}

// The EI curve fit does what it was fitted to (Singhose et al.): V = Vtol at the design frequency,
// a zero on each side and no hump above Vtol between them, to the fit's accuracy: V(f) within
// 5 % of Vtol (measured: 2.4 % at Vtol = 5 %, ζ = 0; 4.8 % at Vtol = 10 %, ζ = 0.05), the zeros
// below 5 % of Vtol (measured up to 0.6 % and 3.8 %), the hump within 5 % above it (1.2 %, 3.2 %).
// At ζ = 0 it is the closed form [(1+V)/4, (1−V)/2, (1+V)/4] to 1e-3 (measured 6e-4).
TEST(Shaper, EiLeavesItsToleranceAtItsFrequencyAndZerosEitherSide) {
  for (double vtol : {0.05, 0.1}) {
    for (double zeta : {0.0, 0.05, 0.1, 0.15, 0.2}) {
      SCOPED_TRACE(std::to_string(vtol) + " " + std::to_string(zeta));
      const InputShaper ei = MakeShaper(ShaperType::kEI, 40, zeta, vtol);
      EXPECT_NEAR(RemainingVibration(ei, 40, zeta) / vtol, 1, 0.05);
      EXPECT_LT(MinV(ei, 40, zeta, 0.7, 1.0), 0.05 * vtol);
      EXPECT_LT(MinV(ei, 40, zeta, 1.0, 1.35), 0.05 * vtol);
      EXPECT_LT(MaxV(ei, 40, zeta, 0.85, 1.15), 1.05 * vtol);
    }
  }
  const InputShaper ei0 = MakeShaper(ShaperType::kEI, 40, 0.0, 0.05);
  EXPECT_NEAR(ei0.amplitudes[0], 1.05 / 4, 1e-3);
  EXPECT_NEAR(ei0.amplitudes[1], 0.95 / 2, 1e-3);
  EXPECT_NEAR(ei0.amplitudes[2], 1.05 / 4, 1e-3);
}

// The multi-hump shapers, Klipper's fits in ζ of Singhose et al.'s designs at Vtol = 5 %, do what
// they were designed for to the fits' accuracy over ζ 0-0.2 (measured): two humps leave almost
// nothing at the design frequency (at most 0.32 %; 0.5 % here) and humps of Vtol on each side
// (the highest 0.0537 at ζ = 0, so 1.08·Vtol), three humps leave Vtol there (0.0443-0.0505: 12 %)
// and no more on their side humps (at most 0.0505: 1.02·Vtol), and Klipper's 3HUMP_EI at 40 Hz,
// ζ = 0.1 leaves 4.9 % at its design frequency (issue 31: the project's own design left 2.5 %).
TEST(Shaper, MultiHumpShapersKeepTheirHumpsWithinTheTolerance) {
  for (double zeta : {0.0, 0.05, 0.1, 0.15, 0.2}) {
    SCOPED_TRACE(zeta);
    const InputShaper two = MakeShaper(ShaperType::kTwoHumpEI, 40, zeta);
    const InputShaper three = MakeShaper(ShaperType::kThreeHumpEI, 40, zeta);
    EXPECT_LT(RemainingVibration(two, 40, zeta), 0.005);
    EXPECT_NEAR(RemainingVibration(three, 40, zeta) / 0.05, 1, 0.12);
    const double two_humps = MaxV(two, 40, zeta, 0.75, 1.25);  // the humps (0.83, 1.17 undamped)
    EXPECT_LT(two_humps, 1.08 * 0.05);
    EXPECT_GT(two_humps, 0.95 * 0.05);  // the humps are there: the tolerance is used
    EXPECT_LT(MaxV(three, 40, zeta, 0.7, 1.3), 1.02 * 0.05);  // (0.68, 1, 1.32 undamped)
  }
  EXPECT_NEAR(RemainingVibration(MakeShaper(ShaperType::kThreeHumpEI, 40, 0.1), 40, 0.1), 0.049,
              0.0005);
  EXPECT_THROW(MakeShaper(ShaperType::kTwoHumpEI, 40, 0.1, 0.1), std::invalid_argument);
}

// Insensitivity, the width of the band where V <= Vtol = 5 % in units of the design frequency.
// Undamped, each shaper's V is a polynomial in one cosine, and its band edge is a root we solve
// here apart from RemainingVibration (with θ = π·f/f_d):
//   EI:     V = |A2 + 2A1·cos θ|;  edge cos θ = (Vtol − A2)/(2A1), A = [(1+V)/4, (1−V)/2, …].
//   2HUMP:  V = 2c·|4A1c² − 3A1 + A2|, c = cos(θ/2); edge: 8A1c³ − 2(3A1 − A2)c = Vtol, the root
//           above the outer zero, with Singhose et al.'s closed-form amplitudes
//           A1 = (3X² + 2X + 3Vtol²)/(16X), X = (Vtol²·(√(1 − Vtol²) + 1))^{1/3}, A2 = 1/2 − A1.
//   3HUMP:  V = |A3 + 2A2·cos θ + 2A1·cos 2θ|, A1 = (1 + 3Vtol + 2√(2Vtol(Vtol + 1)))/16,
//           A2 = (1 − Vtol)/4, A3 = 1 − 2(A1 + A2); edge: 4A1c² + 2A2c + A3 − 2A1 = Vtol, larger
//           root.
// Band = 2·(1 − θ_edge/π). These give 0.399, 0.724 and 0.964 (EI's 0.4 is Singhose et al.'s
// figure). EI, a curve fit whose amplitudes at ζ = 0 are off the closed form by up to 4e-4, must
// match within 3e-3. The multi-hump shapers are Klipper's fits, whose humps reach up to 1.08·Vtol
// (MultiHumpShapersKeepTheirHumpsWithinTheTolerance), so their band is taken at 1.1·Vtol: it
// holds the closed form's and is within 0.02 of it (measured 0.737 and 0.973); the two-hump's
// damped (ζ 0.1) is no narrower than the undamped closed form (0.870; the three-hump's, 0.907,
// is: its damped side humps reach 1.1·Vtol further in).
TEST(Shaper, EiFamilyInsensitivityMatchesTheClosedForms) {
  const double v = 0.05;
  auto numeric = [](ShaperType type, double zeta, double level) {
    const auto [lo, hi] = Band(MakeShaper(type, 40, zeta), 40, zeta, level);
    return hi - lo;
  };
  const double ei_edge = std::acos((v - (1 - v) / 2) / ((1 + v) / 2));
  const double ei_band = 2 * (1 - ei_edge / pi);
  // Two humps: the closed-form amplitudes, then bisection for the cubic's root in [c_zero, 1].
  const double x = std::cbrt(v * v * (std::sqrt(1 - v * v) + 1));
  const double a1 = (3 * x * x + 2 * x + 3 * v * v) / (16 * x), a2 = 0.5 - a1;
  double lo = std::sqrt((3 * a1 - a2) / (4 * a1)), hi = 1;
  for (int i = 0; i < 200; ++i) {
    const double c = 0.5 * (lo + hi);
    (8 * a1 * c * c * c - 2 * (3 * a1 - a2) * c < v ? lo : hi) = c;
  }
  const double two_band = 2 * (1 - 2 * std::acos(lo) / pi);
  const double b1 = (1 + 3 * v + 2 * std::sqrt(2 * v * (v + 1))) / 16, b2 = (1 - v) / 4;
  const double b3 = 1 - 2 * (b1 + b2);
  const double c3 = (-2 * b2 + std::sqrt(4 * b2 * b2 - 16 * b1 * (b3 - 2 * b1 - v))) / (8 * b1);
  const double three_band = 2 * (1 - std::acos(c3) / pi);
  EXPECT_NEAR(ei_band, 0.399, 1e-3);
  EXPECT_NEAR(numeric(ShaperType::kEI, 0.0, v), ei_band, 3e-3);
  EXPECT_GT(two_band, 0.72);
  EXPECT_GT(three_band, 0.96);
  const double two = numeric(ShaperType::kTwoHumpEI, 0.0, 1.1 * v);
  const double three = numeric(ShaperType::kThreeHumpEI, 0.0, 1.1 * v);
  EXPECT_GE(two, two_band);
  EXPECT_LT(two, two_band + 0.02);
  EXPECT_GE(three, three_band);
  EXPECT_LT(three, three_band + 0.02);
  EXPECT_GE(numeric(ShaperType::kTwoHumpEI, 0.1, 1.1 * v), two_band);
  // (Damped EI's hump is Vtol to the fit's 3 %, so its 5 % band is not contiguous: no check.)
}

// Two shapers in series leave the product of their vibrations (the vector sums multiply; 1e-12)
// and their impulses are the pairwise products, Σ = 1.
TEST(Shaper, ConvolvedShapersMultiplyTheirVibrations) {
  const InputShaper a = MakeShaper(ShaperType::kZV, 40), b = MakeShaper(ShaperType::kMZV, 63);
  const InputShaper c = Convolve(a, b);
  EXPECT_EQ(c.amplitudes.size(), 6u);
  EXPECT_NEAR(c.duration(), a.duration() + b.duration(), 1e-15);
  for (double f : {20.0, 40.0, 51.0, 63.0, 90.0}) {
    for (double zeta : {0.0, 0.1}) {
      EXPECT_NEAR(RemainingVibration(c, f, zeta),
                  RemainingVibration(a, f, zeta) * RemainingVibration(b, f, zeta), 1e-12);
    }
  }
}

// ShapedVibration by hand: bins of PSD 1, 0.04 and 0.5 at 40, 20 and 80 Hz with the floor at 5 %
// of the highest weigh 0.95, 0 and 0.45, each by the worst V² over the test dampings (1e-15).
TEST(ShaperFit, ShapedVibrationWeighsThePsdAboveItsFloor) {
  const InputShaper s = MakeShaper(ShaperType::kMZV, 45);
  const std::vector<double> dampings = {0.05, 0.2};
  auto worst2 = [&](double f) {
    const double v = std::max(RemainingVibration(s, f, 0.05), RemainingVibration(s, f, 0.2));
    return v * v;
  };
  const double expected = (0.95 * worst2(40) + 0.45 * worst2(80)) / 1.4;
  EXPECT_NEAR(ShapedVibration(s, {40, 20, 80}, {1, 0.04, 0.5}, dampings, 0.05), expected, 1e-15);
  EXPECT_THROW(ShapedVibration(s, {40, 20}, {1, 0.04, 0.5}, dampings, 0.05), std::invalid_argument);
  EXPECT_THROW(ShapedVibration(s, {40}, {0.0}, dampings, 0.05), std::invalid_argument);
}

// ---- Smoothing ---------------------------------------------------------------------------------

// The corner, simulated: X decelerates at a to v at the corner (t = 0), Y then accelerates from v;
// both convolved with the shaper on a grid of duration/2e5, and the largest distance of the shaped
// point from the unshaped L taken. That largest distance is a corner (D falling, U rising), which
// the grid misses by up to a step's change, ~2e-5 relative (measured up to 1e-5): Smoothing must
// be at least the grid's (1e-12) and within 3e-5 of it.
TEST(Shaper, SmoothingIsTheLargestCornerDeviation) {
  for (ShaperType type :
       {ShaperType::kZV, ShaperType::kMZV, ShaperType::kEI, ShaperType::kThreeHumpEI}) {
    for (double v : {0.0, kSquareCornerVelocity, 0.05}) {
      const InputShaper s = MakeShaper(type, 40, 0.1);
      const double a = 5.0;  // m/s²
      auto x_to_go = [&](double t) { return t < 0 ? v * -t + 0.5 * a * t * t : 0.0; };
      auto y_made = [&](double t) { return t > 0 ? v * t + 0.5 * a * t * t : 0.0; };
      double worst = 0;
      const int n = 200000;
      for (int k = 0; k <= n; ++k) {
        const double t = s.duration() * k / n;
        double xs = 0, ys = 0;
        for (size_t i = 0; i < s.times.size(); ++i) {
          xs += s.amplitudes[i] * x_to_go(t - s.times[i]);
          ys += s.amplitudes[i] * y_made(t - s.times[i]);
        }
        worst = std::max(worst, std::min(xs, ys));  // the distance to the L: Xc − x or y
      }
      SCOPED_TRACE(s.name + " v " + std::to_string(v));
      EXPECT_GE(CornerDeviation(s, a, v), worst * (1 - 1e-12));
      EXPECT_NEAR(CornerDeviation(s, a, v) / worst, 1, 3e-5);
    }
  }
}

// A symmetric shaper (undamped) at v = 0 cuts the corner by a·σ²/4, σ² the variance of its
// impulse times: undamped ZV (σ² = T²/16, T = 1/f) gives a/(64f²), ZVD (σ² = T²/8) a/(32f²)
// (1e-12 relative: bisection to rounding).
TEST(Shaper, SymmetricShapersSmoothByAQuarterOfTheirVariance) {
  const double f = 40, a = 3.0;
  EXPECT_NEAR(CornerDeviation(MakeShaper(ShaperType::kZV, f, 0.0), a, 0.0) * 64 * f * f / a, 1,
              1e-12);
  EXPECT_NEAR(CornerDeviation(MakeShaper(ShaperType::kZVD, f, 0.0), a, 0.0) * 32 * f * f / a, 1,
              1e-12);
}

// On a constant-acceleration segment a shaped ramp is the unshaped one delayed by T̄ = Σ A_i·T_i
// and ahead by α·σ²/2 (the identity Smoothing's documentation rests on), through CommandProfile:
// a speed ramp of α = 2π/0.8 rad/s² shaped by damped EI, inside the ramp (1e-12 rad, rounding).
TEST(Shaper, ShapedRampIsDelayedAndOffsetByTheVariance) {
  const CommandProfile raw = CommandProfile::Parse("ramp(0rpm, 60rpm, 0.8s)");
  const CommandProfile shaped = CommandProfile::Parse("shaped(ramp(0rpm, 60rpm, 0.8s), ei 30Hz)");
  const InputShaper& s = *shaped.shaper();
  double mean = 0, variance = 0;
  for (size_t i = 0; i < s.times.size(); ++i) mean += s.amplitudes[i] * s.times[i];
  for (size_t i = 0; i < s.times.size(); ++i) {
    variance += s.amplitudes[i] * (s.times[i] - mean) * (s.times[i] - mean);
  }
  const double alpha = kTwoPi / 0.8;
  for (double t : {0.2, 0.5, 0.75}) {
    EXPECT_NEAR(shaped.Angle(t), raw.Angle(t - mean) + 0.5 * alpha * variance, 1e-12);
  }
}

// MaxAccelForCornerDeviation inverts CornerDeviation (1e-9 relative: bisection), scales as f² at
// v = 0 (a shaper twice as fast smooths a quarter as much; 1e-9), and is 0 when the corner
// velocity alone already cuts the corner by the limit.
TEST(Shaper, MaxAccelForCornerDeviationGivesItsLimit) {
  const InputShaper ei = MakeShaper(ShaperType::kEI, 45);
  const double a = MaxAccelForCornerDeviation(ei);
  EXPECT_GT(a, 0);
  EXPECT_NEAR(CornerDeviation(ei, a) / kDefaultSmoothingLimit, 1, 1e-9);
  const double a40 = MaxAccelForCornerDeviation(MakeShaper(ShaperType::kMZV, 40), 1e-4, 0.0);
  const double a80 = MaxAccelForCornerDeviation(MakeShaper(ShaperType::kMZV, 80), 1e-4, 0.0);
  EXPECT_NEAR(a80 / a40, 4, 4e-9);
  EXPECT_EQ(MaxAccelForCornerDeviation(MakeShaper(ShaperType::kThreeHumpEI, 10), 1e-4, 1.0), 0.0);
}

// Klipper's max_accel inverts Klipper's smoothing (1e-12: a closed form), scales as f² at
// scv = 0, and is 0 when the corner velocity alone reaches the target. Klipper's smoothing is
// not the corner deviation: for MZV at 61.8 Hz and 5000 mm/s² it is larger (0.6-0.7 of it, the
// issue's 0.64).
TEST(Shaper, KlippersMaxAccelGivesItsSmoothingTarget) {
  const InputShaper mzv = MakeShaper(ShaperType::kMZV, 61.8);
  const double a = KlipperMaxAccel(mzv);
  EXPECT_NEAR(KlipperSmoothing(mzv, a) / kDefaultSmoothingLimit, 1, 1e-12);
  EXPECT_GT(KlipperSmoothing(mzv, 1.0001 * a), kDefaultSmoothingLimit);
  const double a40 = KlipperMaxAccel(MakeShaper(ShaperType::kEI, 40), 0.0);
  const double a80 = KlipperMaxAccel(MakeShaper(ShaperType::kEI, 80), 0.0);
  EXPECT_NEAR(a80 / a40, 4, 1e-12);
  EXPECT_EQ(KlipperMaxAccel(MakeShaper(ShaperType::kThreeHumpEI, 10), 1.0), 0.0);
  const double ratio = CornerDeviation(mzv, 5.0) / KlipperSmoothing(mzv, 5.0);
  std::printf("MZV 61.8 Hz at 5000 mm/s²: corner deviation / Klipper's smoothing = %.3f\n", ratio);
  EXPECT_GT(ratio, 0.55);
  EXPECT_LT(ratio, 0.75);
}

// ---- Welch -------------------------------------------------------------------------------------

// A sine of amplitude A off the bin grid: the PSD integrated over ±10 Hz is its power A²/2 (1 %:
// the Hann window's leakage beyond 5 bins is < 1e-4, the remainder is the window's scalloping,
// which the density scaling's Σw² conserves), peaking in the bin nearest to it.
TEST(Welch, SineHasItsPower) {
  const double fs = 3200, f0 = 41.3, amp = 250;  // mm/s²
  std::vector<double> x(32000);
  for (size_t k = 0; k < x.size(); ++k) x[k] = 9810 + amp * std::sin(kTwoPi * f0 * k / fs);
  const Spectrum s = Welch(x, fs, 1600);
  ASSERT_EQ(s.psd.size(), 801u);
  const double df = s.frequency[1];
  EXPECT_DOUBLE_EQ(df, 2.0);
  double power = 0;
  size_t peak = 0;
  for (size_t k = 0; k < s.psd.size(); ++k) {
    if (std::abs(s.frequency[k] - f0) <= 10) power += s.psd[k] * df;
    if (s.psd[k] > s.psd[peak]) peak = k;
  }
  EXPECT_NEAR(power / (amp * amp / 2), 1, 0.01);
  EXPECT_NEAR(s.frequency[peak], f0, df / 2);
}

// Parseval: Σ psd·fs/N is the mean over the segments of Σ(w·(x − x̄))²/Σw², exactly (1e-10
// relative, rounding), for an even and an odd segment; white noise of variance σ² has the level
// 2σ²/fs (5 %: 199 averaged segments of 400 bins).
TEST(Welch, ParsevalHoldsAndWhiteNoiseIsFlat) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 3.0);
  std::vector<double> x(40000);
  for (double& v : x) v = 5 + noise(rng);
  for (size_t n : {800u, 801u}) {
    const Spectrum s = Welch(x, 1000, n);
    double integral = 0;
    for (double p : s.psd) integral += p * 1000.0 / n;
    double expected = 0, windows = 0;
    for (size_t start = 0; start + n <= x.size(); start += n / 2, ++windows) {
      double mean = 0, num = 0, den = 0;
      for (size_t k = 0; k < n; ++k) mean += x[start + k] / n;
      for (size_t k = 0; k < n; ++k) {
        const double w = 0.5 - 0.5 * std::cos(kTwoPi * k / n);
        num += w * w * (x[start + k] - mean) * (x[start + k] - mean);
        den += w * w;
      }
      expected += num / den;
    }
    EXPECT_NEAR(integral / (expected / windows), 1, 1e-10) << n;
    double level = 0;
    for (size_t k = 1; k < s.psd.size(); ++k) level += s.psd[k] / (s.psd.size() - 1);
    EXPECT_NEAR(level / (2 * 9.0 / 1000), 1, 0.05) << n;
  }
  EXPECT_THROW(Welch(x, 1000, 50000), std::invalid_argument);
  EXPECT_THROW(Welch(x, 1000, 1), std::invalid_argument);
}

// ---- Fitting -----------------------------------------------------------------------------------

// A measured spectrum of one 40 Hz mode, ζ = 0.1, as TEST_RESONANCES sees it: the sweep's
// acceleration grows as f (SPEC §9: accel_per_hz·f), so its PSD ∝ f² times the transmissibility
// |T|² = (1 + (2ζr)²)/((1 − r²)² + (2ζr)²), r = f/40; bins every 2 Hz from 5 to 133 Hz.
void OneMode(std::vector<double>* f, std::vector<double>* psd) {
  for (double x = 5; x <= 133; x += 2) {
    const double r = x / 40, z = 0.1;
    f->push_back(x);
    psd->push_back(r * r * (1 + 4 * z * z * r * r) /
                   ((1 - r * r) * (1 - r * r) + 4 * z * z * r * r));
  }
}

// Each fit is within its margin of the least vibration its type leaves in the scan (checked on
// a 1 Hz grid), no frequency leaving as little has less smoothing (the same grid), the
// zero-vibration shapers land near the mode (ZV and MZV within 10 %: the worst test damping pulls
// them a little off), and max_accel gives the smoothing limit.
TEST(ShaperFit, EachTypeTakesTheLeastSmoothingWithinItsMargin) {
  std::vector<double> f, psd;
  OneMode(&f, &psd);
  FitOptions options;
  const std::vector<ShaperFit> fits = FitShapers(f, psd, options);
  ASSERT_EQ(fits.size(), 6u);
  for (const ShaperFit& fit : fits) {
    SCOPED_TRACE(fit.shaper.name);
    // A 1 Hz grid, a subset of the scan's 0.2 Hz one: its least is no lower than the scan's.
    double least = 1;
    for (double fs = 5; fs <= 200; fs += 1) {
      const InputShaper s = MakeShaper(fit.type, fs, options.design_damping);
      const double v = ShapedVibration(s, f, psd, options.test_dampings, options.psd_floor);
      least = std::min(least, v);
      // Leaving no more than the fit, it was a candidate: then it must not smooth less.
      if (v <= fit.vibration - 1e-12) {
        EXPECT_GE(KlipperSmoothing(s, options.reference_accel), fit.smoothing - 1e-15) << fs;
      }
    }
    EXPECT_LE(fit.vibration, least + options.vibration_margin + 1e-12);
    EXPECT_NEAR(KlipperSmoothing(fit.shaper, options.reference_accel), fit.smoothing, 1e-15);
    EXPECT_NEAR(KlipperSmoothing(fit.shaper, fit.max_accel) / options.smoothing_limit, 1, 1e-12);
    EXPECT_NEAR(CornerDeviation(fit.shaper, options.reference_accel), fit.corner_deviation, 1e-15);
  }
  EXPECT_NEAR(fits[0].frequency / 40, 1, 0.1);  // zv
  EXPECT_NEAR(fits[1].frequency / 40, 1, 0.1);  // mzv
  // The EI family is tuned above the mode (their bands reach down).
  for (int k : {3, 4, 5}) EXPECT_GT(fits[k].frequency, 40) << fits[k].shaper.name;
}

// The rule: among the fits leaving at most 1 % of the energy, the largest max_accel; none under
// it, the least vibration.
TEST(ShaperFit, RecommendTakesTheFastestQuietEnoughShaper) {
  auto fit = [](const char* name, double vibration, double max_accel) {
    ShaperFit f;
    f.shaper.name = name;
    f.vibration = vibration;
    f.max_accel = max_accel;
    return f;
  };
  const std::vector<ShaperFit> fits = {fit("zv", 0.03, 9), fit("mzv", 0.008, 6),
                                       fit("ei", 0.004, 5), fit("2hump_ei", 0.002, 4)};
  EXPECT_EQ(Recommend(fits).shaper.name, "mzv");
  EXPECT_EQ(Recommend(fits, 0.005).shaper.name, "ei");
  EXPECT_EQ(Recommend(fits, 0.001).shaper.name, "2hump_ei");
  EXPECT_THROW(Recommend({}), std::invalid_argument);
}

// End to end: SPEC §9's TEST_RESONANCES on a 40 Hz mode (ζ = 0.1): the frame shaken at
// 75 mm/s² per Hz while the frequency rises from 5 to 133 Hz at 1 Hz/s, the accelerometer on the
// mass sampled at 3200 Hz (a Klipper log's rate), Welch with 0.5 s segments over the swept band:
// the PSD peaks within a bin (2 Hz) of the mode, and the ZV and MZV fits land within 10 % of it.
TEST(ShaperFit, ResonanceTestLogOfOneModeFitsItsFrequency) {
  const double fs = 3200, w = kTwoPi * 40, zeta = 0.1;
  std::vector<double> accel;
  double z = 0, zd = 0;  // the mass relative to the frame, mm and mm/s
  const int sub = 8;
  const double h = 1 / (fs * sub);
  auto base = [](double t) {  // the frame's acceleration, mm/s²: f = 5 + t Hz
    return 75 * (5 + t) * std::sin(kTwoPi * (5 * t + 0.5 * t * t));
  };
  for (int k = 0; k < 128 * 3200; ++k) {
    for (int i = 0; i < sub; ++i) {  // RK4 of z'' = −2ζωz' − ω²z − base(t)
      const double t = (k * sub + i) * h;
      auto acc = [&](double tt, double p, double v) {
        return -2 * zeta * w * v - w * w * p - base(tt);
      };
      const double k1v = acc(t, z, zd), k1p = zd;
      const double k2v = acc(t + h / 2, z + 0.5 * h * k1p, zd + 0.5 * h * k1v);
      const double k2p = zd + 0.5 * h * k1v;
      const double k3v = acc(t + h / 2, z + 0.5 * h * k2p, zd + 0.5 * h * k2v);
      const double k3p = zd + 0.5 * h * k2v;
      const double k4v = acc(t + h, z + h * k3p, zd + h * k3v), k4p = zd + h * k3v;
      z += h / 6 * (k1p + 2 * k2p + 2 * k3p + k4p);
      zd += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
    }
    accel.push_back(-2 * zeta * w * zd - w * w * z);  // the mass's absolute acceleration
  }
  const Spectrum s = Welch(accel, fs, 1600);
  std::vector<double> f, psd;  // the swept band
  for (size_t k = 0; k < s.frequency.size(); ++k) {
    if (s.frequency[k] >= 5 && s.frequency[k] <= 133) {
      f.push_back(s.frequency[k]);
      psd.push_back(s.psd[k]);
    }
  }
  const size_t peak = std::max_element(psd.begin(), psd.end()) - psd.begin();
  EXPECT_NEAR(f[peak], 40, 2.0);
  FitOptions options;
  options.types = {ShaperType::kZV, ShaperType::kMZV};
  const std::vector<ShaperFit> fits = FitShapers(f, psd, options);
  EXPECT_NEAR(fits[0].frequency / 40, 1, 0.1);
  EXPECT_NEAR(fits[1].frequency / 40, 1, 0.1);
}

// ---- Shaped command profiles -------------------------------------------------------------------

// The text form: the shaper is MakeShaper's for the type, frequency and damping given (0.1 by
// default), and bad texts say what is expected.
TEST(ShapedProfile, ParsesTheShaper) {
  const CommandProfile p =
      CommandProfile::Parse("shaped(trapezoid(60rpm, 0.05s, 0.1s, 0.05s), zvd 40Hz)");
  ASSERT_NE(p.shaper(), nullptr);
  const InputShaper expected = MakeShaper(ShaperType::kZVD, 40, 0.1);
  EXPECT_EQ(p.shaper()->amplitudes, expected.amplitudes);
  EXPECT_EQ(p.shaper()->times, expected.times);
  const CommandProfile q = CommandProfile::Parse("shaped(constant(90deg), EI 35hz 0.15)");
  EXPECT_EQ(q.shaper()->times, MakeShaper(ShaperType::kEI, 35, 0.15).times);
  EXPECT_TRUE(q.absolute_angle());
  EXPECT_EQ(CommandProfile::Parse("constant(1rpm)").shaper(), nullptr);
  for (const char* text :
       {"shaped(constant(1rpm))", "shaped(constant(1rpm), wobble 40Hz)",
        "shaped(constant(1rpm), zv 40)", "shaped(constant(1rpm), zv -5Hz)",
        "shaped(constant(1rpm), zv 40Hz 0.9)", "shaped(constant(1rpm), zv 40Hz 0.1 x)",
        "shaped(constant(1rpm), zv 40Hz x)", "shaped(wobble(1rpm), zv 40Hz)"}) {
    try {
      CommandProfile::Parse(text);
      ADD_FAILURE() << text << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr("profile \"")) << e.what();
    }
  }
}

// The shaped command is the convolution Σ A_i·P(t − T_i) of the angle and the speed (1e-12, the
// same arithmetic); the move ends where the unshaped one does (1e-12 rad); ControlForStep passes
// it on (velocity input: the mean shaped speed over the step; position: the shaped angle at
// mid-step).
TEST(ShapedProfile, IsTheConvolutionAndEndsAtTheSameAngle) {
  const std::string raw_text = "trapezoid(120rpm, 0.07s, 0.1s, 0.05s)";
  const CommandProfile raw = CommandProfile::Parse(raw_text);
  const CommandProfile shaped = CommandProfile::Parse("shaped(" + raw_text + ", mzv 37Hz)");
  const InputShaper& s = *shaped.shaper();
  for (double t = -0.01; t < 0.3; t += 0.0037) {
    double angle = 0, speed = 0;
    for (size_t i = 0; i < s.times.size(); ++i) {
      angle += s.amplitudes[i] * raw.Angle(t - s.times[i]);
      speed += s.amplitudes[i] * raw.Speed(t - s.times[i]);
    }
    EXPECT_NEAR(shaped.Angle(t), angle, 1e-12) << t;
    EXPECT_NEAR(shaped.Speed(t), speed, 1e-12) << t;
  }
  EXPECT_GT(std::abs(shaped.Angle(0.1) - raw.Angle(0.1)), 1e-3);  // it does change the command
  EXPECT_NEAR(shaped.Angle(1.0), raw.Angle(1.0), 1e-12);
  const double h = 1e-3;
  EXPECT_NEAR(shaped.ControlForStep(0.05, h, InputMode::kVelocity, 0.3),
              (shaped.Angle(0.05 + h) - shaped.Angle(0.05)) / h, 1e-9);
  EXPECT_NEAR(shaped.ControlForStep(0.05, h, InputMode::kPosition, 0.3),
              0.3 + shaped.Angle(0.05 + h / 2), 1e-12);
  // A constant speed is relative to t = 0 and left as it is (shaping a constant does nothing).
  const CommandProfile cruise = CommandProfile::Parse("shaped(constant(100rpm), ei 40Hz)");
  EXPECT_NEAR(cruise.Angle(0.5), RpmToRadPerSec(100) * 0.5, 1e-12);
  EXPECT_NEAR(cruise.Angle(0.0), 0.0, 1e-15);
}

// A step list shaped: the count is round(Σ A_i·count(t − T_i)), whole steps, ending at the list's
// count; STEP/DIR input counts from the start angle's steps.
TEST(ShapedProfile, StepListCountsTheShapedSteps) {
  const std::string path = ::testing::TempDir() + "/shaped_steps.txt";
  {
    std::ofstream out(path);
    for (int k = 1; k <= 200; ++k) out << k * 5e-4 << "\n";  // 2000 microsteps/s for 0.1 s
  }
  const CommandProfile raw = CommandProfile::Parse("steps(" + path + ")");
  const CommandProfile shaped = CommandProfile::Parse("shaped(steps(" + path + "), zv 50Hz 0)");
  EXPECT_TRUE(shaped.step_list());
  const double step = kTwoPi / 3200;  // rad per microstep
  // ZV at 50 Hz, ζ = 0: half the steps now, half 10 ms later. At 5.6 ms (11 steps, none of the
  // delayed half) and 105.6 ms (200 and 191) the mean is half a step: rounded to a whole one.
  for (double t : {0.0056, 0.0101, 0.0502, 0.0952, 0.1049, 0.1056, 0.2}) {  // none on a step
    const double expected = std::round(0.5 * raw.Angle(t, 1) + 0.5 * raw.Angle(t - 0.01, 1));
    EXPECT_EQ(shaped.Angle(t, 1), expected) << t;
    EXPECT_EQ(shaped.Angle(t, 1), std::round(shaped.Angle(t, 1))) << t;
    EXPECT_EQ(shaped.ControlForStep(t - 1e-3, 1e-3, InputMode::kSteps, 7 * step, step),
              7 + expected)
        << t;
  }
  EXPECT_EQ(shaped.Angle(0.2, 1), 200);
  EXPECT_NEAR(shaped.Speed(0.05, step), 2000 * step, 1e-9);
}

// Two shapers in series (nested shaped): the profile's shaper is their convolution.
TEST(ShapedProfile, NestedShapersAreInSeries) {
  const CommandProfile p =
      CommandProfile::Parse("shaped(shaped(trapezoid(60rpm, 0.1s, 0.1s, 0.1s), zv 40Hz), zv 60Hz)");
  const InputShaper both =
      Convolve(MakeShaper(ShaperType::kZV, 40), MakeShaper(ShaperType::kZV, 60));
  EXPECT_EQ(p.shaper()->times, both.times);
  EXPECT_EQ(p.shaper()->amplitudes, both.amplitudes);
}

// Issue 33 (severe): 6 000 nested shaped(…) crashed the command with SIGSEGV (a recursion per
// level, each copying the inner text). Beyond kMaxNestedShapers the profile is refused at once,
// naming the bound; four nested still parse into four shapers in series.
TEST(ShapedProfile, DeepNestingIsRefusedNotRecursed) {
  auto nested = [](int n) {
    std::string text = "constant(100rpm)";
    for (int i = 0; i < n; ++i) text = "shaped(" + text + ", zv 40Hz)";
    return text;
  };
  EXPECT_EQ(CommandProfile::Parse(nested(4)).shaper()->amplitudes.size(), 5u);  // 2⁴ at 5 times
  for (int n : {5, 6000}) {
    try {
      CommandProfile::Parse(nested(n));
      ADD_FAILURE() << n << " levels parsed";
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(),
                  ::testing::HasSubstr(std::to_string(n) + " shaped(…) nested, at most 4"));
      EXPECT_LT(std::string(e.what()).size(), 200u);  // the text is not echoed whole
    }
  }
  EXPECT_THROW(CommandProfile::Parse("shaped (" + nested(5) + ", zv 40Hz)"), std::invalid_argument);
}

// A mass on a spring (f, ζ) following the commanded angle, x'' = −2ζω(x' − u') − ω²(x − u),
// integrated by RK4 at 10 µs (over 2000 steps a period at 40-46 Hz), driven through
// a trapezoid with and without a shaper. The vibration left when each command ends, the amplitude
// √(e² + ((e' + ζωe)/ω_d)²) of e = x − u_end, shaped over unshaped must be the shaper's V(f, ζ)
// (SPEC §9's target: within 20 %; measured within 6.3e-5 here, so also 1e-3), and below 1/10 at
// the tuned frequency (there the shapers with an exact zero leave < 1e-3, the integration's
// error).
TEST(ShapedProfile, MassSpringRingsByTheShapersRemainingVibration) {
  const std::string move = "trapezoid(60rpm, 0.033s, 0.05s, 0.033s)";  // ramps: no whole periods
  auto residual = [&](const CommandProfile& p, double f, double zeta) {
    const double w = kTwoPi * f, wd = w * std::sqrt(1 - zeta * zeta);
    const double end = 0.116 + (p.shaper() ? p.shaper()->duration() : 0.0);  // s
    const double h = 1e-5;
    double x = 0, v = 0, t = 0;
    auto acc = [&](double tt, double xx, double vv) {
      return -2 * zeta * w * (vv - p.Speed(tt)) - w * w * (xx - p.Angle(tt));
    };
    const int n = static_cast<int>(std::round(end / h));
    for (int i = 0; i < n; ++i, t = i * h) {
      const double k1x = v, k1v = acc(t, x, v);
      const double k2x = v + 0.5 * h * k1v, k2v = acc(t + h / 2, x + 0.5 * h * k1x, k2x);
      const double k3x = v + 0.5 * h * k2v, k3v = acc(t + h / 2, x + 0.5 * h * k2x, k3x);
      const double k4x = v + h * k3v, k4v = acc(t + h, x + h * k3x, k4x);
      x += h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x);
      v += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
    }
    const double e = x - p.Angle(1e3);  // the final angle
    return std::hypot(e, (v + zeta * w * e) / wd);
  };
  const double zeta = 0.05;
  const CommandProfile raw = CommandProfile::Parse(move);
  for (const char* type : {"zv", "mzv", "zvd", "ei", "2hump_ei", "3hump_ei"}) {
    const CommandProfile shaped =
        CommandProfile::Parse("shaped(" + move + ", " + type + " 40Hz 0.05)");
    for (double f : {40.0, 46.0}) {
      const double ratio = residual(shaped, f, zeta) / residual(raw, f, zeta);
      const double predicted = RemainingVibration(*shaped.shaper(), f, zeta);
      SCOPED_TRACE(std::string(type) + " at " + std::to_string(f) + " Hz: ratio " +
                   std::to_string(ratio) + ", V " + std::to_string(predicted));
      if (f == 40) {
        EXPECT_LT(ratio, 0.1);
      }
      // (Klipper's 2hump_ei, a fit, leaves 0.1 % at its frequency rather than an exact zero.)
      const bool zero_at_40 =
          std::string(type) == "zv" || std::string(type) == "mzv" || std::string(type) == "zvd";
      if (f == 40 && zero_at_40) {
        EXPECT_LT(ratio, 1e-3);  // V = 0 there: only the integration's error is left
      } else {
        EXPECT_NEAR(ratio / predicted, 1, 0.2);
        EXPECT_NEAR(ratio / predicted, 1, 1e-3);  // linear and exact: RK4's error only
      }
    }
  }
}

}  // namespace
}  // namespace mjstepper
