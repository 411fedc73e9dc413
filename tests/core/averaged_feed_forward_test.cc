// core/averaged_feed_forward.h: (F-2), the rotor-frame winding under a polynomial forcing, against
// a fine classical Runge-Kutta integration of (F-1) itself.
#include "core/averaged_feed_forward.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <complex>

namespace mjstepper {
namespace {

// (F-1) by RK4 in n steps, the integrals carried as states of their own: y = (I, ∫I, ∫|I|²).
RotatingFrameStep Rk4(PhaseVector mu, const ForcingPolynomial& g, PhaseVector start, int n) {
  struct Y {
    PhaseVector i, integral;
    double norm = 0;
    Y operator+(const Y& o) const { return {i + o.i, integral + o.integral, norm + o.norm}; }
    Y operator*(double a) const { return {a * i, a * integral, a * norm}; }
  };
  auto slope = [&](double s, const Y& y) {
    PhaseVector forcing = 0;
    for (int m = 4; m >= 0; --m) forcing = forcing * s + g[m];
    return Y{-mu * y.i + forcing, y.i, std::norm(y.i)};
  };
  Y y{start, 0, 0};
  const double h = 1.0 / n;
  for (int k = 0; k < n; ++k) {
    const double s = k * h;
    const Y k1 = slope(s, y), k2 = slope(s + h / 2, y + k1 * (h / 2)),
            k3 = slope(s + h / 2, y + k2 * (h / 2)), k4 = slope(s + h, y + k3 * h);
    y = y + (k1 + k2 * 2 + k3 * 2 + k4) * (h / 6);
  }
  return {.end = y.i, .integral = y.integral, .norm_integral = y.norm};
}

// (F-2) is exact: it equals the integration to its own accuracy (RK4 in 20 000 steps: 1e-13) at a
// small μ (no cancellation: a 50 µs step of Kim's winding at rest, μ = 0.0128), a turning one
// (|μ| 1.6) and one cut into pieces (|μ| 9.4, three pieces), with every power of s forced. The
// copper's integral is 6-point Gauss-Legendre: exact for the polynomial part, 1.0e-9 relative at
// |μ| 1.6 (measured); the band is 1e-8 where |μ| > 1, 1e-12 below.
TEST(AveragedFeedForward, TheRotorFrameSolutionIsTheWindingsOwn) {
  const ForcingPolynomial g = {PhaseVector(0.3, -0.2), PhaseVector(-1.1, 0.7),
                               PhaseVector(2.0, 0.4), PhaseVector(-0.8, -1.5),
                               PhaseVector(0.5, 0.9)};
  const PhaseVector start(0.4, -0.25);
  for (const PhaseVector mu :
       {PhaseVector(0.0128, 0.0), PhaseVector(0.26, 1.57), PhaseVector(0.5, -9.4)}) {
    SCOPED_TRACE(std::abs(mu));
    const RotatingFrameStep exact = AdvanceRotatingFrame(mu, g, start);
    const RotatingFrameStep fine = Rk4(mu, g, start, 20000);
    EXPECT_LT(std::abs(exact.end - fine.end), 1e-9 * std::abs(fine.end));
    EXPECT_LT(std::abs(exact.integral - fine.integral), 1e-9 * std::abs(fine.integral));
    EXPECT_NEAR(exact.norm_integral / fine.norm_integral, 1.0, std::abs(mu) > 1 ? 1e-8 : 1e-12);
  }
}

// (F-3): a real 2×2 M that is no complex multiplication (the FOC's: the law reads Im I), against
// the same integration on (Re I, Im I); one piece and, with ‖M‖ 9.6, three.
TEST(AveragedFeedForward, TheRealTwoByTwoSolutionIsTheWindingsOwn) {
  const ForcingPolynomial g = {PhaseVector(0.3, -0.2), PhaseVector(-1.1, 0.7),
                               PhaseVector(2.0, 0.4), PhaseVector(-0.8, -1.5),
                               PhaseVector(0.5, 0.9)};
  const PhaseVector start(0.4, -0.25);
  for (const double scale : {1.0, 4.0}) {
    Eigen::Matrix2d m;
    m << -0.6, 1.1, -0.3, -1.3;  // on (Re I, Im I)
    m *= scale;
    SCOPED_TRACE(scale);
    // RK4 on y = (Re I, Im I, ∫Re I, ∫Im I, ∫|I|²).
    using Y = Eigen::Matrix<double, 5, 1>;
    auto slope = [&](double s, const Y& y) {
      PhaseVector forcing = 0;
      for (int k = 4; k >= 0; --k) forcing = forcing * s + g[k];
      const Eigen::Vector2d i = y.head<2>();
      const Eigen::Vector2d di = m * i + Eigen::Vector2d(forcing.real(), forcing.imag());
      Y out;
      out << di, i, i.squaredNorm();
      return out;
    };
    Y y;
    y << start.real(), start.imag(), 0, 0, 0;
    const int n = 20000;
    const double h = 1.0 / n;
    for (int k = 0; k < n; ++k) {
      const double s = k * h;
      const Y k1 = slope(s, y), k2 = slope(s + h / 2, y + h / 2 * k1),
              k3 = slope(s + h / 2, y + h / 2 * k2), k4 = slope(s + h, y + h * k3);
      y += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    }
    const RotatingFrameStep exact =
        AdvanceRotatingFrame({m(0, 0), m(0, 1), m(1, 0), m(1, 1)}, g, start);
    EXPECT_LT(std::abs(exact.end - PhaseVector(y(0), y(1))), 1e-9 * std::hypot(y(0), y(1)));
    EXPECT_LT(std::abs(exact.integral - PhaseVector(y(2), y(3))), 1e-9 * std::hypot(y(2), y(3)));
    EXPECT_NEAR(exact.norm_integral / y(4), 1.0, 1e-8);
  }
}

// The quartic through five samples at s = 0, 1/4, 1/2, 3/4, 1 is the polynomial they sample.
TEST(AveragedFeedForward, TheQuarticThroughFiveSamplesIsTheirs) {
  const std::array<double, 5> c = {0.1, -2.0, 3.5, 0.25, -1.75};
  std::array<double, 5> samples;
  for (int k = 0; k < 5; ++k) {
    const double s = 0.25 * k;
    samples[k] = c[0] + s * (c[1] + s * (c[2] + s * (c[3] + s * c[4])));
  }
  const std::array<double, 5> fitted = QuarticThrough(samples);
  for (int m = 0; m < 5; ++m) EXPECT_NEAR(fitted[m], c[m], 1e-12) << m;
}

}  // namespace
}  // namespace mjstepper
