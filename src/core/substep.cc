#include "core/substep.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <tuple>

#include "core/coupling.h"

namespace mjstepper {

namespace {
using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
Eigen::Map<const RowMajor> MatrixOf(std::span<const double> v, std::size_t rows, std::size_t cols) {
  return {v.data(), static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(cols)};
}
Eigen::Map<const Eigen::VectorXd> VectorOf(std::span<const double> v) {
  return {v.data(), static_cast<Eigen::Index>(v.size())};
}
bool AllFinite(std::span<const double> v) {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

template <int MaxN>
bool InvertShiftedWith(std::span<const double> b, double delta, std::size_t n,
                       std::span<double> out) {
  using MatrixN = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, MaxN, MaxN>;
  MatrixN a = delta * MatrixOf(b, n, n);
  a.diagonal().array() += 1.0;
  const MatrixN inverse = a.partialPivLu().inverse();
  if (!inverse.allFinite()) return false;
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < n; ++j) out[i * n + j] = inverse(i, j);
  }
  return true;
}

// (I + δ·B)⁻¹ into `out` (row-major n×n); false when it is not finite.
bool InvertShifted(std::span<const double> b, double delta, std::size_t n, std::span<double> out) {
  return n <= 8 ? InvertShiftedWith<8>(b, delta, n, out)
                : InvertShiftedWith<Eigen::Dynamic>(b, delta, n, out);
}
}  // namespace

int SubstepCount(double ring, double forcing, double h) {
  const double n = std::max(std::ceil(ring * h / kSubstepRingOmegaTimesStep),
                            std::ceil(forcing * h / kSubstepOmegaTimesStep));
  if (!(n >= 1)) return 1;  // (NaN too)
  return n > kMaxSubsteps ? kMaxSubsteps : static_cast<int>(n);
}

double FastestRotorMode(std::span<const double> inverse_inertia,
                        std::span<const double> stiffness) {
  const std::size_t n = stiffness.size();
  double norm = 0;  // ‖G·K‖∞, 1/s²: bounds every eigenvalue of G·K
  for (std::size_t i = 0; i < n; ++i) {
    double row = 0;
    for (std::size_t j = 0; j < n; ++j) row += std::abs(inverse_inertia[i * n + j] * stiffness[j]);
    norm = std::max(norm, row);
  }
  return std::sqrt(norm);
}

void IntegrateRotors(const RotorLoad& load, SubsteppedMotors& motors, double t0, double t1,
                     int substeps, std::span<double> theta, std::span<double> omega,
                     std::span<double> scratch) {
  const std::size_t n = theta.size();
  if (omega.size() != n || load.inverse_inertia.size() != n * n || load.acceleration.size() != n ||
      load.reference_speed.size() != n || (!load.damping.empty() && load.damping.size() != n * n) ||
      scratch.size() < 4 * n || substeps < 1) {
    throw std::invalid_argument("IntegrateRotors: G, B n×n; a_x, c0, ω n long; 4·n scratch");
  }
  const std::span<double> torque = scratch.subspan(0, n);  // τ, N·m
  const std::span<double> stiffness = scratch.subspan(n, n);
  const std::span<double> accel = scratch.subspan(2 * n, n);   // R-1's other terms, rad/s²
  const std::span<double> handed = scratch.subspan(3 * n, n);  // C-3's torques, N·m
  const std::span<const double> g = load.inverse_inertia;
  // The damping taken implicitly, as MuJoCo's Euler step takes it: (I + δ·B)·ω1 = ω0 + δ·(…), with
  // (I + δ·B)⁻¹ made once for the nominal δ (the sub-steps differ by round-off only).
  // (Row-major n×n in `scratch` past R-1's 4·n: no heap.)
  const std::span<double> implicit_damping = scratch.subspan(4 * n, load.damping.size());
  if (!load.damping.empty()) {
    const double delta = (t1 - t0) / substeps;
    if (!InvertShifted(load.damping, delta, n, implicit_damping)) {
      for (std::size_t i = 0; i < n; ++i) {
        for (std::size_t j = 0; j < n; ++j) implicit_damping[i * n + j] = i == j ? 1.0 : 0.0;
      }
    }
  }
  for (int k = 0; k < substeps; ++k) {
    // The sub-step's ends from the step's: no drift of t over many sub-steps, and the last is t1.
    const double ta = k == 0 ? t0 : t0 + (t1 - t0) * k / substeps;
    const double tb = k + 1 == substeps ? t1 : t0 + (t1 - t0) * (k + 1) / substeps;
    const double delta = tb - ta;  // s
    for (std::size_t i = 0; i < n; ++i) {
      std::tie(torque[i], stiffness[i]) =
          motors.TorqueAndStiffness(static_cast<int>(i), theta[i], omega[i]);
      // R-1 without G·τ and without the damping, which the velocity update below takes
      // implicitly: a_x + B·c0 (as the consistent coupling's a_ext leaves out the damping MuJoCo
      // integrates implicitly: C-1's σ scales the spring's map, not the damper's).
      double a = load.acceleration[i];
      if (!load.damping.empty()) {
        for (std::size_t j = 0; j < n; ++j) a += load.damping[i * n + j] * load.reference_speed[j];
      }
      accel[i] = a;
    }
    // C-3 over the sub-step (C-2 for one rotor): the linearised rotors' exact map.
    if (n == 1) {
      handed[0] = g[0] > 0 ? ConsistentTorque(torque[0], stiffness[0], 1.0 / g[0], accel[0], delta)
                           : torque[0];
    } else {
      ConsistentTorques(g, stiffness, torque, accel, delta, handed);
    }
    // Symplectic Euler on the handed torques: ω1 = ω0 + δ·(G·τ + a_x − B·(ω1 − c0)).
    for (std::size_t i = 0; i < n; ++i) {
      double a = accel[i];  // a_x + B·c0
      for (std::size_t j = 0; j < n; ++j) a += g[i * n + j] * handed[j];
      accel[i] = omega[i] + delta * a;  // (I + δ·B)·ω1
    }
    if (load.damping.empty()) {
      for (std::size_t i = 0; i < n; ++i) omega[i] = accel[i];
    } else {
      for (std::size_t i = 0; i < n; ++i) {
        double w = 0;
        for (std::size_t j = 0; j < n; ++j) w += implicit_damping[i * n + j] * accel[j];
        omega[i] = w;
      }
    }
    for (std::size_t i = 0; i < n; ++i) {
      theta[i] += delta * omega[i];
      motors.Advance(static_cast<int>(i), ta, tb, theta[i]);
    }
  }
}

namespace {

// R-2 with matrices of at most MaxN (rotors) and MaxS (damped dofs) rows: no heap allocation when
// both are fixed (Eigen::Dynamic for any size). Inputs checked and finite.
template <int MaxN, int MaxS>
bool SolveLanding(const Landing& landing, std::span<const double> chord, double h,
                  std::span<double> out) {
  using MatrixN = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, MaxN, MaxN>;
  using VectorN = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, MaxN, 1>;
  using MatrixS = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, MaxS, MaxS>;
  using VectorS = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, MaxS, 1>;
  using MatrixNS = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, MaxN, MaxS>;
  using MatrixSN = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, MaxS, MaxN>;
  const std::size_t n = chord.size();
  const std::size_t s = landing.step_damping.size();
  MatrixN g = MatrixOf(landing.inverse_inertia, n, n);
  VectorN a = VectorOf(landing.acceleration);
  if (s > 0) {  // R-2's Woodbury terms
    MatrixS k = MatrixOf(landing.damped_block, s, s);
    for (std::size_t i = 0; i < s; ++i) k(i, i) += 1.0 / landing.step_damping[i];
    const MatrixS symmetric = 0.5 * (k + k.transpose());
    const Eigen::LLT<MatrixS> kk(symmetric);
    if (kk.info() != Eigen::Success) return false;
    const MatrixNS u = MatrixOf(landing.damped_rows, n, s);
    const MatrixSN ut = u.transpose();
    const MatrixSN solved = kk.solve(ut);
    g.noalias() -= u * solved;
    const VectorS force = VectorOf(landing.damped_force);
    const VectorS solved_force = kk.solve(force);
    a.noalias() -= u * solved_force;
  }
  const MatrixN symmetric = 0.5 * (g + g.transpose());
  const VectorN wanted = (VectorOf(chord) - VectorOf(landing.start_speed)) / h - a;  // rad/s²
  VectorN tau;
  const Eigen::LLT<MatrixN> gg(symmetric);
  double least = std::numeric_limits<double>::infinity(), most = 0;  // L's pivots
  if (gg.info() == Eigen::Success) {
    for (std::size_t i = 0; i < n; ++i) {
      least = std::min(least, gg.matrixLLT()(i, i));
      most = std::max(most, gg.matrixLLT()(i, i));
    }
  }
  if (gg.info() == Eigen::Success && least > 1e-6 * most) {
    tau = gg.solve(wanted);
  } else {  // two rotors on one coordinate: the least-squares torques of least norm
    tau = Eigen::CompleteOrthogonalDecomposition<MatrixN>(symmetric).solve(wanted);
  }
  if (!tau.allFinite()) return false;
  for (std::size_t i = 0; i < n; ++i) out[i] = tau(i);
  return true;
}

}  // namespace

bool LandingTorques(const Landing& landing, std::span<const double> chord, double h,
                    std::span<double> out) {
  const std::size_t n = chord.size();
  const std::size_t s = landing.step_damping.size();
  if (landing.inverse_inertia.size() != n * n || landing.damped_rows.size() != n * s ||
      landing.damped_block.size() != s * s || landing.acceleration.size() != n ||
      landing.damped_force.size() != s || landing.start_speed.size() != n || out.size() < n) {
    throw std::invalid_argument("LandingTorques: G n×n, U n×s, Q s×s, a_x, c0, chord n long");
  }
  if (!(h > 0) || !std::isfinite(h) || !AllFinite(landing.inverse_inertia) ||
      !AllFinite(landing.damped_rows) || !AllFinite(landing.damped_block) ||
      !AllFinite(landing.step_damping) || !AllFinite(landing.acceleration) ||
      !AllFinite(landing.damped_force) || !AllFinite(landing.start_speed) || !AllFinite(chord)) {
    return false;
  }
  if (n <= 8 && s <= 16) return SolveLanding<8, 16>(landing, chord, h, out);  // an arm's
  return SolveLanding<Eigen::Dynamic, Eigen::Dynamic>(landing, chord, h, out);
}

namespace {

template <int MaxN>
void SolveRotorDamping(std::span<const double> inverse_inertia, std::span<const double> p,
                       std::size_t n, std::span<double> out) {
  using MatrixN = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, MaxN, MaxN>;
  const MatrixN g = MatrixOf(inverse_inertia, n, n);
  const MatrixN symmetric = 0.5 * (g + g.transpose());
  const Eigen::LLT<MatrixN> gg(symmetric);
  if (gg.info() != Eigen::Success) return;
  // B = P·G⁻¹ = (G⁻¹·P)ᵀ, both symmetric.
  const MatrixN pp = MatrixOf(p, n, n);
  const MatrixN solved = gg.solve(pp);
  if (!solved.allFinite()) return;
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < n; ++j) out[i * n + j] = solved(j, i);
  }
}

}  // namespace

void RotorDamping(std::span<const double> inverse_inertia, std::span<const double> p,
                  std::span<double> out) {
  const std::size_t n = static_cast<std::size_t>(std::sqrt(static_cast<double>(p.size())) + 0.5);
  if (inverse_inertia.size() != n * n || p.size() != n * n || out.size() < n * n) {
    throw std::invalid_argument("RotorDamping: G and P n×n");
  }
  std::fill_n(out.begin(), n * n, 0.0);
  if (!AllFinite(p) || !AllFinite(inverse_inertia)) return;
  if (n <= 8) {
    SolveRotorDamping<8>(inverse_inertia, p, n, out);
  } else {
    SolveRotorDamping<Eigen::Dynamic>(inverse_inertia, p, n, out);
  }
}

}  // namespace mjstepper
