#include "core/averaged_feed_forward.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace mjstepper {
namespace {

constexpr int kDegree = 4;            // G's
constexpr int kOrders = kDegree + 3;  // φ0..φ6: (F-2)'s end needs φ5, its integral φ6
constexpr double kFactorials[kOrders] = {1, 1, 2, 6, 24, 120, 720};

// φ0(z)..φ6(z) (φ0 = e^z): φ6 by its series, the rest by φk = 1/k! + z·φ_{k+1}.
std::array<PhaseVector, kOrders> Phi(PhaseVector z) {
  std::array<PhaseVector, kOrders> phi;
  PhaseVector term = 1.0 / kFactorials[kOrders - 1];  // z^j/(j + 6)!
  PhaseVector sum = term;
  for (int j = 1; j < 60; ++j) {
    term *= z / static_cast<double>(j + kOrders - 1);
    sum += term;
    if (std::norm(term) <= 1e-36 * std::norm(sum)) break;
  }
  phi[kOrders - 1] = sum;
  for (int k = kOrders - 2; k >= 0; --k) phi[k] = 1.0 / kFactorials[k] + z * phi[k + 1];
  return phi;
}

// (F-2) at u for a piece: e^{−μu}·I0 + Σm gm·m!·u^{m+1}·φ_{m+1}(−μu).
PhaseVector At(PhaseVector mu, const ForcingPolynomial& g, PhaseVector start, double u) {
  const std::array<PhaseVector, kOrders> phi = Phi(-mu * u);
  PhaseVector value = phi[0] * start;
  double power = u;  // u^{m+1}
  for (int m = 0; m <= kDegree; ++m) {
    value += g[m] * kFactorials[m] * power * phi[m + 1];
    power *= u;
  }
  return value;
}

// One piece, s ∈ [0, 1] with |μ| <= kFeedForwardPieceMu.
RotatingFrameStep Piece(PhaseVector mu, const ForcingPolynomial& g, PhaseVector start) {
  const std::array<PhaseVector, kOrders> phi = Phi(-mu);
  RotatingFrameStep r;
  r.end = phi[0] * start;
  r.integral = phi[1] * start;
  for (int m = 0; m <= kDegree; ++m) {
    r.end += g[m] * kFactorials[m] * phi[m + 1];
    r.integral += g[m] * kFactorials[m] * phi[m + 2];
  }
  // 6-point Gauss-Legendre on [0, 1]: exact for |I|² of a quintic I (a quartic G's solution at
  // μ = 0); the exponential parts' error is about 1e-9 relative at |μ| = 3.
  static constexpr int kNodes = 6;
  static constexpr double kNode[kNodes] = {0.033765242898423975, 0.16939530676686776,
                                           0.38069040695840156,  0.6193095930415985,
                                           0.8306046932331322,   0.966234757101576};
  static constexpr double kWeight[kNodes] = {0.0856622461895852, 0.1803807865240693,
                                             0.2339569672863455, 0.2339569672863455,
                                             0.1803807865240693, 0.0856622461895852};
  for (int k = 0; k < kNodes; ++k)
    r.norm_integral += kWeight[k] * std::norm(At(mu, g, start, kNode[k]));
  return r;
}

}  // namespace

RotatingFrameStep AdvanceRotatingFrame(PhaseVector mu, const ForcingPolynomial& g,
                                       PhaseVector start) {
  const int pieces = std::max(1, static_cast<int>(std::ceil(std::abs(mu) / kFeedForwardPieceMu)));
  if (pieces == 1) return Piece(mu, g, start);
  // Piece p covers s = (p + u)/n: G(s) re-expanded in u, Gp_k = Σ_{m>=k} gm·C(m, k)·p^{m−k}/n^m.
  const double n = pieces;
  RotatingFrameStep total;
  PhaseVector current = start;
  for (int p = 0; p < pieces; ++p) {
    ForcingPolynomial local{};
    for (int m = 0; m <= kDegree; ++m) {
      double binomial = 1;  // C(m, k)
      for (int k = 0; k <= m; ++k) {
        local[k] += g[m] * binomial * std::pow(p, m - k) / std::pow(n, m) / n;  // (d/du = d/ds/n)
        binomial = binomial * (m - k) / (k + 1);
      }
    }
    const RotatingFrameStep r = Piece(mu / n, local, current);
    total.integral += r.integral / n;
    total.norm_integral += r.norm_integral / n;
    current = r.end;
  }
  total.end = current;
  return total;
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
