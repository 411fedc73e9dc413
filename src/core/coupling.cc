#include "core/coupling.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
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

namespace {

// C-3 with matrices of at most MaxN rows (no heap allocation when MaxN is fixed: it runs every
// step), Eigen::Dynamic for any n.
template <int MaxN>
void SolveConsistentTorques(std::span<const double> inverse_inertia,
                            std::span<const double> stiffness, std::span<const double> torque,
                            std::span<const double> external_accel, double h,
                            std::vector<double>& out) {
  using Matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, MaxN, MaxN>;
  using Vector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, MaxN, 1>;
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const Eigen::Index n = static_cast<Eigen::Index>(torque.size());
  const Eigen::Map<const RowMajor> g_in(inverse_inertia.data(), n, n);
  const Eigen::Map<const Eigen::VectorXd> k_in(stiffness.data(), n), tau_in(torque.data(), n),
      external_in(external_accel.data(), n);
  if (!(h > 0) || !std::isfinite(h) || !g_in.allFinite() || !k_in.allFinite() ||
      !external_in.allFinite() || !tau_in.allFinite()) {
    return;
  }
  const Vector k = k_in, tau = tau_in, external = external_in;
  const Matrix g = 0.5 * (g_in + g_in.transpose());  // symmetric to round-off
  // G = L·Lᵀ (Cholesky). A = G·K = L·(Lᵀ·K·L)·L⁻¹: A is similar to the symmetric S = Lᵀ·K·L, so
  // σ(h²·A) = L·W·diag(σ(h²·λ))·Wᵀ·L⁻¹ with S = W·diag(λ)·Wᵀ (C-1 on each mode). Then, with
  // a0 = G·τ0 + a_ext, C-3's G⁻¹·(σ·a0 − a_ext) is L⁻ᵀ·(W·diag(σ)·Wᵀ·y − z), z = L⁻¹·a_ext and
  // y = L⁻¹·a0 = Lᵀ·τ0 + z: one Cholesky and one symmetric eigenproblem.
  const Eigen::LLT<Matrix> cholesky(g);
  // Positive definite to well within round-off (two steppers on one joint make G singular): else
  // the steppers keep their torques at the step's start. L's pivots squared bound G's spectrum.
  if (cholesky.info() != Eigen::Success) return;
  const Matrix l = cholesky.matrixL();
  double least = std::numeric_limits<double>::infinity(), most = 0;  // pivots², 1/(kg·m²)
  for (Eigen::Index i = 0; i < n; ++i) {
    least = std::min(least, l(i, i) * l(i, i));
    most = std::max(most, l(i, i) * l(i, i));
  }
  if (!(least > 1e-9 * most)) return;
  const Matrix s = l.transpose() * k.asDiagonal() * l;
  const Eigen::SelfAdjointEigenSolver<Matrix> modes(s);
  if (modes.info() != Eigen::Success) return;
  Vector scale(n);
  for (Eigen::Index i = 0; i < n; ++i) scale(i) = StiffnessScale(h * h * modes.eigenvalues()(i));
  const Vector z = l.template triangularView<Eigen::Lower>().solve(external);
  const Vector y = l.transpose() * tau + z;
  const Matrix& w = modes.eigenvectors();
  const Vector mixed = w * scale.cwiseProduct(w.transpose() * y) - z;
  const Vector handed = l.transpose().template triangularView<Eigen::Upper>().solve(mixed);  // C-3
  Eigen::Map<Eigen::VectorXd>(out.data(), n) = handed;
}

}  // namespace

std::vector<double> ConsistentTorques(std::span<const double> inverse_inertia,
                                      std::span<const double> stiffness,
                                      std::span<const double> torque,
                                      std::span<const double> external_accel, double h) {
  std::vector<double> out(torque.begin(), torque.end());
  if (torque.size() <= 8) {  // an arm's steppers: fixed-capacity matrices
    SolveConsistentTorques<8>(inverse_inertia, stiffness, torque, external_accel, h, out);
  } else {
    SolveConsistentTorques<Eigen::Dynamic>(inverse_inertia, stiffness, torque, external_accel, h,
                                           out);
  }
  return out;
}

}  // namespace mjstepper
