// The PI current loop of T(9)-(11) replaced by its continuous closed-loop response: the averaged
// fidelity of `current_microstep` (SPEC §11: "the PI loop by its closed-loop response with its
// delay"), and of `servo` and `identification`, whose loop (T(18)) runs in the encoder's frame
// ψ = Nr·θfb with id* = 0 and iq* held (drive.cc); below, θcmd stands for the frame's angle.
//
// The digital loop samples i at t_k, reads it in the frame ψk = Nr·θcmd(t_k) (rounded to the
// microstep table), and holds e^{jψk}·(Kp·e[k] + s[k]) over [t_k + D, t_k + D + T]. To the winding
// that staircase is, for each part turning at μ (rad/s), its fundamental: scaled by sinc(μ·T/2)
// and lagged by τ = D + T/2, as the averaged voltage drive's (drive.cc). The averaged loop applies
// that fundamental, continuous, part by part:
//   - the setpoint and the integrator, e^{jψ}·(Kp·(Id + j·iq*) + s) of T(9)-(13) at the lagged
//     command θcmd(t − τ): known parts cm·e^{jμm·t}, each applied as sinc(μm·T/2)·cm;
//   - the feedback −Kp·i(t_k): the loop reads and writes the current in the same frame ψk, so it
//     is −Kp·i held and lagged, whatever the frame; a current part Pm·e^{jμm·t} meets
//     −Kp·G(μm)·Pm, G(μ) = sinc(μ·T/2)·e^{−jμτ}, the loop's own frequency response.
// With S-3 (L·i' = v − R·i − e) each part forced at μm (the setpoint's, the damping's and the
// back-EMF's j·Km·ω·e^{jx(t)}) is then exactly
//   Pm = Vm / (R + jμm·L + Kp·G(μm)),
// and the current is i(t) = Σm Pm·e^{jμm·t} + C·e^{−α·t}, C = i0 − Σm Pm, whose transient turns
// with no single μ and decays at α = (R + Kp·G(−α))/L, the root at which the sampled, delayed
// feedback meets its own exponential (G(−α) = e^{ατ}·sinh(αT/2)/(αT/2); the digital loop's
// dominant pole to 0.3 % on Tsui's drive). Every part meets
// S-3 exactly, so S-8's energies follow in closed form (integrals of products of exponentials).
//
// The frame: with a continuous setpoint (microsteps = 0) it turns at Ωf = Ωc = Nr·θ̇cmd. A table's
// staircase is followed piece by piece (its frame held, Ωf = 0) between the lagged command's
// microstep crossings while a (sub-)step crosses at most kAveragedLoopPieces of them; beyond, the
// staircase is replaced by its fundamental, the continuous frame scaled by sinc(Δψ/2) (Δψ the
// microstep's electrical angle: rounding to the nearest entry centres the staircase, no lag).
//
// The integrator (T(10): Ki per tick, Ki/T per second) is slow against the loop (Tsui's gains: its
// zero at Ki/(Kp·T) = 27 rad/s, the loop's pole at (R + Kp)/L = 3 800 1/s). It is held over a piece
// and then moves by (Ki/T)·∫e dt of the exact e(t) (first-order splitting), e read as the
// interrupts read it: at the command's own time, not the lagged one, so that it holds the sampled
// current on the command as the digital loop's integrator does.
//
// Where the bus cuts the request (S-13/S-14) the loop is not linear, and no closed form holds: a
// piece whose voltage leaves the stage's range at any of its samples (at most 0.5 rad of rotation
// apart) is run instead as the interrupts run it: a tick of the unit's own each period T from the
// piece's start (the request clamped, the integrator frozen: anti-windup), its voltage applied D
// later, on the exact winding solution. Its cost is then the switching form's.
#ifndef MJSTEPPER_CORE_AVERAGED_CURRENT_LOOP_H_
#define MJSTEPPER_CORE_AVERAGED_CURRENT_LOOP_H_

#include "core/controllers/current_microstep.h"
#include "core/power_stage.h"
#include "core/winding.h"

namespace mjstepper {

/// The most damping harmonics (T(13)) the averaged loop carries: each adds two terms.
inline constexpr int kAveragedLoopHarmonics = 4;

/// A (sub-)step crossing more of the table's microsteps than this is averaged over the staircase's
/// fundamental rather than piece by piece.
inline constexpr int kAveragedLoopPieces = 2;

/// One (sub-)step of an averaged PI loop: its frame's chord and the rotor's motion over it.
struct AveragedLoopStep {
  /// The frame's angle at the step's start, rad (rotor side): θcmd for the PI drive (S-12), the
  /// encoder's θfb for the servo and identification (T(18)).
  double theta_frame = 0;
  double omega_frame = 0;        ///< its chord's speed over the step, rad/s
  double omega = 0;              ///< the rotor's speed, constant over the step, rad/s
  PhaseVector rotor_phasor;      ///< e^{jNr·θ} at the step's start
  PhaseVector rotor_phasor_end;  ///< and at its end
  double h = 0;                  ///< s
  double compute_delay = 0;      ///< D, s
  /// A, an iq* held over the step beside the setpoint's: the servo's T(19) between position
  /// updates, identification's Fs·sgn(ωfb)/Km of T(8); 0 for the PI drive.
  double iq = 0;
  /// 1/s, the transient's rate TransientRate() for this winding and loop, made once; 0: made here.
  double transient_rate = 0;
};

/// The rate α (1/s) at which the loop's transient decays: the real root of
/// L·α = R + Kp·G(−α), G(−α) = e^{ατ}·sinh(αT/2)/(αT/2), the sampled, held feedback delayed by
/// τ = D + T/2 meeting its own exponential; and dα/dR there (1/(Ω·s)), for a winding whose R
/// moves with its temperature (linear in R to 5e-5 of α over a 40 % rise on Tsui's drive).
/// Depends on the winding and the loop only: made at load.
struct LoopTransient {
  double rate = 0;     ///< α, 1/s
  double per_ohm = 0;  ///< dα/dR, 1/(Ω·s)
};
LoopTransient TransientRate(double resistance, double inductance, double kp, double period,
                            double lag);

/// What the step leaves: the phase currents and the applied voltage at its end, and its energies.
struct AveragedLoopResult {
  PhaseVector current;  ///< A
  PhaseVector voltage;  ///< V
  IntervalEnergy energy;
  int pieces = 0;  ///< closed-form pieces
  int held = 0;    ///< held-voltage periods (the bus cut the request)
};

/// Advances the windings and the loop's integrator s (V, d + j·q; updated in place) over one
/// (sub-)step, the loop regulating `setpoint` (T(12)-(13): id*, the damping harmonics in iq*, the
/// table) plus j·step.iq in its frame. `k` is what the drive assumes (Km for iq*, T), `motor` the
/// winding's true, possibly hot, constants.
AveragedLoopResult AdvanceAveragedLoop(const MicrostepSetpoint& setpoint, const DqCurrentLoop& loop,
                                       const DriveConstants& k, const MotorParams& motor,
                                       const PowerStage& stage, const AveragedLoopStep& step,
                                       PhaseVector current0, PhaseVector* integral);

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_AVERAGED_CURRENT_LOOP_H_
