#include "core/coupling.h"

#include <cmath>
#include <numbers>

namespace mjstepper {

double StiffnessScale(double u) {
  if (!std::isfinite(u)) return 1.0;
  constexpr double kPiSquared = std::numbers::pi * std::numbers::pi;
  if (u >= kPiSquared) return 3.96 / u;  // ωh >= π: just inside the stability limit (C-1)
  if (u < -kPiSquared) u = -kPiSquared;  // a falling rotor: at most its growth over |ω|h = π
  if (std::abs(u) < 1e-4) return 1.0 - u / 12.0 + u * u / 360.0;  // series: error < 1e-15
  const double root = std::sqrt(std::abs(u));
  // 1 − cos √u = 2·sin²(√u/2), and cosh √|u| − 1 = 2·sinh²(√|u|/2): no cancellation.
  const double half = u > 0 ? std::sin(root / 2) : std::sinh(root / 2);
  return 4.0 * half * half / std::abs(u);  // C-1
}

double ConsistentTorque(double torque, double stiffness, double inertia, double external_accel,
                        double h) {
  if (!(inertia > 0) || !(h > 0) || !std::isfinite(inertia) || !std::isfinite(h) ||
      !std::isfinite(stiffness) || !std::isfinite(external_accel)) {
    return torque;
  }
  const double sigma = StiffnessScale(stiffness * h * h / inertia);  // C-1
  return sigma * torque + (sigma - 1.0) * inertia * external_accel;  // C-2
}

}  // namespace mjstepper
