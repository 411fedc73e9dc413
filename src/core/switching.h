// Switching bridges: what a chopper drive's H-bridge does on one phase, event by event (SPEC §8).
//
// A chopper drive does not hold a voltage from tick to tick: each phase's full bridge applies +Vbus
// or −Vbus (current driven up or back into the supply: on-time, fast decay) or 0 (winding shorted:
// slow decay), and decides again at an event: a time (the end of an off-time) or the phase current
// crossing a comparator level (the target, or the target less a hysteresis), the comparator blind
// until the end of the blank time. Between events S-3 holds with a constant voltage, so the winding
// kernel (winding.h) integrates each interval exactly, and a level crossing is found as a root of
// that exact solution (FirstCrossing): the switching is simulated at its own times, whatever the
// interrupt period or the simulation step.
//
// Each chopper unit (controllers/constant_off_time.h, spread_cycle.h) keeps one PhaseSwitch per
// phase in its state and sets it from its own rules; the drive (drive.cc) only finds the next event
// of each phase and calls the unit back there.
#ifndef MJSTEPPER_CORE_SWITCHING_H_
#define MJSTEPPER_CORE_SWITCHING_H_

#include <concepts>
#include <type_traits>

#include "core/motor.h"
#include "core/power_stage.h"
#include "core/winding.h"

namespace mjstepper {

/// Why a chopper unit is asked to decide a phase's bridge again.
enum class SwitchReason {
  kTime,    ///< the phase's `until` time was reached
  kLevel,   ///< the phase current crossed the comparator level in `direction`
  kTarget,  ///< a new current target reached the phase (a tick's output, at t_k + D)
};

/// One phase's bridge and the condition on which it switches next; plain doubles (stored in the
/// unit's state, so in the simulator's state array). Times are absolute, s.
struct PhaseSwitch {
  double mode = 0;         ///< the unit's own phase of its chopper cycle (an enum as a double)
  double voltage = 0;      ///< V applied to the phase now: +Vbus, 0 or −Vbus
  double target = 0;       ///< A, the phase's current target (signed, from the microstep table)
  double has_until = 0;    ///< 1: decide again at `until`
  double until = 0;        ///< s
  double has_level = 0;    ///< 1: decide again when the current crosses the comparator level
  double direction = 0;    ///< +1: rising through the level; −1: falling through it
  double level = 0;        ///< A, the level at `armed_from`
  double level_slope = 0;  ///< A/s: the level moves linearly from `armed_from` ...
  double level_stop = 0;   ///< s ... until this time, then stays (SpreadCycle's hysteresis decay)
  double armed_from = 0;   ///< s: the comparator is blind before this time (blank time)
  double mode_start = 0;   ///< s, when `mode` began (for the unit's rules)
  double aux = 0;          ///< the unit's own value (e.g. SpreadCycle's hysteresis, A)
  // The ripple of the chopper's last whole cycle (Ripple), kept by the drive: each cycle's
  // current at its start and at each change of the bridge's voltage, between which it is nearly
  // linear (an exponential of time constant L/R, milliseconds, over microseconds).
  static constexpr int kCyclePoints = 4;  ///< the most kept per cycle (SpreadCycle makes 4)
  double cycle_open = 0;                  ///< 1 while the ongoing cycle is recorded
  double cycle_target = 0;                ///< A, its target when it began
  double cycle_from = 0;                  ///< s, the ongoing cycle's start (its on phase's)
  double charge = 0;                      ///< A·s, ∫i dt since cycle_from
  double points = 0;                      ///< how many of `at`, `current_at` the cycle has
  double at[kCyclePoints] = {};           ///< s from cycle_from
  double current_at[kCyclePoints] = {};   ///< A
  // The last whole cycle, kept if its target held throughout (a new target's slew is not ripple):
  double last_points = 0;                         ///< its points, its end included; 0: none kept
  double last_at[kCyclePoints + 1] = {};          ///< s from its start
  double last_current_at[kCyclePoints + 1] = {};  ///< A
  double last_mean = 0;                           ///< A, its mean current

  /// The comparator level at time t (s): level + slope·(clamp(t, armed_from, level_stop) −
  /// armed_from).
  double LevelAt(double t) const;

  /// After the unit decided the bridge at time t (s) with the phase current `current` (A):
  /// `cycle_starts` when an on phase began after another phase of the cycle, which closes a
  /// whole cycle (kept if its target held throughout); `voltage_changed` records a point of the
  /// ongoing one. A zero target (an idle bridge) ends the record until the next cycle.
  void NoteSwitch(bool cycle_starts, bool voltage_changed, double t, double current);

  /// The ripple at time t (s) that a simulation step of `step` (s) would fold: the last whole
  /// cycle's current at the same time into its cycle, less that cycle's mean, A. The phase
  /// current less it is the cycle's mean without its lag: a steady cycle repeats, so at any
  /// instant the current less the ripple is the mean. Past the last cycle's length, its end's.
  /// Only while the chopper repeats a steady cycle: 0 unless the last cycle and the ongoing one
  /// have held one target throughout (a new target's slew, or a target that moves with each
  /// cycle at speed, is not a repeated ripple, and a wrong template held over a long step costs
  /// more than the fold: pull-out at 500 µs fell 20 % with one). Also 0 when the step resolves
  /// the cycle (its length >= 2·step: one sample per half cycle or more), and once the ongoing
  /// cycle has lasted kStaleCycles of the last (the bridge no longer chops: held at the bus).
  double Ripple(double t, double step) const;
};

/// How many of its last whole cycle's lengths an ongoing cycle may last and still be taken to
/// repeat it (PhaseSwitch::Ripple).
inline constexpr double kStaleCycles = 1.25;
static_assert(std::is_trivially_copyable_v<PhaseSwitch> &&
              sizeof(PhaseSwitch) % sizeof(double) == 0);

/// A bridge that stops driving (a zero target): the current decays to 0 through the reversed
/// bridge (fast decay, v = −sgn(i)·Vbus, until the comparator sees i = 0), then the winding is
/// shorted; `mode` is the unit's own idle mode. Without it, the least on-time of a chopper would
/// pump the current up to Vbus·t_blank/(R·t_off) against a target of 0.
void IdleBridge(double mode, double t, double current, double vbus, PhaseSwitch* sw);

/// The next event of a phase over [t, t_end] (s): the earlier of `until` and the first crossing of
/// the comparator level after `armed_from`, or +infinity if neither falls in [t, t_end].
/// The phase's current over that interval is the exact solution of S-3 (winding.h) from current0 at
/// t with the voltage held, the rotor at electrical phasor `phasor0` at t and turning at the
/// speed kernel's ω: component `phase` (0: ia, 1: ib). A comparator already past its level when
/// it is armed switches at that instant.
double NextSwitchTime(const PhaseSwitch& sw, int phase, const MotorParams& p,
                      const SpeedKernel& speed, PhaseVector current0, PhaseVector voltage,
                      PhaseVector phasor0, double t, double t_end);

/// The most pieces FirstCrossing searches an interval in.
inline constexpr int kMaxCrossingPieces = 64;

/// The first τ in [from, to] (s from the interval's start) at which component `phase` of the exact
/// winding current i(τ) = v/R + P·z0·e^{jΩτ} + (i0 − v/R − P·z0)·e^{−aτ} (winding.h) reaches the
/// level ℓ(τ) = level0 + slope·clamp(τ − from, 0, ramp) going in `direction` (+1 up, −1 down),
/// i.e. the first root of direction·(i(τ) − ℓ(τ)) = 0 from below; `from` itself when the current is
/// already past the level there; +infinity if there is none in [from, to].
/// The interval is searched in pieces of at most 0.5 rad of electrical rotation (over which the
/// back-EMF term is nearly monotone), each root refined by a safeguarded Newton iteration to
/// 1e-12 s: a crossing and a re-crossing within one such piece (a current grazing its level) can be
/// missed, which the tests bound. At most kMaxCrossingPieces pieces: beyond 32 rad of electrical
/// rotation in one interval (a held bridge over a long step at a speed far past any stepper's
/// pull-out), the pieces lengthen and the search coarsens, so that its work is bounded.
double FirstCrossing(const MotorParams& p, const SpeedKernel& speed, PhaseVector current0,
                     PhaseVector voltage, PhaseVector phasor0, int phase, int direction,
                     double level0, double slope, double ramp, double from, double to);

/// A controller unit whose bridges switch (kSwitching): its State holds `PhaseSwitch phase[2]`; its
/// tick's current_ref is the phases' new targets, which reach them at t_k + D through SetTarget
/// and Switch(kTarget); Start begins the chopper cycle of a drive at rest; Switch decides a phase
/// again at each of its events. The drive owns the event loop (drive.cc).
template <class C>
concept SwitchingUnit = requires {
  C::kSwitching;
}
&&requires(const C c, typename C::State* s, const PowerStage& stage) {
  { s->phase[0] } -> std::same_as<PhaseSwitch&>;
  c.Start(stage, 0.0, s);
  c.Switch(stage, SwitchReason::kTime, 0, 0.0, 0.0, s);
  C::SetTarget(0, 0.0, s);
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_SWITCHING_H_
