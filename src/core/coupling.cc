#include "core/coupling.h"

#include <Eigen/Dense>
#include <cmath>
#include <numbers>

namespace mjstepper {

double MaxOmegaTimesStep(Coupling coupling) {
  return coupling == Coupling::kConsistent ? 0.2 : 0.15;  // docs/coupling.md, the ripple table
}

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

std::vector<double> ConsistentTorques(std::span<const double> inverse_inertia,
                                      std::span<const double> stiffness,
                                      std::span<const double> torque,
                                      std::span<const double> external_accel, double h) {
  const Eigen::Index n = static_cast<Eigen::Index>(torque.size());
  std::vector<double> out(torque.begin(), torque.end());
  using Matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const Eigen::Map<const Matrix> g_in(inverse_inertia.data(), n, n);
  const Eigen::Map<const Eigen::VectorXd> k(stiffness.data(), n), tau(torque.data(), n),
      external(external_accel.data(), n);
  if (!(h > 0) || !std::isfinite(h) || !g_in.allFinite() || !k.allFinite() ||
      !external.allFinite() || !tau.allFinite()) {
    return out;
  }
  const Eigen::MatrixXd g = 0.5 * (g_in + g_in.transpose());  // symmetric to round-off
  // G = V·diag(γ)·Vᵀ, γ > 0: G^½ and G^−½.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> inertia(g);
  // Positive definite to well within round-off (two steppers on one joint make G singular): else
  // the steppers keep their torques at the step's start.
  if (inertia.info() != Eigen::Success ||
      !(inertia.eigenvalues().minCoeff() > 1e-9 * inertia.eigenvalues().maxCoeff())) {
    return out;
  }
  const Eigen::MatrixXd& v = inertia.eigenvectors();
  const Eigen::VectorXd root_gamma = inertia.eigenvalues().cwiseSqrt();
  const Eigen::MatrixXd root = v * root_gamma.asDiagonal() * v.transpose();
  const Eigen::MatrixXd inverse_root = v * root_gamma.cwiseInverse().asDiagonal() * v.transpose();
  // σ(h²·S), S = G^½·K·G^½ symmetric: σ(h²·λ) on each of its modes (C-1).
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> modes(root * k.asDiagonal() * root);
  if (modes.info() != Eigen::Success) return out;
  Eigen::VectorXd scale(n);
  for (Eigen::Index i = 0; i < n; ++i) scale(i) = StiffnessScale(h * h * modes.eigenvalues()(i));
  const Eigen::MatrixXd sigma = root * modes.eigenvectors() * scale.asDiagonal() *
                                modes.eigenvectors().transpose() * inverse_root;  // σ(h²·A)
  const Eigen::VectorXd accel = g * tau + external;                               // a0
  const Eigen::VectorXd handed = g.ldlt().solve(sigma * accel - external);        // C-3
  Eigen::Map<Eigen::VectorXd>(out.data(), n) = handed;
  return out;
}

}  // namespace mjstepper
