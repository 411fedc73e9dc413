// The multi-rate stepper drive: interrupt clock, sample → compute → apply after the computation
// delay → zero-order hold (S-15), the bridges (S-13), and the windings integrated exactly in
// between.
//
// Time line of interrupt k (t_k = k·T, T = isr_period, absolute, independent of any simulation
// step; D = compute_delay, 0 <= D < T):
//   t_k       sample i_ab(t_k), θ(t_k), θcmd(t_k); the controller computes v[k]
//   t_k + D   v[k] reaches the phases and is held until t_{k+1} + D               S-15
// With Tsui's timing (T = 50 µs, D = 25 µs) this is the paper's 37.5-82.5 µs delay window.
//
// A caller moves the drive from t0 to t1 (one simulation step, any length: several ticks per step
// or several steps per tick) with the rotor angle moving linearly from its value at t0 to θ1 and
// the command held. Between events the windings follow the exact solution of S-3 (winding.h), so
// the only approximation is the linear rotor path within one step.
#ifndef MJSTEPPER_CORE_DRIVE_H_
#define MJSTEPPER_CORE_DRIVE_H_

#include <cstddef>
#include <type_traits>

#include "core/controllers/current_microstep.h"
#include "core/controllers/servo.h"
#include "core/controllers/voltage_microstep.h"
#include "core/motor_params.h"
#include "core/power_stage.h"
#include "core/sensors/velocity_estimator.h"

namespace mjstepper {

enum class DriveKind {
  kVoltageMicrostep,  ///< open-loop voltage microstepping, K(5)
  kCurrentMicrostep,  ///< PI current loop at the commanded angle, T(9)-(12)
  kIdealCurrent,      ///< currents equal the T(12)-(13) setpoint at every instant (ideal source)
  kServo,             ///< servo with harmonic damping, T(18)-(19): encoder feedback, 4 kHz + 20 kHz
  kIdentification,    ///< T(7)-(8): servo with the position loop off, compensation only
};

/// The MJCF name of a drive kind: voltage_microstep, current_microstep, ideal_current, servo,
/// identification.
const char* DriveKindName(DriveKind kind);

enum class InputMode {
  kPosition,  ///< the command is the rotor angle θcmd, rad (held over a step)
  kVelocity,  ///< the command is dθcmd/dt, rad/s; the drive integrates θcmd
};

enum class WindingSolver { kExact, kRk4 };  ///< kRk4 only for reference runs in tests

struct DriveConfig {
  MotorParams motor;
  DriveKind kind = DriveKind::kCurrentMicrostep;
  InputMode input = InputMode::kPosition;
  double bus_voltage = 48.0;        ///< Vbus, V (S-13)
  double voltage_amplitude = 24.0;  ///< Vmax of voltage microstepping, V (K(5))
  double hold_current = 1.9;        ///< I_hold, A (T(12))
  double kp = 7.5;                  ///< PI proportional gain, V/A (T(9))
  double ki_per_tick = 0.01;        ///< PI integral gain, V/A per tick (T(10))
  double isr_period = 50e-6;        ///< T, s: interrupt period (S-15)
  double compute_delay = 25e-6;     ///< D, s: from sample to new voltage, 0 <= D < T (S-15)
  PowerStageKind power_stage = PowerStageKind::kTwoHBridges;  ///< S-13 or S-14
  /// The drive's harmonic compensation (T(13), T(19), T(8)): the enabled harmonics with the
  /// drive's own estimates of Kdh, φh (may differ from motor.detent). Empty: no damping.
  std::vector<DetentHarmonic> damping;
  int encoder_counts = 4000;        ///< counts/rev of the servo's encoder (S-16); 0: ideal
  double velocity_cutoff = 32.0;    ///< Hz, corner of the velocity estimate's low-pass (S-17)
  double position_period = 250e-6;  ///< s, servo position loop period: a multiple of isr_period
  double servo_kp = 1.0;            ///< N·m/rad, T(19)
  double servo_ki = 10.0;           ///< N·m/(rad·s), T(19)
  double servo_kv = 0.01;           ///< N·m·s/rad, T(19)
  double friction_compensation = 0.029;  ///< Fs the servo and identification modes add, N·m
  WindingSolver solver = WindingSolver::kExact;
  double rk4_step = 1e-6;  ///< s, step of the kRk4 reference
};

/// Throws std::invalid_argument naming the field, value and rule.
void Validate(const DriveConfig& c);

/// Everything that changes as the drive runs, as plain doubles so that a simulator can store it
/// (MuJoCo: plugin_state) and copy, reset and snapshot it. All zero = "not started": the drive then
/// starts at rest on the rotor (Drive::Rest), SPEC §6.
struct DriveState {
  double started = 0;            ///< 0 until the drive has been anchored to a rotor angle
  double theta = 0;              ///< rad, rotor angle at the state's time
  double theta_cmd = 0;          ///< rad, commanded angle at the state's time
  double omega_cmd = 0;          ///< rad/s, commanded speed over the last step
  double current_a = 0;          ///< A
  double current_b = 0;          ///< A
  double voltage_a = 0;          ///< V, applied now (held)
  double voltage_b = 0;          ///< V
  double pending_a = 0;          ///< V, computed at the last tick, applied at that tick + D
  double pending_b = 0;          ///< V
  double pending = 0;            ///< 1 while pending_a/b wait for their apply time
  double next_tick = 0;          ///< k of the next interrupt, at k·T
  double integral_d = 0;         ///< V, PI integrator s, d axis
  double integral_q = 0;         ///< V, q axis
  double theta_meas = 0;         ///< rad, encoder angle at the last tick (S-16)
  double omega_est = 0;          ///< rad/s, velocity estimate at the last tick (S-17)
  double position_integral = 0;  ///< rad·s, servo ∫θerr
  double iq_cmd = 0;             ///< A, servo q-current command held between position updates
  double energy_input = 0;       ///< J, ∫(va·ia + vb·ib) dt since the start
  double energy_copper = 0;      ///< J, ∫R·(ia² + ib²) dt
  double energy_mechanical = 0;  ///< J, ∫τm·ω dt

  PhaseVector current() const { return {current_a, current_b}; }
  PhaseVector voltage() const { return {voltage_a, voltage_b}; }
};
static_assert(std::is_trivially_copyable_v<DriveState> && sizeof(DriveState) % sizeof(double) == 0);
inline constexpr int kDriveStateSize = sizeof(DriveState) / sizeof(double);

/// The state from / to kDriveStateSize doubles (a simulator's state array).
DriveState LoadState(const double* values);
void StoreState(const DriveState& state, double* values);

/// What a user reads of one drive at one instant (SPEC §1, DESIGN §5).
struct DriveSignals {
  double current_a = 0, current_b = 0;  ///< A
  double voltage_a = 0, voltage_b = 0;  ///< V, held phase voltages
  double current_d = 0, current_q = 0;  ///< A, Park frame at ψ = Nr·θcmd (S-9, S-12)
  double theta_cmd = 0;                 ///< rad
  double omega_cmd = 0;                 ///< rad/s
  double torque_em = 0;                 ///< τm, N·m (S-4)
  double torque_detent = 0;             ///< τdet, N·m (S-5)
  double torque_total = 0;              ///< τm + τdet, N·m: what the drive applies to the rotor
  double load_angle = 0;                ///< δ = Nr·(θcmd − θ), electrical rad (S-12)
  double lost_steps = 0;                ///< full steps slipped: 4·round(δ/2π), signed
  double theta_meas = 0;                ///< rad, encoder angle at the last tick
  double omega_est = 0;                 ///< rad/s, velocity estimate at the last tick
};

class Drive {
 public:
  explicit Drive(DriveConfig config);  ///< validates; throws std::invalid_argument

  const DriveConfig& config() const { return config_; }

  /// The state of a drive that has rested for ever at time t with the rotor at θ and the command
  /// `command` (SPEC §6): currents aligned with the commanded angle (θcmd = command in position
  /// mode, θcmd = θ in velocity mode), voltages and PI integrator holding them. No transient.
  DriveState Rest(double time, double theta, double command) const;

  /// Moves `state` from t0 to t1 >= t0. The rotor moves linearly from state->theta to theta1; the
  /// command (rad or rad/s, by input mode) is held over the interval.
  void Advance(DriveState* state, double t0, double t1, double theta1, double command) const;

  /// τm + τdet at rotor angle θ with the state's currents (N·m).
  double Torque(const DriveState& state, double theta) const;

  DriveSignals Signals(const DriveState& state, double theta) const;

  /// Magnitude of the current vector the drive holds at rest, A: I_hold, or Vmax/R in voltage mode.
  double RestCurrentMagnitude() const;

  /// Holding stiffness at rest, N·m/rad: T' = Nr·Km·I (SPEC §1, T(1)); the servo's Kp in servo
  /// mode; 0 in identification mode.
  double HoldingStiffness() const;

 private:
  bool IsServo() const {
    return config_.kind == DriveKind::kServo || config_.kind == DriveKind::kIdentification;
  }
  // Interrupt k at time t: sample the sensors, run the controller, schedule the new voltage.
  void Tick(DriveState* s, long k, double theta, double theta_cmd, double omega_cmd,
            PhaseVector current) const;

  DriveConfig config_;
  PowerStage stage_;
  VoltageMicrostepController voltage_controller_;
  CurrentMicrostepController current_controller_;
  ServoController servo_controller_;
  VelocityEstimator velocity_estimator_;
  long ticks_per_position_update_ = 5;
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_DRIVE_H_
