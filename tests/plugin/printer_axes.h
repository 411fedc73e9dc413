// The printer models' axes (models/corexy.xml, models/bedslinger.xml) as models/README.md
// documents them, and their closed-form modes: shared by the models' own tests
// (printer_models_test.cc) and the resonance test's (tests/tools/resonance_test.cc).
#ifndef MJSTEPPER_TESTS_PLUGIN_PRINTER_AXES_H_
#define MJSTEPPER_TESTS_PLUGIN_PRINTER_AXES_H_

#include <cmath>
#include <numbers>
#include <utility>

namespace mjstepper::testing {

constexpr double kEA = 1.94e4;  // N, GT2 6 mm belt: specific stiffness (models/README.md)

// One belt axis as documented in models/README.md: a carriage of mass `mass` on `belts` belts in
// parallel, each of stiffness `belt_stiffness`, to `belts` rotors of inertia J on pulleys of
// radius r, each held by its motor's T' = Nr·Km·I_peak; R, L, Km for the winding's own stiffness.
struct Axis {
  const char* joint;       // the carriage's (or bed's) slide joint
  double mass;             // kg
  int belts;               // 2 for either CoreXY axis, 1 for a Cartesian one
  double belt_stiffness;   // N/m, each
  double radius;           // m, pulley pitch radius
  double holding;          // N·m/rad, T' of each motor
  double resistance;       // Ω, the motor's phase R
  double inductance;       // H, its L
  double torque_constant;  // N·m/A, its Km
  double belt_damping;     // N·s/m, each belt's (the tendon's `damping`)
};

// The belts' damping ratio of the axis' lower mode, c_total/(2·√(K_total·M)) with the belts
// alone as the spring (the motors are stiffer): the damped mode rings at ω·√(1 − ζ²).
inline double DampingRatio(const Axis& a) {
  return a.belts * a.belt_damping / (2 * std::sqrt(a.belts * a.belt_stiffness * a.mass));
}

constexpr double kRotorInertia = 8.2e-6;  // kg·m², both catalogue motors (armature)

// CoreXY: EA/L with L = 0.45 m; 17HS19-2004S1 (Nr 50, R 1.4 Ω, L 3 mH, Km 0.208597 N·m/A) at
// T' = 50·0.208597·1.125 (TMC2209, 0.8 A → 0.7955 A RMS).
constexpr double kCoreXYRadius = 0.04 / (2 * std::numbers::pi);
constexpr double kCoreXYBelt = kEA / 0.45;
constexpr double kCoreXYHolding = 50 * 0.208597 * 1.125;
constexpr Axis kCoreXYX{"x", 0.50,  2,        kCoreXYBelt, kCoreXYRadius, kCoreXYHolding,
                        1.4, 0.003, 0.208597, 20};
constexpr Axis kCoreXYY{"y", 1.10,  2,        kCoreXYBelt, kCoreXYRadius, kCoreXYHolding,
                        1.4, 0.003, 0.208597, 20};
// Bed-slinger: 8·EA/(3·L) with Lx = 0.35 m, Ly = 0.38 m; 17HM19-2004S (Nr 100, R 1.45 Ω, L 4 mH,
// Km 0.162635 N·m/A) at T' = 100·0.162635·I_peak (TMC2130 with 0.22 Ω: 0.55 A → 0.5386 A RMS,
// 0.70 A → 0.6882 A RMS).
constexpr double kBedslingerRadius = 0.032 / (2 * std::numbers::pi);
constexpr Axis kBedslingerX{
    "x",   0.55,     1, 8 * kEA / (3 * 0.35), kBedslingerRadius, 100 * 0.162635 * 0.761719, 1.45,
    0.004, 0.162635, 57};
constexpr Axis kBedslingerY{
    "y",   1.10,     1, 8 * kEA / (3 * 0.38), kBedslingerRadius, 100 * 0.162635 * 0.973307, 1.45,
    0.004, 0.162635, 77};

// The two modes of an axis whose motors each hold with `holding` N·m/rad, rad/s (README): the
// carriage M = mass on the belts' K = n·k to the rotors' μ = n·J/r² held by K_m = n·T'/r²;
// det(K − ω²·M) = 0 with K = [[K, −K], [−K, K + K_m]], M = diag(M, μ):
// M·μ·ω⁴ − (M·(K + K_m) + μ·K)·ω² + K·K_m = 0.
inline std::pair<double, double> TwoMassModes(const Axis& a, double holding) {
  const double mass = a.mass;
  const double mu = a.belts * kRotorInertia / (a.radius * a.radius);
  const double k = a.belts * a.belt_stiffness;
  const double km = a.belts * holding / (a.radius * a.radius);
  const double b = mass * (k + km) + mu * k;
  const double root = std::sqrt(b * b - 4 * mass * mu * k * km);
  return {std::sqrt((b - root) / (2 * mass * mu)), std::sqrt((b + root) / (2 * mass * mu))};
}

// The closed forms with the motors as the ideal springs T'.
inline std::pair<double, double> ClosedFormModes(const Axis& a) {
  return TwoMassModes(a, a.holding);
}

// The lower mode with the winding's own stiffness added (README, "A chopper drive rings higher"):
// a stepper at rest on a full step has one phase at a zero target, whose bridge the chopper
// shorts; the back-EMF Km·ω drives a current through R + jωL in it, whose torque in phase with
// the displacement adds Km²·ω²·L/(R² + ω²·L²) to T' at the ringing frequency ω (solved by
// iteration; it converges in a few steps as the term varies slowly with ω).
inline double ShortedPhaseMode(const Axis& a) {
  double w = ClosedFormModes(a).first;
  for (int i = 0; i < 30; ++i) {
    const double km2 = a.torque_constant * a.torque_constant;
    const double wl = w * a.inductance;
    const double extra = km2 * w * wl / (a.resistance * a.resistance + wl * wl);
    w = TwoMassModes(a, a.holding + extra).first;
  }
  return w;
}

}  // namespace mjstepper::testing

#endif  // MJSTEPPER_TESTS_PLUGIN_PRINTER_AXES_H_
