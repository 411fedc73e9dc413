#include "core/switching.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mjstepper {
namespace {

constexpr double kNever = std::numeric_limits<double>::infinity();

double Component(PhaseVector z, int phase) { return phase == 0 ? z.real() : z.imag(); }

// A count of points stored as a double (the simulator's state, which may hold anything): itself
// when a whole number in [0, most], else -1.
int PointCount(double stored, int most) {
  return stored >= 0 && stored <= most && stored == std::floor(stored) ? static_cast<int>(stored)
                                                                       : -1;
}

}  // namespace

double PhaseSwitch::LevelAt(double t) const {
  const double span = std::max(0.0, level_stop - armed_from);  // s
  return level + level_slope * std::clamp(t - armed_from, 0.0, span);
}

void PhaseSwitch::NoteSwitch(bool cycle_starts, bool voltage_changed, double t, double current) {
  if (target == 0) {
    cycle_open = 0;
    last_points = 0;
    return;
  }
  const int n = PointCount(points, kCyclePoints + 1);  // kCyclePoints + 1: too many to keep
  if (cycle_starts) {
    last_points = 0;
    if (cycle_open != 0 && target == cycle_target && t > cycle_from && n >= 1 &&
        n <= kCyclePoints) {
      for (int k = 0; k < n; ++k) {
        last_at[k] = at[k];
        last_current_at[k] = current_at[k];
      }
      last_at[n] = t - cycle_from;
      last_current_at[n] = current;
      last_points = n + 1;
      last_mean = charge / (t - cycle_from);
    }
    cycle_open = 1;
    cycle_target = target;
    cycle_from = t;
    charge = 0;
    points = 1;
    at[0] = 0;
    current_at[0] = current;
    return;
  }
  if (cycle_open == 0 || !voltage_changed) return;
  if (n >= 0 && n < kCyclePoints) {
    at[n] = t - cycle_from;
    current_at[n] = current;
  }
  // Past kCyclePoints (or a count the state made up) the cycle is not kept (NoteSwitch at its
  // end).
  points = n >= 0 && n < kCyclePoints ? n + 1 : kCyclePoints + 1;
}

double PhaseSwitch::Ripple(double t, double step) const {
  const int n = PointCount(last_points, kCyclePoints + 1);
  if (cycle_open == 0 || n < 2) return 0;
  const double length = last_at[n - 1];  // s
  const double into = t - cycle_from;    // s
  if (!(length < 2 * step) || !(into >= 0) || into > kStaleCycles * length ||
      target != cycle_target) {
    return 0;
  }
  if (into >= length) {
    const double ripple = last_current_at[n - 1] - last_mean;
    return std::isfinite(ripple) ? ripple : 0.0;
  }
  int k = 1;
  while (k < n - 1 && last_at[k] <= into) ++k;  // last_at[k − 1] <= into < last_at[k]
  const double span = last_at[k] - last_at[k - 1];
  const double f = span > 0 ? (into - last_at[k - 1]) / span : 0.0;
  const double ripple =
      last_current_at[k - 1] + f * (last_current_at[k] - last_current_at[k - 1]) - last_mean;
  return std::isfinite(ripple) ? ripple : 0.0;  // (a state the simulator was handed)
}

void IdleBridge(double mode, double t, double current, double vbus, PhaseSwitch* sw) {
  sw->mode = mode;
  sw->mode_start = t;
  sw->has_until = 0;
  sw->voltage = current > 0 ? -vbus : current < 0 ? vbus : 0.0;
  sw->has_level = current != 0 ? 1 : 0;
  sw->direction = current > 0 ? -1 : 1;
  sw->level = 0;
  sw->level_slope = 0;
  sw->armed_from = t;
}

double FirstCrossing(const MotorParams& p, const SpeedKernel& speed, PhaseVector current0,
                     PhaseVector voltage, PhaseVector phasor0, int phase, int direction,
                     double level0, double slope, double ramp, double from, double to) {
  if (!(to >= from)) return kNever;
  // i(τ) = A + B·e^{jΩτ} + C·e^{−aτ}  (winding.h)
  const PhaseVector A = voltage / p.resistance;
  const PhaseVector B = speed.emf_gain * phasor0;
  const PhaseVector C = current0 - A - B;
  const double a = speed.decay_rate;  // 1/s
  const double W = speed.electrical;  // Ω, rad/s
  const double sign = direction >= 0 ? 1.0 : -1.0;
  // g(τ) = sign·(i(τ) − ℓ(τ)): the crossing is g's first root from below; dg/dτ if asked.
  auto g = [&](double tau, double* slope_out) {
    const PhaseVector rotation = UnitPhasor(W * tau);
    const double decay = std::exp(-a * tau);
    const double into_ramp = tau - from;  // s
    const double level = level0 + slope * std::clamp(into_ramp, 0.0, ramp);
    if (slope_out != nullptr) {
      const double level_rate = into_ramp < ramp ? slope : 0.0;
      *slope_out = sign * (Component(PhaseVector(0, W) * B * rotation, phase) -
                           a * Component(C, phase) * decay - level_rate);
    }
    return sign * (Component(A + B * rotation + C * decay, phase) - level);
  };
  const double g_from = g(from, nullptr);
  if (g_from >= 0) return from;           // already past the level when the comparator is armed
  if (std::isnan(g_from)) return kNever;  // a state no step makes: the drive's check finds it
  // No crossing at all where the level stays beyond the current's reach: |i_p(τ)| <= |A| + |B| +
  // |C| for τ >= 0 (|e^{jΩτ}| = 1, e^{−aτ} <= 1), and sign·ℓ is least at one end of its ramp.
  // Exact, and it bounds the work of a comparator armed on a level out of reach (found by the
  // drive fuzzer: a stored level of 1e308 took 64 pieces at every interrupt, seconds a step).
  const double reach = std::abs(A) + std::abs(B) + std::abs(C);  // A
  const double least_level = std::min(sign * level0, sign * (level0 + slope * ramp));
  if (a >= 0 && least_level > reach) return kNever;
  // Pieces of at most 0.5 rad of electrical rotation, split at the ramp's end (a kink of ℓ), and
  // at most kMaxCrossingPieces of them (bounded work at any speed, found by the drive fuzzer: at
  // an absurd speed 0.5/|Ω| fell below the round-off of `lo` and the loop never moved).
  const double piece =
      std::max(W != 0 ? 0.5 / std::abs(W) : kNever, (to - from) / kMaxCrossingPieces);
  const double kink = from + ramp;
  double lo = from, g_lo = g_from;
  while (lo < to) {
    double hi = std::min(to, lo + piece);
    if (!(hi > lo)) hi = to;  // a piece below lo's round-off: the rest at once
    if (kink > lo && kink < hi) hi = kink;
    const double g_hi = g(hi, nullptr);
    if (g_hi >= 0) {
      // A root in (lo, hi]: safeguarded Newton from the secant point, keeping the bracket
      // g(lo) < 0 <= g(hi); the answer is the bracket's upper end, where the level is reached.
      double bad = lo, good = hi;
      double x = lo - g_lo * (hi - lo) / (g_hi - g_lo);
      for (int iteration = 0; iteration < 60 && good - bad > 1e-12; ++iteration) {
        double dg = 0;
        const double gx = g(x, &dg);
        (gx >= 0 ? good : bad) = x;
        double next = dg != 0 ? x - gx / dg : 0.5 * (bad + good);
        if (!(next > bad && next < good)) next = 0.5 * (bad + good);
        x = next;
      }
      return good;
    }
    lo = hi;
    g_lo = g_hi;
  }
  return kNever;
}

double NextSwitchTime(const PhaseSwitch& sw, int phase, const MotorParams& p,
                      const SpeedKernel& speed, PhaseVector current0, PhaseVector voltage,
                      PhaseVector phasor0, double t, double t_end) {
  double next = sw.has_until != 0 ? std::max(t, sw.until) : kNever;
  if (next > t_end) next = kNever;
  if (sw.has_level != 0) {
    const double armed = std::max(t, sw.armed_from);  // s
    const double horizon = std::min(t_end, next);
    if (armed <= horizon) {
      const double tau =
          FirstCrossing(p, speed, current0, voltage, phasor0, phase, sw.direction >= 0 ? 1 : -1,
                        sw.LevelAt(armed), sw.level_slope, std::max(0.0, sw.level_stop - armed),
                        armed - t, horizon - t);
      next = std::min(next, t + tau);
    }
  }
  return next;
}

}  // namespace mjstepper
