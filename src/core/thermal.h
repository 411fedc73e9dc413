// Heat (SPEC §8): the copper loss warms the winding, the winding the housing, the housing the air;
// the winding's temperature raises its resistance and weakens the magnet.
//
// A two-node thermal network, each node a heat capacity, joined by thermal resistances:
//
//   P ──► winding (C_w) ──R_wh──► housing (C_h) ──R_ha──► ambient T_a
//
//   C_w·dθw/dt = P − (θw − θh)/R_wh                  θw = T_w − T_a, θh = T_h − T_a (rises, K)
//   C_h·dθh/dt = (θw − θh)/R_wh − θh/R_ha            P = R(T_w)·(ia² + ib²), W (S-8's copper term)
//
// i.e. dθ/dt = A·θ + b·P. For P held over an interval h the exact solution is
//   θ(h) = e^{A·h}·θ(0) + A⁻¹·(e^{A·h} − I)·b·P,
// computed in A's eigenbasis (ThermalNetwork): no step-size limit, the same for one step of 1 s as
// for 20 000 steps of 50 µs. Iron loss (hysteresis and eddy currents in the laminations, growing
// with speed) is not modelled: P is the copper loss alone.
//
// The temperature laws, with T in °C and the reference 20 °C at which datasheets give R:
//   R(T)  = R20·(1 + α·(T − 20)),    α = 0.00393 /K  (annealed copper, IEC 60028)
//   Km(T) = Km20·(1 + β·(T − 20)),   β = −0.0011 /K  (an NdFeB hybrid's magnet: remanence falls
//           0.09-0.12 %/K for sintered NdFeB; ferrite about 0.2 %/K)
// The winding warms over minutes (thermal time constants of 18-39 min, Trinamic's QSH manuals),
// the currents change over milliseconds: a drive holds R and Km over one simulation step at the
// step's starting temperature.
#ifndef MJSTEPPER_CORE_THERMAL_H_
#define MJSTEPPER_CORE_THERMAL_H_

#include <array>

namespace mjstepper {

/// The temperature at which R and Km are given (datasheets: "phase resistance at 20 °C"), °C.
inline constexpr double kReferenceTemperature = 20.0;

/// The winding temperatures at which R(T) and Km(T) are evaluated are limited to this range, °C:
/// the linear laws mean nothing far outside it (and R stays > 0 for any α and β the attributes
/// accept). The temperatures themselves are not limited.
inline constexpr double kLeastLawTemperature = -60.0;
inline constexpr double kMostLawTemperature = 400.0;

/// The network's constants: every one finite and > 0.
struct ThermalParams {
  double resistance_winding = 0;  ///< R_wh, K/W: winding → housing
  double resistance_housing = 0;  ///< R_ha, K/W: housing → ambient
  double capacity_winding = 0;    ///< C_w, J/K
  double capacity_housing = 0;    ///< C_h, J/K
};

/// Throws std::invalid_argument naming the field, its value and the rule.
void Validate(const ThermalParams& p);

/// Heat as a drive uses it: the network, the air around it, where it starts, and the laws.
struct HeatParams {
  ThermalParams network;
  double ambient_temperature = 25.0;             ///< T_a, °C
  double initial_temperature = 25.0;             ///< T_w = T_h at the start (Drive::Rest), °C
  double insulation_limit = 130.0;               ///< °C: the winding's insulation class (B)
  double resistance_coefficient = 0.00393;       ///< α, 1/K
  double torque_constant_coefficient = -0.0011;  ///< β, 1/K
};

/// Throws std::invalid_argument naming the field, its value and the rule.
void Validate(const HeatParams& p);

/// 1 + c·(T − 20) at T limited to [kLeastLawTemperature, kMostLawTemperature]: the factor on R20
/// (c = α) or Km20 (c = β).
double TemperatureFactor(double coefficient, double temperature);

/// The network of ThermalParams, decomposed once: A = D^{-1/2}·Q·Λ·Qᵀ·D^{1/2}, D = diag(C_w, C_h),
/// where D^{1/2}·A·D^{-1/2} is symmetric (a passive network), so Q is orthonormal and the two
/// eigenvalues λ1, λ2 are real, negative and distinct.
class ThermalNetwork {
 public:
  ThermalNetwork() = default;
  explicit ThermalNetwork(const ThermalParams& p);  ///< validates

  /// The rises (θw, θh), K, after `h` s with the power `power` (W) held, from `rise`: exact.
  std::array<double, 2> Step(std::array<double, 2> rise, double power, double h) const;

  /// The two modes' time constants −1/λ, s, the fast one first.
  std::array<double, 2> TimeConstants() const;

  /// The steady rises under a held power P: θw = P·(R_wh + R_ha), θh = P·R_ha.
  std::array<double, 2> SteadyRise(double power) const;

 private:
  ThermalParams p_;
  std::array<double, 2> rates_{};  // λ1, λ2, 1/s (negative)
  // Modal coordinates y = M·θ, θ = N·y; the power enters mode i as c_i·P.
  std::array<std::array<double, 2>, 2> to_modes_{};    // M = Qᵀ·D^{1/2}
  std::array<std::array<double, 2>, 2> from_modes_{};  // N = D^{-1/2}·Q
  std::array<double, 2> input_{};                      // c = M·b, b = (1/C_w, 0)
};

/// A winding's rises (θw, θh), K, after `duration` s carrying the phase currents' mean square
/// sum `current_squared` = mean(ia² + ib²), A², from `rise`: the copper loss
/// P = R20·TemperatureFactor(α, T_a + θw)·current_squared, held over each of `pieces` equal
/// intervals at the interval's starting temperature (ThermalNetwork::Step is exact for a held P).
/// A drive that regulates its currents keeps ia² + ib² whatever R: this is how a duty cycle's heat
/// is carried over many cycles from one simulated cycle (`mjstepper size`).
std::array<double, 2> RiseUnderCurrent(const ThermalNetwork& network, const HeatParams& heat,
                                       double r20, double current_squared,
                                       std::array<double, 2> rise, double duration, int pieces);

/// The winding's steady temperature, °C, under `current_squared` held for ever: the fixed point of
/// θw = (R_wh + R_ha)·R20·(1 + α·(T_a + θw − 20))·i², i.e.
///   θw = k·(1 + α·(T_a − 20)) / (1 − k·α),  k = (R_wh + R_ha)·R20·i²;
/// +infinity when k·α >= 1 (the loss grows faster with T than the network sheds it: runaway).
double SteadyWindingTemperature(const HeatParams& heat, double r20, double current_squared);

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_THERMAL_H_
