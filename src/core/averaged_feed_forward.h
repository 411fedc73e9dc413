// Kim's position laws averaged: the fidelity = averaged form of his STMMS (SPEC §11, Kim 2016
// K(20)-(32)) and of his high-gain FOC (K(33)-(34), F-3 below). The STMMS's interrupts (1 MHz in
// Kim's simulation) apply
//   v[k] = R·id[k] + j·Km·ω·e^{jx[k]},   id = j·(τd/Km)·e^{jx},                          K(27)-(28)
// with τd of K(24) from the sampled rotor and command, and no current feedback.
//
// Over one (sub-)step the rotor turns at a constant ω (the drive's step, drive.h) and the command
// is a polynomial in time (a profile's quadratic pieces, a ctrl's line), so the law's τd is a
// polynomial too: K(24) is linear in e1, ė1, e0 = ∫e1 and θ̈d. The interrupts' staircase reaches
// the winding as its fundamental, lagged by D + T/2 and scaled by sinc(Ω·T/2) (the averaged voltage
// drive's, drive.cc). In the rotor's frame, I = i·e^{−jx}, x = Nr·θ, S-3 becomes
//   dI/ds = −μ·I + G(s),  s = (t − t0)/h ∈ [0, 1],  μ = (R/L + jΩ)·h,  Ω = Nr·ω,           (F-1)
//   G(s) = (h/L)·(c·(j·(R'/Km')·τd(t − D − T/2) + j·Km'·ω) − j·Km·ω),
//   c = sinc(Ω·T/2)·e^{−jΩ(D+T/2)}
// (R', Km': the drive's nominal constants, which the law uses; R, Km: the winding's, hot or not),
// a polynomial G(s) = Σm gm·s^m of degree <= 4. Its exact solution, with the φ functions of
// exponential integrators, φk(z) = Σj z^j/(j + k)!:
//   I(s) = e^{−μs}·I0 + Σm gm·m!·s^{m+1}·φ_{m+1}(−μs),                                       (F-2)
//   ∫0^1 I ds = φ1(−μ)·I0 + Σm gm·m!·φ_{m+2}(−μ),
// with no division by μ (no cancellation at small steps). ∫|I|² ds (the copper loss) is taken by
// 6-point Gauss-Legendre on (F-2): exact for a quintic I (the polynomial part), the exponential
// parts' error about 1e-9 relative at a piece's largest |μ| (measured against a fine integration,
// tests/core/averaged_feed_forward_test.cc); a step with |μ| > kFeedForwardPieceMu is cut into
// pieces.
//
// Kim's high-gain FOC (K(33)) adds current feedback, v = R'·i + e' + L'·(i̇d + ρ·(id − i)), with
// i̇d's ω̇ from the current, ω̇ = (Km'·Im(e^{−jx}·i) − B·ω − τl)/J, and τ̇d linear in ω̇. In the
// rotor's frame the law's terms in I are R'·I and −L'·ρ·I (read D + T/2 late in the stator, so
// turned by c) and a term in Im I; the winding is then a real 2×2 system on (Re I, Im I):
//   D·dI/dt = A·I + F(t),  dI/ds = M·I + G(s),  M = h·D⁻¹·A,  G = h·D⁻¹·F                (F-3)
// with D = L, or for the FOC L plus the first-order delay of its current feedback (the current it
// reads is I − (D + T/2)·dI/dt). (F-2) holds with the φ functions of M.
//
// Where the law's voltage might leave the power stage's linear range (a bound on |v| over the
// step for the STMMS; its value at the step's ends within kFeedForwardMargin of the range for the
// FOC) the closed form does not hold; the drive runs that step's interrupts instead (drive.cc).
#ifndef MJSTEPPER_CORE_AVERAGED_FEED_FORWARD_H_
#define MJSTEPPER_CORE_AVERAGED_FEED_FORWARD_H_

#include <array>

#include "core/motor.h"

namespace mjstepper {

/// The largest |μ| of (F-1) one piece takes; a step beyond is cut into equal pieces. The φ series
/// then converge in about 25 terms and lose at most two digits to cancellation.
inline constexpr double kFeedForwardPieceMu = 4.0;

/// The most pieces a drive lets one step take (|μ| <= 64·kFeedForwardPieceMu: a rotor turning
/// about 40 electrical cycles in the step); beyond, it runs the step's interrupts.
inline constexpr double kFeedForwardMaxPieces = 64;

/// The share of the stage's linear range a FOC step's voltage may reach at its start and end for
/// the closed form to be taken: its current feedback makes |v| over the step known only there, so
/// a tenth is left for what it does between (a heuristic, not a bound; the STMMS's is a bound).
inline constexpr double kFeedForwardMargin = 0.9;

/// The largest ρ·(D + T/2) at which the FOC's averaged form takes its current feedback as read
/// first-order late (F-3); Kim's 1 MHz clock gives 0.0125. Beyond, the drive runs the interrupts.
inline constexpr double kFeedForwardLoopLag = 0.1;

/// G(s) of (F-1): coefficients g0..g4 of s^0..s^4.
using ForcingPolynomial = std::array<PhaseVector, 5>;

/// (F-2) over s ∈ [0, 1]: the end value, and the integrals the energies need.
struct RotatingFrameStep {
  PhaseVector end;           ///< I(1), A
  PhaseVector integral;      ///< ∫0^1 I ds, A
  double norm_integral = 0;  ///< ∫0^1 |I|² ds, A²
};

/// Solves (F-1) from I(0) = start over s ∈ [0, 1] exactly (pieces of |μ| <= kFeedForwardPieceMu).
RotatingFrameStep AdvanceRotatingFrame(PhaseVector mu, const ForcingPolynomial& g,
                                       PhaseVector start);

/// M of (F-3), a real 2×2 matrix on (Re I, Im I), row-major. (Plain doubles: no Eigen type
/// crosses this header, whose callers may be built for another instruction set and so another
/// Eigen alignment.)
using RotatingFrameMatrix = std::array<double, 4>;

/// The same for dI/ds = M·I + G(s) with I read as (Re I, Im I) and M any real 2×2 matrix (F-3:
/// a law that reads Im(I), the current's torque, as the high-gain FOC's does); pieces of ‖M‖∞ <=
/// kFeedForwardPieceMu.
RotatingFrameStep AdvanceRotatingFrame(const RotatingFrameMatrix& m, const ForcingPolynomial& g,
                                       PhaseVector start);

/// The quartic through samples at s = 0, 1/4, 1/2, 3/4, 1: its coefficients of s^0..s^4.
std::array<double, 5> QuarticThrough(const std::array<double, 5>& samples);

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_AVERAGED_FEED_FORWARD_H_
