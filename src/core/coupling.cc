#include "core/coupling.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace mjstepper {

double MaxOmegaTimesStep(Coupling coupling) {
  // docs/coupling.md, the ripple table; the sub-stepped rotors' own modes are not MuJoCo's to
  // resolve (core/substep.h): 0.2 for the model's other modes, as consistent.
  return coupling == Coupling::kExplicit ? 0.15 : 0.2;
}

namespace {

constexpr double kPiSquared = std::numbers::pi * std::numbers::pi;

// C-4's series: φ(u) = Σⱼ cⱼ·u^j, cⱼ = 2·(−1)^(j+1)/(2j+4)!, for |u| (or ‖X‖∞) up to
// kSeriesReach (< π²: no mode reaches C-1's hold). Constant-initialised: no static order to mind.
constexpr int kSeriesTerms = 16;
constexpr double kSeriesReach = 9.0;
constexpr std::array<double, kSeriesTerms> SeriesCoefficients() {
  std::array<double, kSeriesTerms> c{};
  double factorial = 24.0;  // (2j+4)! at j = 0
  for (int j = 0; j < kSeriesTerms; ++j) {
    c[j] = (j % 2 == 0 ? -2.0 : 2.0) / factorial;
    factorial *= (2.0 * j + 5) * (2.0 * j + 6);
  }
  return c;
}
constexpr std::array<double, kSeriesTerms> kPhi = SeriesCoefficients();

// How many terms of φ serve for arguments of magnitude up to x <= kSeriesReach: until the first
// omitted one, |c_N|·x^N, is below 1e-18 (φ is about −1/12, and beyond it the terms shrink by
// x/((2j+5)(2j+6)) <= 0.3 each, so the tail is below 1.5e-17 of φ). For a matrix X the powers
// obey ‖X^N‖∞ <= ‖X‖∞^N, so the same count bounds the tail of φ(X)·a0 by that of ‖a0‖∞ however
// far from normal X is. At most 13 terms at x = 9.
int SeriesTerms(double x) {
  int n = 1;
  double power = x;  // x^n
  while (n < kSeriesTerms && std::abs(kPhi[n]) * power > 1e-18) {
    ++n;
    power *= x;
  }
  return n;
}

}  // namespace

double StiffnessScale(double u) {
  if (!std::isfinite(u)) return 1.0;
  if (u >= kPiSquared) return 3.96 / u;  // ωh >= π: just inside the stability limit (C-1)
  if (u < -kPiSquared) u = -kPiSquared;  // a falling rotor: at most its growth over |ω|h = π
  if (std::abs(u) <= kSeriesReach) {     // σ = 1 + u·φ(u), C-4's series
    const int terms = SeriesTerms(std::abs(u));
    double phi = kPhi[terms - 1];
    for (int j = terms - 2; j >= 0; --j) phi = phi * u + kPhi[j];
    return 1.0 + u * phi;
  }
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

// C-3 by the eigenproblem (inputs finite, h > 0), with matrices of at most MaxN rows (no heap
// allocation when MaxN is fixed), Eigen::Dynamic for any n.
template <int MaxN>
void SolveConsistentTorques(std::span<const double> inverse_inertia,
                            std::span<const double> stiffness, std::span<const double> torque,
                            std::span<const double> external_accel, double h,
                            std::span<double> out) {
  using Matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, MaxN, MaxN>;
  using Vector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, MaxN, 1>;
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const Eigen::Index n = static_cast<Eigen::Index>(torque.size());
  const Eigen::Map<const RowMajor> g_in(inverse_inertia.data(), n, n);
  const Eigen::Map<const Eigen::VectorXd> k_in(stiffness.data(), n), tau_in(torque.data(), n),
      external_in(external_accel.data(), n);
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

void ConsistentTorques(std::span<const double> inverse_inertia, std::span<const double> stiffness,
                       std::span<const double> torque, std::span<const double> external_accel,
                       double h, std::span<double> out) {
  const std::size_t n = torque.size();
  if (out.size() < n || inverse_inertia.size() != n * n || stiffness.size() != n ||
      external_accel.size() != n) {
    throw std::invalid_argument("ConsistentTorques: G must be n×n and k, a_ext, out n long");
  }
  std::copy(torque.begin(), torque.end(), out.begin());  // τ0 unless solved
  const auto finite = [](std::span<const double> x) {
    return std::all_of(x.begin(), x.end(), [](double v) { return std::isfinite(v); });
  };
  if (!(h > 0) || !std::isfinite(h) || !finite(inverse_inertia) || !finite(stiffness) ||
      !finite(torque) || !finite(external_accel)) {
    return;
  }
  // C-4 while every mode's h²·λ lies within the series' reach (‖X‖∞ bounds them), else C-3.
  constexpr std::size_t kLocal = 8;
  std::array<double, kLocal * kLocal + 3 * kLocal> local;
  std::vector<double> heap;
  double* x = local.data();  // X = h²·G·K, row-major; then a0, φ(X)·a0 and a scratch row
  if (n > kLocal) {
    heap.resize(n * n + 3 * n);
    x = heap.data();
  }
  double* a0 = x + n * n;
  double* phi_a0 = a0 + n;
  double* next = phi_a0 + n;
  double norm = 0;  // ‖X‖∞
  for (std::size_t i = 0; i < n; ++i) {
    double row = 0, a = external_accel[i];
    for (std::size_t j = 0; j < n; ++j) {
      const double g = 0.5 * inverse_inertia[i * n + j] + 0.5 * inverse_inertia[j * n + i];
      x[i * n + j] = h * h * g * stiffness[j];
      row += std::abs(x[i * n + j]);
      a += g * torque[j];
    }
    a0[i] = a;                       // G·τ0 + a_ext, rad/s²
    if (!(row <= norm)) norm = row;  // NaN (an overflow of finite inputs) is kept
  }
  if (!std::isfinite(norm) || !std::all_of(a0, a0 + n, [](double v) { return std::isfinite(v); })) {
    return;  // finite inputs whose products overflow: τ0
  }
  if (norm <= kSeriesReach) {
    // φ(X)·a0 by Horner's rule: p ← X·p + cⱼ·a0, from the last term down.
    const int terms = SeriesTerms(norm);
    for (std::size_t i = 0; i < n; ++i) phi_a0[i] = kPhi[terms - 1] * a0[i];
    for (int t = terms - 2; t >= 0; --t) {
      for (std::size_t i = 0; i < n; ++i) {
        double sum = kPhi[t] * a0[i];
        for (std::size_t j = 0; j < n; ++j) sum += x[i * n + j] * phi_a0[j];
        next[i] = sum;
      }
      std::copy(next, next + n, phi_a0);
    }
    for (std::size_t i = 0; i < n; ++i) out[i] = torque[i] + h * h * stiffness[i] * phi_a0[i];
    return;  // C-4
  }
  if (n <= kLocal) {  // an arm's steppers: fixed-capacity matrices
    SolveConsistentTorques<kLocal>(inverse_inertia, stiffness, torque, external_accel, h, out);
  } else {
    SolveConsistentTorques<Eigen::Dynamic>(inverse_inertia, stiffness, torque, external_accel, h,
                                           out);
  }
}

}  // namespace mjstepper
