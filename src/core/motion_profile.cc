#include "core/motion_profile.h"

#include <cmath>
#include <limits>

namespace mjstepper {
namespace {

double SignOf(double v) { return (v > 0) - (v < 0); }

// Moves (p, v, a) along one segment for τ seconds.
void Along(const MotionProfile::Segment& g, double tau, double* p, double* v, double* a) {
  *p += *v * tau + g.accel * tau * tau / 2 + g.jerk * tau * tau * tau / 6;
  *v += g.accel * tau + g.jerk * tau * tau / 2;
  *a = g.accel + g.jerk * tau;
}

double Duration(const std::array<MotionProfile::Segment, 7>& segments) {
  double total = 0;
  for (const MotionProfile::Segment& g : segments) total += g.duration;
  return total;
}

}  // namespace

MotionProfile::State MotionProfile::Rest(double time, double p) {
  return {.t0 = time, .p0 = p, .v0 = 0, .target = p, .t_end = time};
}

CommandSample MotionProfile::Evaluate(const State& s, double t) const {
  if (t >= s.t_end) return {.theta = s.target};
  if (t <= s.t0) return {.theta = s.p0, .omega = s.v0};
  double p = s.p0, v = s.v0, a = 0;
  double tau = t - s.t0;
  for (const Segment& g : s.segments) {
    if (tau <= g.duration) {
      Along(g, tau, &p, &v, &a);
      return {.theta = p, .omega = v, .accel = a, .jerk = g.jerk};
    }
    Along(g, g.duration, &p, &v, &a);
    tau -= g.duration;
  }
  return {.theta = s.target};
}

double MotionProfile::NextBreak(const State& s, double t) const {
  if (s.t_end <= s.t0) return std::numeric_limits<double>::infinity();  // at rest
  if (t < s.t0) return s.t0;
  double end = s.t0;
  for (const Segment& g : s.segments) {
    end += g.duration;
    if (g.duration > 0 && end > t && end < s.t_end) return end;
  }
  return t < s.t_end ? s.t_end : std::numeric_limits<double>::infinity();
}

std::array<MotionProfile::Segment, 7> MotionProfile::PlanSCurve(double distance) const {
  const double D = std::abs(distance), s = SignOf(distance);
  const double A = max_accel, J = max_jerk;
  // Peak speed: V if the ramps fit, else the largest whose accel + decel cover D.
  auto ramp_distance = [&](double v) {  // accel phase 0 → v, times 2 (accel + decel)
    const double ap = std::min(A, std::sqrt(v * J));
    return v * (ap / J + v / ap);
  };
  double v = max_speed;
  if (ramp_distance(v) > D) {
    // v ≥ A²/J: D = v·(A/J + v/A); below: D = 2·v^{3/2}/√J.
    v = (-A / J + std::sqrt(A * A / (J * J) + 4 * D / A)) * A / 2;
    if (v < A * A / J) v = std::cbrt(D * D * J / 4);
  }
  const double ap = std::min(A, std::sqrt(v * J));              // peak acceleration
  const double tj = ap / J;                                     // jerk phase
  const double tc = std::max(0.0, v / ap - tj);                 // constant-acceleration phase
  const double tv = std::max(0.0, (D - ramp_distance(v)) / v);  // cruise
  return {{{tj, 0, s * J},
           {tc, s * ap, 0},
           {tj, s * ap, -s * J},
           {tv, 0, 0},
           {tj, 0, -s * J},
           {tc, -s * ap, 0},
           {tj, -s * ap, s * J}}};
}

void MotionProfile::Update(State* s, double t0, double t1, double target) const {
  if (target == s->target || t1 <= start_time) return;
  const double t = std::max(t0, start_time);
  if (kind == ProfileKind::kSCurve && t < s->t_end) return;  // taken when this move ends
  const CommandSample now = Evaluate(*s, t);
  State plan{.t0 = t, .p0 = now.theta, .v0 = now.omega, .target = target};
  if (kind == ProfileKind::kSCurve) {
    plan.v0 = 0;  // S-curve moves start at rest (t >= t_end)
    plan.segments = PlanSCurve(target - now.theta);
  } else {
    const double A = max_accel, V = max_speed;
    double p = now.theta, v = now.omega;
    int n = 0;
    const double stop_distance = v * std::abs(v) / (2 * A);  // signed
    if (v != 0 &&
        (SignOf(v) != SignOf(target - p) || std::abs(stop_distance) > std::abs(target - p))) {
      plan.segments[n++] = {std::abs(v) / A, -SignOf(v) * A, 0};  // stop first
      p += stop_distance;
      v = 0;
    }
    const double d = target - p, sd = SignOf(d), D = std::abs(d), u0 = std::abs(v);
    const double u_peak = std::sqrt(A * D + u0 * u0 / 2);
    if (u_peak <= V) {
      plan.segments[n++] = {(u_peak - u0) / A, sd * A, 0};
      plan.segments[n++] = {u_peak / A, -sd * A, 0};
    } else {
      const double t_first = std::abs(V - u0) / A;
      const double first_distance = (u0 + V) / 2 * t_first;
      plan.segments[n++] = {t_first, sd * A * SignOf(V - u0), 0};
      plan.segments[n++] = {(D - first_distance - V * V / (2 * A)) / V, 0, 0};
      plan.segments[n++] = {V / A, -sd * A, 0};
    }
  }
  plan.t_end = t + Duration(plan.segments);
  *s = plan;
}

}  // namespace mjstepper
