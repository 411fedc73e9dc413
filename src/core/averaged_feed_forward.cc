#include "core/averaged_feed_forward.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace mjstepper {
namespace {

using Matrix = Eigen::Matrix2d;  // (F-1)'s M on I = (Re, Im)
using Vector = Eigen::Vector2d;

constexpr int kDegree = 4;            // G's
constexpr int kOrders = kDegree + 3;  // φ0..φ6: (F-2)'s end needs φ5, its integral φ6
constexpr double kFactorials[kOrders] = {1, 1, 2, 6, 24, 120, 720};

Vector Of(PhaseVector z) { return {z.real(), z.imag()}; }
PhaseVector Of(const Vector& v) { return {v(0), v(1)}; }

// φ0(Z)..φ6(Z) (φ0 = e^Z): φ6 by its series, the rest by φk = I/k! + Z·φ_{k+1}.
std::array<Matrix, kOrders> Phi(const Matrix& z) {
  std::array<Matrix, kOrders> phi;
  Matrix term = Matrix::Identity() / kFactorials[kOrders - 1];  // Z^j/(j + 6)!
  Matrix sum = term;
  for (int j = 1; j < 60; ++j) {
    term = z * term / static_cast<double>(j + kOrders - 1);
    sum += term;
    if (term.squaredNorm() <= 1e-36 * sum.squaredNorm()) break;
  }
  phi[kOrders - 1] = sum;
  for (int k = kOrders - 2; k >= 0; --k) {
    phi[k] = Matrix::Identity() / kFactorials[k] + z * phi[k + 1];
  }
  return phi;
}

// (F-2) at u for a piece: e^{Mu}·I0 + Σm gm·m!·u^{m+1}·φ_{m+1}(Mu).
Vector At(const Matrix& m, const std::array<Vector, kDegree + 1>& g, const Vector& start,
          double u) {
  const std::array<Matrix, kOrders> phi = Phi(m * u);
  Vector value = phi[0] * start;
  double power = u;  // u^{m+1}
  for (int k = 0; k <= kDegree; ++k) {
    value += kFactorials[k] * power * (phi[k + 1] * g[k]);
    power *= u;
  }
  return value;
}

// One piece, s ∈ [0, 1] with ‖M‖ <= kFeedForwardPieceMu.
RotatingFrameStep Piece(const Matrix& m, const std::array<Vector, kDegree + 1>& g,
                        const Vector& start) {
  const std::array<Matrix, kOrders> phi = Phi(m);
  Vector end = phi[0] * start, integral = phi[1] * start;
  for (int k = 0; k <= kDegree; ++k) {
    end += kFactorials[k] * (phi[k + 1] * g[k]);
    integral += kFactorials[k] * (phi[k + 2] * g[k]);
  }
  RotatingFrameStep r{.end = Of(end), .integral = Of(integral)};
  // 6-point Gauss-Legendre on [0, 1]: exact for |I|² of a quintic I (a quartic G's solution at
  // M = 0); the exponential parts' error is about 1e-9 relative at ‖M‖ = 3.
  static constexpr int kNodes = 6;
  static constexpr double kNode[kNodes] = {0.033765242898423975, 0.16939530676686776,
                                           0.38069040695840156,  0.6193095930415985,
                                           0.8306046932331322,   0.966234757101576};
  static constexpr double kWeight[kNodes] = {0.0856622461895852, 0.1803807865240693,
                                             0.2339569672863455, 0.2339569672863455,
                                             0.1803807865240693, 0.0856622461895852};
  for (int k = 0; k < kNodes; ++k) {
    r.norm_integral += kWeight[k] * At(m, g, start, kNode[k]).squaredNorm();
  }
  return r;
}

}  // namespace

RotatingFrameStep AdvanceRotatingFrame(const RotatingFrameMatrix& matrix,
                                       const ForcingPolynomial& g, PhaseVector start) {
  Matrix m;
  m << matrix[0], matrix[1], matrix[2], matrix[3];
  // ‖M‖ by its largest row sum (>= its spectral radius).
  const double norm = m.cwiseAbs().rowwise().sum().maxCoeff();
  const int pieces = std::max(1, static_cast<int>(std::ceil(norm / kFeedForwardPieceMu)));
  // Piece p covers s = (p + u)/n: G(s)/n re-expanded in u (d/du = d/ds/n),
  // Gp_k = Σ_{m>=k} gm·C(m, k)·p^{m−k}/n^{m+1}.
  const double n = pieces;
  RotatingFrameStep total;
  Vector current = Of(start);
  for (int p = 0; p < pieces; ++p) {
    std::array<Vector, kDegree + 1> local;
    for (Vector& v : local) v.setZero();
    for (int k = 0; k <= kDegree; ++k) {
      double binomial = 1;  // C(k, i)
      for (int i = 0; i <= k; ++i) {
        local[i] += Of(g[k]) * (binomial * std::pow(p, k - i) / std::pow(n, k + 1));
        binomial = binomial * (k - i) / (i + 1);
      }
    }
    const RotatingFrameStep r = Piece(m / n, local, current);
    total.integral += r.integral / n;
    total.norm_integral += r.norm_integral / n;
    current = Of(r.end);
  }
  total.end = Of(current);
  return total;
}

RotatingFrameStep AdvanceRotatingFrame(PhaseVector mu, const ForcingPolynomial& g,
                                       PhaseVector start) {
  // −μ·I on (Re, Im).
  return AdvanceRotatingFrame({-mu.real(), mu.imag(), -mu.imag(), -mu.real()}, g, start);
}

std::array<double, 5> QuarticThrough(const std::array<double, 5>& samples) {
  static const Eigen::Matrix<double, 5, 5> kInverse = [] {
    Eigen::Matrix<double, 5, 5> vandermonde;
    for (int i = 0; i < 5; ++i) {
      for (int j = 0; j < 5; ++j) vandermonde(i, j) = std::pow(0.25 * i, j);
    }
    return Eigen::Matrix<double, 5, 5>(vandermonde.inverse());
  }();
  const Eigen::Matrix<double, 5, 1> c =
      kInverse * Eigen::Map<const Eigen::Matrix<double, 5, 1>>(samples.data());
  return {c(0), c(1), c(2), c(3), c(4)};
}

}  // namespace mjstepper
