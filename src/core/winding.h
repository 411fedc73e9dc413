// Winding integration over one interval with the phase voltage held (zero-order hold, S-15) while
// the rotor turns at constant speed: S-3 in phase-vector form,
//   L·di/dt + R·i = v − j·Km·ω·e^{jx(t)},   x(t) = Nr·(θ0 + ω·t).
// Its exact solution, for any interval length (no step-size limit, no stiffness problem):
//   i(t) = v/R + P·e^{jx(t)} + (i0 − v/R − P·e^{jx0})·e^{−R·t/L},   P = −j·Km·ω / (R + j·Nr·ω·L).
// The first two terms are the steady-state response to the held voltage and to the back-EMF of a
// rotor turning at ω; the third is the electrical transient, decaying at R/L.
#ifndef MJSTEPPER_CORE_WINDING_H_
#define MJSTEPPER_CORE_WINDING_H_

#include <cmath>

#include "core/motor.h"

namespace mjstepper {

/// sin(x)/x, with its limit 1 at 0: the fundamental's amplitude of a phasor turning by 2x over
/// each hold of a zero-order hold (the staircase of a drive's interrupts).
/// Below |x| = 0.2 by its series to x⁸ (the remainder x¹⁰/11! < 3e-15).
inline double Sinc(double x) {
  if (std::abs(x) >= 0.2) return std::sin(x) / x;
  const double u = x * x;
  return 1 - u / 6 * (1 - u / 20 * (1 - u / 42 * (1 - u / 72)));
}

/// ∫0^h e^{s·t} dt = (e^{s·h} − 1)·(1/s) given exp_sh = e^{s·h} and inv_s() = 1/s (called only
/// where s·h is not small), by its series where s·h is small (no cancellation at s → 0; the
/// series' error there is (s·h)⁴/120 < 1e-14 relative).
template <class InverseOfS>
PhaseVector IntegralOfExp(PhaseVector s, double h, PhaseVector exp_sh, InverseOfS inv_s) {
  const PhaseVector z = s * h;
  if (std::norm(z) < 1e-6) return h * (1.0 + z / 2.0 + z * z / 6.0 + z * z * z / 24.0);
  return (exp_sh - 1.0) * inv_s();
}

/// Energies over one interval, J. Input va·ia + vb·ib, copper R·|i|², mechanical τm·ω (S-8).
/// AdvanceInterval also gives the charge ∫i dt (A·s, each phase), the integral the input's is.
struct IntervalEnergy {
  double input = 0;
  double copper = 0;
  double mechanical = 0;
  PhaseVector charge;  ///< ∫i dt, A·s (AdvanceInterval only)
};

/// What an interval's exact solution needs that depends only on its length h: e^{−ah} and the
/// integrals ∫0^h e^{−at} dt and ∫0^h e^{−2at} dt (a = R/L). A drive computes these once at load
/// for the interval lengths its clock produces (T, D, T − D).
struct DecayKernel {
  DecayKernel() = default;
  DecayKernel(const MotorParams& p, double h);

  double h = -1;      // s; -1: none
  double decay = 0;   // e^{−ah}
  double int_a = 0;   // ∫e^{−at}, s
  double int_2a = 0;  // ∫e^{−2at}, s
};

/// What every interval of one simulation step shares, the rotor turning at ω throughout: P and
/// 1/(jΩ − a), from which all the step's divisions follow (1/(−jΩ − a) is its conjugate).
struct SpeedKernel {
  SpeedKernel() = default;
  SpeedKernel(const MotorParams& p, double omega);
  /// Also given the step [0, h] over which the rotor turns from electrical phasor z0 to z1
  /// (Ω·h = Nr·(θ1 − θ0)), so that the rotations over h and h/2 need no sincos.
  SpeedKernel(const MotorParams& p, double omega, double h, PhaseVector z0, PhaseVector z1);

  /// e^{jΩt}: from the step's phasors when t is h or h/2 (to 1e-9 of t), else by sincos.
  PhaseVector Rotation(double t) const;

  double omega = 0;           // rad/s
  double electrical = 0;      // Ω = Nr·ω, rad/s
  double decay_rate = 0;      // a = R/L, 1/s
  PhaseVector emf_gain;       // P = −j·Km·ω / (R + j·Ω·L), A
  PhaseVector inv_jw_a;       // 1/(jΩ − a), s
  double step = -1;           // h, s; -1: no step given
  PhaseVector step_rotation;  // e^{jΩh} = z1·conj(z0)
  PhaseVector half_rotation;  // e^{jΩh/2} = (1 + e^{jΩh})/|1 + e^{jΩh}|, valid for |Ω·h| < π
};

/// An interval's whole kernel: e^{jΩh}, e^{−ah}, P and the integrals ∫0^h e^{s·t} dt of the
/// energies. Every interval of one length within one simulation step shares it (the drive keeps
/// the last one: at 1 MHz, 50 intervals per step, one kernel).
struct WindingKernel {
  WindingKernel() = default;
  WindingKernel(const MotorParams& p, double omega, double h);
  /// From its two parts: one sincos and a few products, no division.
  WindingKernel(const SpeedKernel& speed, const DecayKernel& decay);

  double h = -1;         // s; -1: none yet
  double omega = 0;      // rad/s
  PhaseVector rotation;  // e^{jΩh}, Ω = Nr·ω
  double decay = 0;      // e^{−ah}, a = R/L
  PhaseVector emf_gain;  // P = −j·Km·ω / (R + j·Ω·L)
  PhaseVector int_jw;    // ∫e^{jΩt}
  double int_a = 0;      // ∫e^{−at}
  double int_2a = 0;     // ∫e^{−2at}
  PhaseVector int_jw_a;  // ∫e^{(jΩ−a)t}; ∫e^{(−jΩ−a)t} is its conjugate
};

/// One interval of S-3 with v held from current i0, the rotor at electrical phasor e^{jx0} and
/// turning at the kernel's ω: the current at its end, and (if `energy` is not null) its energies.
PhaseVector AdvanceInterval(const MotorParams& p, const WindingKernel& k, PhaseVector current0,
                            PhaseVector voltage, PhaseVector phasor0, IntervalEnergy* energy);

/// One interval of length h of S-3 driven by a rotating voltage v(t) = v0·e^{jΩc·t} (a voltage
/// drive's K(5) without its clock's staircase: the averaged fidelity, SPEC §11) while the rotor
/// turns at ω from electrical phasor e^{jx0}. Exact for any h:
///   i(t) = Q·e^{jΩc·t} + P·e^{jx(t)} + (i0 − Q − P·e^{jx0})·e^{−a·t},   Q = v0/(R + j·Ωc·L),
/// the first term the steady response to the rotating voltage (Ωc = 0: v0/R, AdvanceInterval's).
/// The current at the end, and (if `energy` is not null) the interval's energies in closed form.
PhaseVector AdvanceRotatingVoltage(const MotorParams& p, double omega, PhaseVector current0,
                                   PhaseVector voltage0, double command_electrical_speed, double h,
                                   PhaseVector phasor0, IntervalEnergy* energy);

/// One interval of S-3 with v held and θ moving linearly from θ0 at speed ω.
class WindingInterval {
 public:
  WindingInterval(const MotorParams& p, PhaseVector current0, PhaseVector voltage, double theta0,
                  double omega);

  /// Phase currents at time t after the interval's start (A); exact for any t >= 0.
  PhaseVector CurrentAt(double t) const;

  /// Energies over [0, h], integrated in closed form from the exact solution (sums of
  /// exponentials), so S-8 holds to round-off: a test of the solution, not of a quadrature.
  IntervalEnergy Energy(double h) const;

  /// The current at the interval's end, t = h (as CurrentAt(h)), and, if `energy` is not null, the
  /// interval's energies (as Energy(h)), sharing their exponentials.
  PhaseVector EndOfInterval(double h, IntervalEnergy* energy) const;

 private:
  // i(t) = steady_ + emf_·e^{jΩt} + transient_·e^{−a·t},  Ω = Nr·ω,  a = R/L.
  const MotorParams& p_;
  PhaseVector voltage_;      // V
  double theta0_;            // rad
  double omega_;             // rad/s
  double decay_;             // a = R/L, 1/s
  double electrical_speed_;  // Ω = Nr·ω, rad/s
  PhaseVector steady_;       // v/R, A
  PhaseVector emf_;          // P·e^{jx0}, A
  PhaseVector transient_;    // i0 − v/R − P·e^{jx0}, A
};

/// Reference solver for tests: classical RK4 on S-3 with steps of at most max_step.
PhaseVector IntegrateWindingRk4(const MotorParams& p, PhaseVector current0, PhaseVector voltage,
                                double theta0, double omega, double h, double max_step);

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_WINDING_H_
