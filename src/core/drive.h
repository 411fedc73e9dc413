// The multi-rate stepper drive: interrupt clock, sample → compute → apply after the computation
// delay → zero-order hold (S-15), the bridges (S-13/S-14), the sensors (S-16, S-17), the motion
// profile, and the windings integrated exactly in between. It holds one controller unit from the
// registry (controllers/registry.h) and hands it, at each tick, the input that controller reads.
//
// Time line of interrupt k (T = isr_period, D = compute_delay, 0 <= D < T; the clock is its own,
// independent of any simulation step):
//   t_k       sample i_ab(t_k), θ(t_k), θcmd(t_k); the controller computes v[k]
//   t_k + D   v[k] reaches the phases and is held until t_{k+1} + D               S-15
// With Tsui's timing (T = 50 µs, D = 25 µs) this is the paper's 37.5-82.5 µs delay window.
// The clock starts on the grid k·T and is re-anchored to a step's start time t0 whenever its next
// tick falls on t0 up to round-off: t_k = t_{k_a} + n·T, n = k − k_a ticks after the last anchor
// k_a. So when the step is a multiple or a fraction of T, ticks stay on step boundaries bit for
// bit however long the run (MuJoCo's accumulated time drifts from n·h by 5 µs over an hour at
// 20 kHz), and the clock never accumulates round-off of its own.
//
// Bounded by construction (issue 16): the clock counts n, a small integer (the clock re-anchors
// before it passes kMaxTicksFromAnchor), never the absolute k, which stops growing under `+= 1`
// past 2^53; one Advance runs at most kMaxEventsPerAdvance events whatever its input; and a time
// whose round-off is not small against T (see AdvanceStatus::kCoarseTime) is worked in the step's
// own frame, t − t0, where T still resolves. What was wrong with an input is returned as an
// AdvanceStatus, and the state is finite after every Advance.
//
// A caller moves the drive from t0 to t1 (one simulation step, any length: several ticks per step
// or several steps per tick) with the rotor angle moving linearly from its value at t0 to θ1 and
// the command held. Between events the windings follow the exact solution of S-3 (winding.h), so
// the only approximation is the linear rotor path within one step.
#ifndef MJSTEPPER_CORE_DRIVE_H_
#define MJSTEPPER_CORE_DRIVE_H_

#include <algorithm>
#include <array>
#include <cstddef>
#include <memory>
#include <optional>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "core/averaged_bridge.h"
#include "core/averaged_current_loop.h"
#include "core/controllers/registry.h"
#include "core/motion_profile.h"
#include "core/motor_params.h"
#include "core/power_stage.h"
#include "core/sensors/velocity_estimator.h"
#include "core/step_times.h"
#include "core/thermal.h"
#include "core/transmission.h"
#include "core/winding.h"

namespace mjstepper {

enum class InputMode {
  kPosition,  ///< the command is the rotor angle θcmd, rad (held over a step), or a profile target
  kVelocity,  ///< the command is dθcmd/dt, rad/s; the drive integrates θcmd
  kSteps,     ///< STEP/DIR (SPEC §8): the command is the motion controller's microstep count n
              ///< at the drive's `microsteps` M, θcmd = n·2π/(4·Nr·M); the pulses between two
              ///< counts are spread evenly over the step, θcmd moving linearly between them; a
              ///< unit with an Edge (the chip drives) moves its table at each pulse, an event of
              ///< its own; the others read the count at their interrupts (the DSP's timing)
};

enum class WindingSolver { kExact, kRk4 };  ///< kRk4 only for reference runs in tests

/// How a drive's current regulation is simulated (SPEC §11): kSwitching, every interrupt and every
/// bridge event (the reference); kAveraged, a chopper's cycle average (averaged_bridge.h), whose
/// cost does not grow with the clock or the chopper frequency; STEP/DIR edges and the bus limit
/// are kept in both.
enum class Fidelity { kSwitching, kAveraged };

struct DriveConfig {
  MotorParams motor;
  Controller controller;  ///< default: CurrentMicrostep with Tsui's loop
  InputMode input = InputMode::kPosition;
  double bus_voltage = 48.0;     ///< Vbus, V (S-13)
  double isr_period = 50e-6;     ///< T, s: interrupt period (S-15)
  double compute_delay = 25e-6;  ///< D, s: from sample to new voltage, 0 <= D < T (S-15)
  PowerStageKind power_stage = PowerStageKind::kTwoHBridges;  ///< S-13 or S-14
  int encoder_counts = 4000;      ///< counts/rev of the encoder (S-16); 0: ideal
  double velocity_cutoff = 32.0;  ///< Hz, corner of the velocity estimate's low-pass (S-17)
  /// What the controller receives as ωfb; unset: the controller's own default.
  std::optional<SpeedFeedback> speed_feedback;
  MotionProfile profile;  ///< kNone: ctrl is the command itself
  /// input = steps only: the STEP/DIR pulses at their own times (the list's count from the count
  /// the drive rests at), each an edge of its own whatever the step; ctrl is then unused.
  /// Unset: ctrl is the count at each step's end, its pulses spread evenly over the step.
  std::shared_ptr<const StepTimes> step_times;
  WindingSolver solver = WindingSolver::kExact;
  Fidelity fidelity = Fidelity::kSwitching;  ///< kAveraged: only on a switching (chopper) drive
  double rk4_step = 1e-6;                    ///< s, step of the kRk4 reference
  /// Heat (SPEC §8, thermal.h): unset, R and Km are the motor's own (its R20, Km20) for ever; set,
  /// the winding's temperature sets R(T) and Km(T) over each step, and the copper loss warms it.
  /// Needs windings (not `ideal_current`) and the exact solver (the kRk4 reference has no
  /// energies).
  std::optional<HeatParams> heat;
  /// The gear train's efficiency (transmission.h), applied by a simulator to the torque it hands
  /// the load; the drive's own torques and energies are the motor's.
  Transmission transmission;
};

/// Throws std::invalid_argument naming the field, value and rule.
void Validate(const DriveConfig& c);

/// The rotor angle of one microstep of STEP/DIR input (input = steps), rad: 2π/(4·Nr·M) with M
/// the controller's microsteps (S-1); 0 when the controller has no microstep table.
double StepAngle(const DriveConfig& c);

/// The largest ωn·h a simulation step may have with the default (consistent) coupling: the velocity
/// ripple of the Tsui sweep stays within 1 % of a fine reference up to it (0.7 %;
/// docs/coupling.md). core/coupling.h's MaxOmegaTimesStep gives each coupling's measured limit.
inline constexpr double kMaxOmegaTimesStep = 0.2;

/// The largest timestep, s, that resolves a rotor of inertia J (kg·m²) held by stiffness T'
/// (N·m/rad): kMaxOmegaTimesStep/ωn, ωn = √(T'/J); infinite when T' = 0.
double LargestTimestep(double stiffness, double inertia);

/// A step runs every interrupt in it (and MuJoCo's compiler steps once while loading): at most
/// this many per timestep, so that no config makes a load or a step take unbounded time. 10 000 is
/// 1 MHz control on a 10 ms step, far beyond any model here (at most 50).
inline constexpr int kMaxInterruptsPerStep = 10000;

/// Whether a timestep (s) holds at most kMaxInterruptsPerStep interrupts of isr_period (s), less a
/// relative 1e-9 for the decimal round trip (5e-9 s × 10 000 is a hair under 5e-5 s).
bool InterruptsFit(double timestep, double isr_period);

/// The least isr_period (s) that fits the timestep (s), rounded up to 3 significant digits: the
/// value messages print, accepted when a user copies it back.
double LeastIsrPeriod(double timestep);

/// One Advance runs at most this many interrupts: a timestep raised after loading (which refuses
/// more than kMaxInterruptsPerStep) still runs all of its interrupts up to ten times the load's
/// bound; a longer step (an absurd timestep, a jump in time) is not run (AdvanceStatus).
inline constexpr double kMaxTicksPerAdvance = 10.0 * kMaxInterruptsPerStep;

/// The hard stop of one Advance's event loop: each interrupt is two events (its tick, then its
/// voltage's apply at t_k + D), plus one pending apply and round-off at the step's two ends.
inline constexpr long kMaxEventsPerAdvance = 2 * static_cast<long>(kMaxTicksPerAdvance) + 8;

/// STEP/DIR edges (input = steps on a chip drive) are events of their own, one per microstep the
/// count moves within a step; a step that moves it more than this many (a jump, not a pulse
/// train) is read at the ticks instead, so that one Advance stays bounded.
inline constexpr double kMaxEdgesPerAdvance = 100000;

/// The clock re-anchors at its next tick once that many ticks passed since its anchor (2^32: at
/// 20 kHz, 2.5 days of steps that never start on a tick), so that n·T is exact arithmetic on a
/// small integer however long the run.
inline constexpr double kMaxTicksFromAnchor = 4294967296.0;

/// A time t is too coarse for the clock when its round-off, 8·ε·|t| (a few ulp: MuJoCo's
/// accumulated time and the tick times built on it), passes this fraction of isr_period: the ticks
/// could then not be told from step boundaries 1 % of a period away. At 20 kHz that is |t| beyond
/// 2.8e8 s (9 years); at 10 MHz beyond 5.6e5 s (6.5 days); a Unix time (1.7e9 s) for any T below
/// 0.3 ms.
inline constexpr double kCoarseTimeFraction = 0.01;

/// What Advance found wrong with its input, if anything; a simulator reports it (the plugin
/// through mju_warning). Whatever the input, Advance returns after a bounded amount of work and
/// leaves the state finite.
enum class AdvanceStatus {
  kOk,
  kBadTime,     ///< t0 or t1 not finite, or t1 < t0: the state is left unchanged
  kBadInput,    ///< θ1 or the command not finite, or beyond kMaxCommand: state left unchanged
  kBadState,    ///< a stored double was not finite: the drive restarted at rest at t1
  kEventBound,  ///< the step needs more than kMaxTicksPerAdvance interrupts: the drive restarted
                ///< at rest at t1 (energies kept); or the loop hit its hard stop,
                ///< kMaxEventsPerAdvance, and held the voltage to t1
  kCoarseTime,  ///< 8·ε·|t| > kCoarseTimeFraction·T: the step was run in its own frame t − t0,
                ///< every tick placed, but on step times that are themselves this coarse
};

/// A sentence on the status, for messages: "" for kOk.
const char* Describe(AdvanceStatus status);

/// The largest |ctrl| that is a command (MuJoCo's mjMAXVAL, mju_isBad's bound; the plugin checks
/// they agree): beyond it, or not finite, a ctrl is no command.
inline constexpr double kMaxCommand = 1e10;

/// The electrical cycle k (δ ≈ 2π·k) a rotor at load angle δ sits in, given the cycle it was in:
/// it moves on only when δ is more than 5π/4 from 2π·k, past the unstable equilibrium at ±π with
/// a margin, so that a rotor hovering near ±π (at its pull-out torque) does not count slips back
/// and forth. Any number of cycles may pass in one call; a non-finite δ keeps the cell.
double SlipCell(double load_angle, double cell);

/// The drive's own state, the same for every controller, as plain doubles. All zero = "not
/// started": the drive then starts at rest on the rotor (Drive::Rest), SPEC §6.
struct DriveCoreState {
  double started = 0;            ///< 0 until the drive has been anchored to a rotor angle
  double theta = 0;              ///< rad, rotor angle at the state's time
  double theta_cmd = 0;          ///< rad, commanded angle at the state's time
  double omega_cmd = 0;          ///< rad/s, commanded speed at the state's time
  double current_a = 0;          ///< A
  double current_b = 0;          ///< A
  double voltage_a = 0;          ///< V, applied now (held)
  double voltage_b = 0;          ///< V
  double pending_a = 0;          ///< V, computed at the last tick, applied at that tick + D
  double pending_b = 0;          ///< V
  double pending = 0;            ///< 1 while pending_a/b wait for their apply time
  double apply_time = 0;         ///< s, when pending_a/b reach the phases: t_k + D (S-15)
  double next_tick = 0;          ///< n of the next interrupt, counted from the anchor (k − k_a)
  double anchor_tick = 0;        ///< an interrupt k_a whose time is known exactly (k_a labels
                                 ///< the ticks for the controllers, Sample::tick):
  double anchor_time = 0;        ///< t_{k_a}, s; t_k = t_{k_a} + n·T
  double theta_meas = 0;         ///< rad, encoder angle at the last tick (S-16)
  double omega_est = 0;          ///< rad/s, velocity estimate at the last tick (S-17)
  double current_ref_a = 0;      ///< A, the controller's current reference at the last tick
  double current_ref_b = 0;      ///< A
  double energy_input = 0;       ///< J, ∫(va·ia + vb·ib) dt since the start
  double energy_copper = 0;      ///< J, ∫R·(ia² + ib²) dt
  double energy_mechanical = 0;  ///< J, ∫τm·ω dt
  double rotor_cos = 0;        ///< cos(Nr·θ): e^{jx} at `theta`, kept with it so that a step and
  double rotor_sin = 0;        ///< sin(Nr·θ)  the torque after it share one sincos (S-1)
  double slip_cell = 0;        ///< k of the cycle δ ≈ 2π·k the rotor sits in (SlipCell)
  double slip_origin = 0;      ///< slip_cell at the start: slips = slip_cell − slip_origin
  double last_slip_time = -1;  ///< s, end of the step of the last slip; −1: none yet
  // StallGuard and CoolStep (sensors/stallguard.h), for drives that have them:
  double stallguard = 0;           ///< SG_RESULT at the last full step (full scale at rest)
  double stall = 0;                ///< 1 while SG_RESULT flags a stall
  double first_stall_time = -1;    ///< s, the tick of the first stall flag; −1: none yet
  double full_step = 0;            ///< the full step (floor of 4·Nr·θcmd/2π) last measured at
  double full_step_time = -1;      ///< s, the tick it began at; −1: not yet (from rest)
  double full_step_theta = 0;      ///< rad, the rotor angle then
  double current_scale = 1;        ///< CoolStep's scale of the run current
  double coolstep_count = 0;       ///< readings above the upper band since the last fall
  double winding_temperature = 0;  ///< T_w, °C (thermal.h); kReferenceTemperature without heat
  double housing_temperature = 0;  ///< T_h, °C
  // A switching chopper's (fidelity = switching) phase currents less their ripple, the last whole
  // cycle's at the same time into the cycle (PhaseSwitch::Ripple), less the currents now, A; 0
  // for every other drive. The torque handed to the simulator is the currents' without their
  // ripple (handed_current): one sample per step of the 20-40 kHz ripple would fold it down into
  // the rotor (SPEC §11).
  double mean_offset_a = 0;
  double mean_offset_b = 0;
  // The largest |va|, |vb| the bridges held over any part of the last step (of its MuJoCo step
  // under the substepped coupling): a one-interrupt spike between two samples shows in it.
  double voltage_peak = 0;  ///< V

  PhaseVector current() const { return {current_a, current_b}; }
  /// The currents whose torque the simulator is handed (S-4), A.
  PhaseVector handed_current() const {
    return {current_a + mean_offset_a, current_b + mean_offset_b};
  }
  PhaseVector rotor_phasor() const { return {rotor_cos, rotor_sin}; }
  void set_rotor_phasor(PhaseVector z) {
    rotor_cos = z.real();
    rotor_sin = z.imag();
  }
  PhaseVector voltage() const { return {voltage_a, voltage_b}; }
};
static_assert(std::is_trivially_copyable_v<DriveCoreState> &&
              std::is_standard_layout_v<DriveCoreState> &&
              sizeof(DriveCoreState) % sizeof(double) == 0);

namespace internal {
template <class V>
struct LargestState;
template <class... C>
struct LargestState<std::variant<C...>> {
  static constexpr std::size_t value = std::max({sizeof(typename C::State)...});
};
}  // namespace internal

/// Room for the largest controller state plus the profile's plan, in doubles: computed from the
/// registered controllers' own State types, so no combination of drive, chip and profile can
/// exceed it (issue 29: a fixed 40 was exceeded by every chopper drive with a profile).
inline constexpr int kMaxUnitState = static_cast<int>(
    (internal::LargestState<Controller>::value + sizeof(MotionProfile::State)) / sizeof(double));

/// The whole state of one drive: the core, then the controller's own state, then the profile's.
/// Only StateLayout::total doubles of it are stored by a simulator (MuJoCo: plugin_state).
struct DriveState : DriveCoreState {
  std::array<double, kMaxUnitState> unit;  // only StateLayout's part is ever read
};

/// Where each part lives in a simulator's state array, decided once from the config.
struct StateLayout {
  int core = 0;        ///< doubles of DriveCoreState
  int controller = 0;  ///< doubles of the controller's State
  int profile = 0;     ///< doubles of the motion profile's plan (0 without a profile)
  int total() const { return core + controller + profile; }
};
StateLayout MakeStateLayout(const DriveConfig& c);

/// What a user reads of one drive at one instant (SPEC §1, DESIGN §5); the signal table
/// (signals.h) names, orders and documents these fields.
struct DriveSignals {
  double current_a = 0, current_b = 0;          ///< A
  double voltage_a = 0, voltage_b = 0;          ///< V, held phase voltages
  double voltage_peak = 0;                      ///< V, max |va|, |vb| over the last step
  double current_d = 0, current_q = 0;          ///< A, Park frame at ψ = Nr·θcmd (S-9, S-12)
  double current_ref_a = 0, current_ref_b = 0;  ///< A, the controller's current reference
  double theta_cmd = 0;                         ///< rad
  double omega_cmd = 0;                         ///< rad/s
  double torque_em = 0;                         ///< τm, N·m (S-4)
  double torque_detent = 0;                     ///< τdet, N·m (S-5)
  double torque_total = 0;                      ///< τm + τdet, N·m: the rotor's drive torque
  double load_angle = 0;                        ///< δ = Nr·(θcmd − θ), electrical rad (S-12)
  double position_error = 0;                    ///< θ − θcmd, rad (rotor side): e1 of K(20)
  double lost_steps = 0;                        ///< full steps slipped (4 per cycle), signed
  double last_slip_time = -1;                   ///< s; −1 before the first slip
  double stallguard = 0;                        ///< SG_RESULT (counts)
  double stall = 0;                             ///< 1 while flagged
  double first_stall_time = -1;                 ///< s; −1 before the first stall flag
  double current_scale = 1;                     ///< CoolStep's scale
  double energy_input = 0, energy_copper = 0, energy_mechanical = 0;  ///< J
  double theta_meas = 0;           ///< rad, encoder angle at the last tick
  double omega_est = 0;            ///< rad/s, velocity estimate at the last tick
  double winding_temperature = 0;  ///< °C (20 without heat)
  double housing_temperature = 0;  ///< °C (20 without heat)
  double resistance = 0;           ///< Ω, R(T_w) per phase (R20 without heat)
  double omega = 0;  ///< rad/s, rotor speed: not the drive's (0 here); the plugin fills it in
};

class Drive {
 public:
  explicit Drive(DriveConfig config);  ///< validates; throws std::invalid_argument

  const DriveConfig& config() const { return config_; }
  const StateLayout& layout() const { return layout_; }
  const DriveConstants& constants() const { return constants_; }

  /// The state of a drive that has rested for ever at time t with the rotor at θ and the command
  /// `command` (SPEC §6): currents aligned with the commanded angle (θcmd = command in position
  /// mode without a profile, θcmd = θ otherwise), voltages and the controller holding them.
  DriveState Rest(double time, double theta, double command) const;

  /// Moves `state` from t0 to t1 >= t0. The rotor moves linearly from state->theta to theta1; the
  /// command (rad or rad/s, by input mode; the target angle with a profile) is held over the step.
  /// Bounded for any input (at most kMaxEventsPerAdvance events); what was wrong is returned.
  AdvanceStatus Advance(DriveState* state, double t0, double t1, double theta1,
                        double command) const {
    return Advance(state, t0, t1, theta1, command, t1);
  }
  /// The same, the command known to hold (its ctrl unchanged) until `command_end` >= t1 (s): a
  /// sub-step of a longer MuJoCo step (core/substep.h) says so, and an averaged StealthChop at
  /// standstill then spans interrupts to there.
  AdvanceStatus Advance(DriveState* state, double t0, double t1, double theta1, double command,
                        double command_end) const;

  /// `ctrl` (rad or rad/s, by input mode) as the drive's command. A ctrl that is NaN, infinite or
  /// beyond kMaxCommand is no command: a started drive (`state`) keeps doing what it does, at its
  /// commanded speed in velocity mode, else going to the same angle (the profile's target, or
  /// θcmd); one not yet started rests where the rotor is (`theta`, rad).
  double CommandFrom(double ctrl, const DriveState* state, double theta) const;

  /// The rotor angle of one microstep of STEP/DIR input, rad: 2π/(4·Nr·M) (S-1); 0 when the
  /// controller has no microstep table.
  double StepAngle() const { return step_angle_; }

  /// τm + τdet at rotor angle θ with the state's currents (N·m), τm with Km at the state's
  /// winding temperature (with heat).
  double Torque(const DriveCoreState& state, double theta) const;
  /// The same from a started state's stored doubles (layout().total() of them), reading only
  /// what the torque needs: the actuator force of every simulation step.
  double StoredTorque(const double* values, double theta) const;
  /// k = −∂(τm + τdet)/∂θ at θ with the stored currents held (N·m/rad), S-4, S-5: the stiffness
  /// the rotor feels over one step (the consistent coupling, core/coupling.h).
  double StoredStiffness(const double* values, double theta) const;
  /// StoredTorque and StoredStiffness from one read of the stored state: {τ (N·m), k (N·m/rad)}.
  std::pair<double, double> StoredTorqueAndStiffness(const double* values, double theta) const;
  /// The same from a state: the torque τm + τdet (N·m) and −∂τ/∂θ (N·m/rad) at rotor angle θ.
  std::pair<double, double> TorqueAndStiffness(const DriveCoreState& s, double theta) const;
  /// Moves the state's rotor to θ (rad) at once, its phasor with it (no energy is counted): where
  /// the multibody step left the rotor elsewhere than the drive's own path (core/substep.h).
  void Relocate(DriveCoreState* s, double theta) const;

  DriveSignals Signals(const DriveState& state, double theta) const;

  /// Time of the next interrupt, s.
  double NextTickTime(const DriveCoreState& s) const {
    return s.anchor_time + s.next_tick * config_.isr_period;
  }
  /// Index k of the next interrupt (exact while k < 2^53).
  static double NextTickIndex(const DriveCoreState& s) { return s.anchor_tick + s.next_tick; }

  /// Whether time t is too coarse for this drive's clock (kCoarseTimeFraction).
  bool CoarseTime(double t) const;

  /// The state from / to layout().total() doubles (a simulator's state array).
  DriveState Load(const double* values) const;
  /// Whether stored doubles hold a started state (else the drive starts at rest, Rest()).
  static bool Started(const double* values) {
    return values[offsetof(DriveCoreState, started) / sizeof(double)] != 0;
  }
  void Store(const DriveState& state, double* values) const;
  /// Whether stored doubles could be a state this drive made (issue 33: ±1e300 written into a
  /// simulator's state applied its force for a step before the drive restarted): the rotor, its
  /// phasor and the currents finite and within bounds no step reaches (|i| within
  /// current_bound(), the phasor's parts within 1.5, the temperatures within [−273.15, 1e6] °C).
  /// A few comparisons: a simulator checks it before each step reads a force from the state.
  bool Plausible(const double* values) const;
  /// The largest |ia|, |ib| (A) a state may hold: 20·Vbus/R (a winding at a fifth of R, the least
  /// R(T) heat allows, with back-EMF beside the bus) plus 10 times the largest current the drive
  /// holds or is rated for.
  double current_bound() const { return current_bound_; }

  /// Magnitude of the current vector the drive holds at rest, A: I_hold, Vmax/R in voltage mode,
  /// τl/Km for Kim's controllers, 0 for the servo modes.
  double RestCurrentMagnitude() const;

  /// The winding's R (Ω) and Km (N·m/A) at winding temperature T (°C): R20·(1 + α·(T − 20)),
  /// Km20·(1 + β·(T − 20)) with heat (thermal.h), the motor's own without.
  double ResistanceAt(double winding_temperature) const;
  double TorqueConstantAt(double winding_temperature) const;

  /// The heat network (thermal.h), if the drive has heat.
  const std::optional<ThermalNetwork>& thermal() const { return thermal_; }

  /// Holding stiffness at rest, N·m/rad: T' = Nr·Km·I (SPEC §1, T(1)) for the open-loop drives;
  /// the position loop's for the closed-loop ones (servo Kp; J·(k1 + k1p·k2) for Kim's, K(26));
  /// 0 in identification mode.
  double HoldingStiffness() const;

  /// The detent's largest stiffness, N·m/rad: |dτdet/dθ| <= Σh h·Nr·Kdh (S-5), reached where the
  /// harmonics' slopes line up. It adds to T' where both peak together, so the timestep checks
  /// (LargestTimestep) take T' + this as the worst case; 0 without a detent.
  double DetentStiffness() const;

 private:
  // The winding's constants over one step: the motor's, or with heat the ones at the step's
  // starting temperature; and the decay kernels of the clock's interval lengths (T, D, T − D) for
  // them: the ones made at load, or with heat made on first use in the step (`made`, h < 0 until
  // then: a chopper's intervals rarely have the clock's lengths).
  struct StepWinding {
    const MotorParams* motor = nullptr;
    const DecayKernel* kernels = nullptr;  // made at load, for the motor's R: their lengths
    int kernel_count = 0;
    DecayKernel* made = nullptr;  // with heat: kernel_count slots for this step's R
    double loop_rate = 0;  // 1/s, an averaged PI loop's transient rate for this R (0: not made)
  };

  // The winding of a drive without heat: the motor and the kernels made at load.
  StepWinding ColdWinding() const {
    return {.motor = &config_.motor,
            .kernels = decay_kernels_.data(),
            .kernel_count = static_cast<int>(decay_kernels_.size()),
            .loop_rate = loop_transient_.rate};
  }

  // The step with heat: AdvanceWith on the winding at its starting temperature, then the thermal
  // network over the step with the step's copper loss. False if it hit kMaxEventsPerAdvance.
  bool AdvanceHot(DriveState* s, double t0, double t1, double theta1, double command,
                  double command_end, bool coarse) const;

  // The step itself, on checked input; false if it hit kMaxEventsPerAdvance. `coarse`: work in
  // the step's frame t − t0 (CoarseTime), else in absolute time. Sets *copper to the step's
  // copper loss, J.
  template <class C>
  bool AdvanceWith(const C& controller, const StepWinding& winding, DriveState* s, double t0,
                   double t1, double theta1, double command, double command_end, bool coarse,
                   double* copper) const;

  // Sets the clock's anchor at the first tick of the grid k·T at or after `time`, or at `time`
  // itself when the grid is not representable there (coarse); n = 0.
  void AnchorAt(DriveCoreState* s, double time, bool coarse) const;

  // Restarts the drive at rest at `time` on the rotor at θ (rad) holding `command`; the energy
  // integrals kept if asked. Off the normal path (a bad state, a step too long to run).
  void Restart(DriveState* s, double time, double theta, double command, bool keep_energies) const;

  // Whether every stored double of the state is finite.
  bool Finite(const DriveState& s) const;

  // e^{jNr·θ}: the stored one when θ is the state's, else by sincos.
  PhaseVector RotorPhasor(bool started, double stored_theta, PhaseVector stored_phasor,
                          double theta) const;
  // τm + τdet from the currents, z = e^{jx} and Km alone: τdet = −Im(Σh wh·z^h), wh = Kdh·e^{jφh},
  // by Horner's rule.
  // What the torque and its stiffness need of a started state's stored doubles, at θ.
  struct StoredMotor {
    PhaseVector rotor;       // e^{jNrθ}
    PhaseVector current;     // ia + j·ib, A
    double torque_constant;  // Km at the stored winding temperature, N·m/A
  };
  StoredMotor ReadStored(const double* values, double theta) const;
  // k = −∂(τm + τdet)/∂θ of a read state, S-4, S-5.
  double StiffnessOf(const StoredMotor& s) const;
  std::pair<double, double> Torques(PhaseVector current, PhaseVector z,
                                    double torque_constant) const;

  // The full step a commanded angle (rad) is in: floor(4·Nr·θcmd/2π), S-1.
  double FullStep(double theta_cmd) const;

  // The decay part of an interval's kernel (winding.h): the step's kernel for one of the clock's
  // own lengths, else computed.
  static DecayKernel DecayFor(const StepWinding& winding, double length);
  // With heat: slot i of the step's kernels, made on first use.
  static DecayKernel MadeKernel(const StepWinding& winding, int i);

  DriveConfig config_;
  std::vector<PhaseVector> detent_weights_;  // wh = Σ Kdh·e^{jφh} at index h − 1, N·m (S-5)
  DriveConstants constants_;
  StateLayout layout_;
  PowerStage stage_;
  SpeedFeedback speed_feedback_ = SpeedFeedback::kEstimate;
  VelocityEstimator velocity_estimator_;    // S-17
  double velocity_gain_ = 0;                // its a = 1 − exp(−2π·fc·T), computed once
  std::vector<DecayKernel> decay_kernels_;  // for T, D and T − D, computed once
  double step_angle_ = 0;                   // rad per microstep (StepAngle)
  double current_bound_ = 0;                // A (current_bound), at load
  RippleOffsets ripple_;                    // averaged chopper: its cycle's mean offset, at load
  LoopTransient loop_transient_;            // averaged PI loop: its transient's rate, cold
  std::optional<ThermalNetwork> thermal_;   // with heat: the network, decomposed once
  MotorParams winding_motor_;               // with heat: the motor without its detent list, which
                                            // the winding never reads (copied per step, no
                                            // allocation)
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_DRIVE_H_
