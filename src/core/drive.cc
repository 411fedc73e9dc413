#include "core/drive.h"

#include <fmt/format.h>

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <tuple>

#include "core/averaged_bridge.h"
#include "core/averaged_current_loop.h"
#include "core/averaged_feed_forward.h"
#include "core/motor.h"
#include "core/sensors/encoder.h"
#include "core/switching.h"
#include "core/units.h"
#include "core/winding.h"

namespace mjstepper {
namespace {

// The tick labels k (Sample::tick) stay below 2^53 in magnitude, where a double holds every
// integer exactly.
constexpr double kTickLabelRange = 9007199254740992.0;  // 2^53

void Require(bool ok, const char* name, double value, const char* rule) {
  if (!ok) throw std::invalid_argument(fmt::format("DriveConfig: {} = {}; {}", name, value, rule));
}

template <class T>
constexpr int Doubles() {
  return std::is_empty_v<T> ? 0 : static_cast<int>(sizeof(T) / sizeof(double));
}

template <class T>
T Unpack(const double* values) {
  T t{};
  if constexpr (!std::is_empty_v<T>) std::memcpy(static_cast<void*>(&t), values, sizeof(T));
  return t;
}

template <class T>
void Pack(const T& t, double* values) {
  if constexpr (!std::is_empty_v<T>) std::memcpy(values, static_cast<const void*>(&t), sizeof(T));
}

}  // namespace

void Validate(const DriveConfig& c) {
  Validate(c.motor);
  // Each check is written so that NaN fails it.
  Require(c.bus_voltage > 0 && std::isfinite(c.bus_voltage), "bus_voltage", c.bus_voltage,
          "must be finite and > 0 (V)");
  if (const auto* v = std::get_if<VoltageMicrostep>(&c.controller)) {
    Require(v->voltage_amplitude > 0 && v->voltage_amplitude <= c.bus_voltage, "voltage_amplitude",
            v->voltage_amplitude, "must be > 0 and <= bus_voltage (V)");
    // The averaged form's rotating phasor is never cut: on SVPWM (S-14) that needs Vmax·√2 <=
    // Vbus, the range max(va, vb, 0) − min(va, vb, 0) of a phasor at 135°.
    Require(c.fidelity != Fidelity::kAveraged || c.power_stage != PowerStageKind::kThreeLegSvpwm ||
                v->voltage_amplitude * std::numbers::sqrt2 <= c.bus_voltage,
            "voltage_amplitude", v->voltage_amplitude,
            "must be <= bus_voltage/√2 for fidelity = averaged on the svpwm stage (V), where the "
            "averaged voltage is never cut");
  }
  const int harmonics = static_cast<int>(LoopSetpointHarmonics(c.controller));
  Require(c.fidelity != Fidelity::kAveraged || harmonics <= kAveragedLoopHarmonics, "damping",
          harmonics,
          fmt::format("harmonics: fidelity = averaged carries at most {} damping harmonics",
                      kAveragedLoopHarmonics)
              .c_str());
  const bool switching = IsSwitching(c.controller);
  Require(!switching || c.power_stage == PowerStageKind::kTwoHBridges,
          "power_stage (0: h_bridge, 1: svpwm)", static_cast<int>(c.power_stage),
          "a chopper switches each phase's own full bridge: it needs h_bridge");
  Require(c.isr_period > 0 && std::isfinite(c.isr_period), "isr_period", c.isr_period,
          "must be finite and > 0 (s)");
  Require(c.compute_delay >= 0 && c.compute_delay < c.isr_period, "compute_delay", c.compute_delay,
          "must be >= 0 and < isr_period (s)");
  Require(c.rk4_step > 0, "rk4_step", c.rk4_step, "must be > 0 (s)");
  Require(c.fidelity == Fidelity::kSwitching || c.solver == WindingSolver::kExact,
          "fidelity (0: switching, 1: averaged)", static_cast<int>(c.fidelity),
          "averaged needs the exact winding solver");
  Require(c.transmission.efficiency > 0 && c.transmission.efficiency <= 1, "efficiency",
          c.transmission.efficiency, "must be in (0, 1]");
  Require(c.transmission.backdrive_efficiency > 0 && c.transmission.backdrive_efficiency <= 1,
          "backdrive_efficiency", c.transmission.backdrive_efficiency, "must be in (0, 1]");
  Require(c.encoder_counts >= 0, "encoder_counts", c.encoder_counts, "must be >= 0 (0: ideal)");
  // Kim's laws averaged (averaged_feed_forward.h) read the rotor's own angle and speed, and the
  // FOC's derivative must be its continuous one.
  const bool kim_law = std::visit(
      [](const auto& unit) {
        using U = std::decay_t<decltype(unit)>;
        return FeedForwardUnit<U> || HighGainFocUnit<U>;
      },
      c.controller);
  const bool kim_averaged = c.fidelity == Fidelity::kAveraged && kim_law;
  Require(!kim_averaged || c.encoder_counts == 0, "encoder_counts", c.encoder_counts,
          "must be 0 with fidelity = averaged: the averaged law reads the rotor's exact angle");
  Require(
      !kim_averaged || c.speed_feedback.value_or(SpeedFeedback::kExact) == SpeedFeedback::kExact,
      "speed_feedback (0: estimate, 1: exact)", 0,
      "must be exact with fidelity = averaged: the averaged law reads the rotor's exact speed");
  const auto* foc = std::get_if<HighGainFoc>(&c.controller);
  Require(c.fidelity != Fidelity::kAveraged || foc == nullptr ||
              foc->derivative == HighGainFoc::Derivative::kAnalytic,
          "foc_derivative (0: analytic, 1: numeric)", 1,
          "must be analytic with fidelity = averaged: a difference over one period is its clock");
  Require(c.velocity_cutoff > 0 && std::isfinite(c.velocity_cutoff), "velocity_cutoff",
          c.velocity_cutoff, "must be finite and > 0 (Hz)");
  Require(c.input != InputMode::kSteps || Microsteps(c.controller) > 0, "microsteps",
          Microsteps(c.controller),
          "input = steps counts microsteps: it needs a drive with a microstep table and "
          "microsteps >= 1");
  if (c.heat) {
    Validate(*c.heat);
    const bool ideal = std::visit(
        [](const auto& unit) {
          return requires { std::decay_t<decltype(unit)>::kIdealSource; };
        },
        c.controller);
    Require(!ideal, "heat (ThermalParams set)", 1,
            "ideal_current has no windings, so no copper loss: heat needs a drive with windings");
    Require(c.solver == WindingSolver::kExact, "heat (ThermalParams set)", 1,
            "heat needs the exact winding solver, whose energies give the copper loss");
  }
  if (c.profile.kind != ProfileKind::kNone) {
    Require(c.input == InputMode::kPosition, "input (0: position, 1: velocity, 2: steps)",
            static_cast<int>(c.input), "a motion profile needs input = position (ctrl = target)");
    for (double limit : {c.profile.max_speed, c.profile.max_accel, c.profile.max_jerk}) {
      Require(limit > 0 && std::isfinite(limit), "profile limit", limit, "must be finite and > 0");
    }
  }
}

double StepAngle(const DriveConfig& c) {
  const int microsteps = Microsteps(c.controller);
  return microsteps > 0 ? kTwoPi / (4.0 * c.motor.rotor_teeth * microsteps) : 0.0;  // S-1
}

double LargestTimestep(double stiffness, double inertia) {
  if (!(stiffness > 0)) return std::numeric_limits<double>::infinity();
  return kMaxOmegaTimesStep / std::sqrt(stiffness / inertia);
}

bool InterruptsFit(double timestep, double isr_period) {
  return timestep <= kMaxInterruptsPerStep * isr_period * (1 + 1e-9);
}

double LeastIsrPeriod(double timestep) {
  const double exact = timestep / kMaxInterruptsPerStep;                  // s
  const double unit = std::pow(10.0, std::floor(std::log10(exact)) - 2);  // of the 3rd digit
  return std::ceil(exact / unit * (1 - 1e-12)) * unit;
}

double SlipCell(double load_angle, double cell) {
  constexpr double kThreshold = 0.625;  // cycles: 5π/4 over 2π, π plus a margin of π/4
  // In closed form, not cycle by cycle: an absurd command (1e9 rad) must not loop 1e8 times, and
  // a non-finite one leaves the count where it was.
  const double x = load_angle / kTwoPi - cell;  // cycles from the current cell's centre
  if (!std::isfinite(x)) return cell;
  if (x > kThreshold) return cell + std::ceil(x - kThreshold);
  if (x < -kThreshold) return cell - std::ceil(-x - kThreshold);
  return cell;
}

StateLayout MakeStateLayout(const DriveConfig& c) {
  StateLayout layout{.core = Doubles<DriveCoreState>()};
  layout.controller = std::visit(
      [](const auto& unit) { return Doubles<typename std::decay_t<decltype(unit)>::State>(); },
      c.controller);
  layout.profile = c.profile.kind == ProfileKind::kNone ? 0 : Doubles<MotionProfile::State>();
  return layout;
}

Drive::Drive(DriveConfig config) : config_(std::move(config)) {
  Validate(config_);
  const MotorParams& motor = config_.motor;
  constants_ = {.rotor_teeth = motor.rotor_teeth,
                .resistance = motor.resistance,
                .inductance = motor.inductance,
                .torque_constant = motor.torque_constant,
                .isr_period = config_.isr_period,
                .bus_voltage = config_.bus_voltage};
  layout_ = MakeStateLayout(config_);
  step_angle_ = mjstepper::StepAngle(config_);
  stage_ = {.kind = config_.power_stage, .bus_voltage = config_.bus_voltage};
  for (const DetentHarmonic& h : motor.detent) {
    if (static_cast<int>(detent_weights_.size()) < h.order) detent_weights_.resize(h.order);
    detent_weights_[h.order - 1] += h.amplitude * UnitPhasor(h.phase);
  }
  speed_feedback_ = config_.speed_feedback.value_or(DefaultSpeedFeedback(config_.controller));
  velocity_estimator_ = {.period = config_.isr_period, .cutoff = config_.velocity_cutoff};
  velocity_gain_ = velocity_estimator_.Gain();  // S-17, once at load
  // The interval lengths the clock produces when steps are multiples of T: T, D and T − D.
  for (double length :
       {config_.isr_period, config_.compute_delay, config_.isr_period - config_.compute_delay}) {
    if (length > 0) decay_kernels_.push_back(DecayKernel(motor, length));
  }
  if (config_.fidelity == Fidelity::kAveraged) {
    std::visit(
        [&](const auto& unit) {
          if constexpr (SwitchingUnit<std::decay_t<decltype(unit)>>) {
            ripple_ =
                RippleOffsets(unit, config_.bus_voltage, motor.inductance, unit.table.peak_current);
          } else if constexpr (requires { unit.loop.kp; }) {  // averaged_current_loop.h
            loop_transient_ =
                TransientRate(motor.resistance, motor.inductance, unit.loop.kp, config_.isr_period,
                              config_.compute_delay + 0.5 * config_.isr_period);
          }
        },
        config_.controller);
  }
  if (config_.heat) {
    thermal_.emplace(config_.heat->network);
    winding_motor_ = motor;
    winding_motor_.detent.clear();
  }
  current_bound_ = 20 * config_.bus_voltage / motor.resistance +
                   10 * std::max(std::sqrt(2.0) * motor.rated_current, RestCurrentMagnitude());
}

DriveState Drive::Load(const double* values) const {
  DriveState s;
  std::memcpy(static_cast<void*>(static_cast<DriveCoreState*>(&s)), values, sizeof(DriveCoreState));
  std::copy_n(values + layout_.core, layout_.controller + layout_.profile, s.unit.begin());
  return s;
}

void Drive::Store(const DriveState& s, double* values) const {
  std::memcpy(values, static_cast<const void*>(static_cast<const DriveCoreState*>(&s)),
              sizeof(DriveCoreState));
  std::copy_n(s.unit.begin(), layout_.controller + layout_.profile, values + layout_.core);
}

DriveState Drive::Rest(double time, double theta, double command) const {
  DriveState s{};
  s.started = 1;
  s.theta = theta;
  s.set_rotor_phasor(UnitPhasor(constants_.rotor_teeth * theta));
  const bool holds_command =
      config_.input == InputMode::kPosition && config_.profile.kind == ProfileKind::kNone;
  // (A list of pulse times, not ctrl, moves a STEP/DIR count: it counts on from the rotor's own
  // microstep.)
  s.theta_cmd = config_.step_times                   ? std::round(theta / step_angle_) * step_angle_
                : config_.input == InputMode::kSteps ? command * step_angle_
                : holds_command                      ? command
                                                     : theta;
  const PhaseVector current = std::visit(
      [&](const auto& unit) {
        using C = std::decay_t<decltype(unit)>;
        typename C::State state{};
        const PhaseVector i =
            unit.Rest(constants_, {.theta = theta, .theta_cmd = s.theta_cmd}, &state);
        Pack(state, s.unit.data());
        return i;
      },
      config_.controller);
  if (layout_.profile > 0) {
    Pack(MotionProfile::Rest(time, s.theta_cmd), s.unit.data() + layout_.controller);
  }
  s.theta_meas = EncoderAngle(theta, config_.encoder_counts);
  // The rotor starts in the cycle nearest its command: that is where it is, not a slip.
  s.slip_cell = s.slip_origin = std::round(constants_.rotor_teeth * (s.theta_cmd - theta) / kTwoPi);
  s.last_slip_time = -1;
  s.stallguard = std::visit(
      [](const auto& unit) {
        if constexpr (requires { unit.stallguard; }) {
          return unit.stallguard.version != 0 ? unit.stallguard.FullScale() : 0.0;
        } else {
          return 0.0;
        }
      },
      config_.controller);
  s.first_stall_time = -1;
  s.full_step = FullStep(s.theta_cmd);
  s.full_step_time = -1;
  s.full_step_theta = theta;
  s.current_scale = 1;
  // Winding and housing at the initial temperature (heat), else at the one R20 stands for.
  s.winding_temperature = s.housing_temperature =
      config_.heat ? config_.heat->initial_temperature : kReferenceTemperature;
  // At rest v = R·i holds the current constant (S-3 with ω = 0); a switching bridge starts its
  // chopper cycle there instead (switching.h).
  PhaseVector voltage = ResistanceAt(s.winding_temperature) * current;
  std::visit(
      [&](const auto& unit) {
        using C = std::decay_t<decltype(unit)>;
        if constexpr (SwitchingUnit<C>) {
          auto state = Unpack<typename C::State>(s.unit.data());
          if (config_.fidelity == Fidelity::kAveraged) {  // regulating, or idle and shorted
            for (PhaseSwitch& sw : state.phase) {
              sw.mode = sw.target == 0 ? kAveragedShorted : kAveragedRegulating;
            }
          } else {
            unit.Start(stage_, time, &state);
            voltage = {state.phase[0].voltage, state.phase[1].voltage};
          }
          Pack(state, s.unit.data());
        }
      },
      config_.controller);
  s.current_a = s.current_ref_a = current.real();
  s.current_b = s.current_ref_b = current.imag();
  s.voltage_a = s.pending_a = voltage.real();
  s.voltage_b = s.pending_b = voltage.imag();
  s.voltage_peak = std::max(std::abs(voltage.real()), std::abs(voltage.imag()));
  AnchorAt(&s, time, CoarseTime(time));
  return s;
}

void Drive::AnchorAt(DriveCoreState* s, double time, bool coarse) const {
  const double period = config_.isr_period;  // T
  s->next_tick = 0;
  const double k = std::ceil(time / period);
  // k is kept below 2^53, where it is an exact integer; it only labels ticks (Sample::tick).
  s->anchor_tick = std::isfinite(k) ? std::fmod(k, kTickLabelRange) : 0.0;
  // On the grid k·T while that is representable to the clock's resolution; else the step's time.
  s->anchor_time = coarse ? time : k * period;
}

[[gnu::cold]] void Drive::Restart(DriveState* s, double time, double theta, double command,
                                  bool keep_energies) const {
  const double energies[3] = {s->energy_input, s->energy_copper, s->energy_mechanical};
  const double temperatures[2] = {s->winding_temperature, s->housing_temperature};
  *s = Rest(time, theta, command);
  // (Only finite ones: the state a restart leaves is finite, whatever the one it replaces.)
  if (keep_energies && std::isfinite(energies[0] + energies[1] + energies[2])) {
    s->energy_input = energies[0];
    s->energy_copper = energies[1];
    s->energy_mechanical = energies[2];
  }
  // The motor keeps its heat (the step not run adds none).
  if (keep_energies && std::isfinite(temperatures[0] + temperatures[1])) {
    s->winding_temperature = temperatures[0];
    s->housing_temperature = temperatures[1];
  }
}

bool Drive::CoarseTime(double t) const {
  return 8 * std::numeric_limits<double>::epsilon() * std::abs(t) >
         kCoarseTimeFraction * config_.isr_period;
}

bool Drive::Finite(const DriveState& s) const {
  // x·0 is 0 for a finite x and NaN otherwise: sums of them over the stored doubles, no branch
  // each, in four independent lanes (the order of the sums does not matter: any NaN stays).
  double lanes[4] = {0, 0, 0, 0};
  auto add = [&lanes](const double* x, int count) {
    int i = 0;
    for (; i + 4 <= count; i += 4) {
      for (int j = 0; j < 4; ++j) lanes[j] += x[i + j] * 0;
    }
    for (; i < count; ++i) lanes[0] += x[i] * 0;
  };
  constexpr int kCore = sizeof(DriveCoreState) / sizeof(double);
  double core[kCore];
  std::memcpy(core, static_cast<const void*>(static_cast<const DriveCoreState*>(&s)), sizeof(core));
  add(core, kCore);
  add(s.unit.data(), layout_.controller + layout_.profile);
  return lanes[0] + lanes[1] + lanes[2] + lanes[3] == 0;
}

const char* Describe(AdvanceStatus status) {
  switch (status) {
    case AdvanceStatus::kOk:
      return "";
    case AdvanceStatus::kBadTime:
      return "the step's time is not finite or runs backwards; the drive is held unchanged";
    case AdvanceStatus::kBadInput:
      return "the rotor angle or the command is not finite or beyond 1e10; the drive is held "
             "unchanged";
    case AdvanceStatus::kBadState:
      return "the drive's stored state held a value that is not finite or that no step makes (a "
             "current, angle or temperature beyond Drive::Plausible's bounds); the drive "
             "restarted at rest";
    case AdvanceStatus::kEventBound:
      return "the step holds more interrupts than one step may run (100000); the drive restarted "
             "at rest at the step's end";
    case AdvanceStatus::kCoarseTime:
      return "the time is so large that its round-off is not small against isr_period; the "
             "drive's clock follows the step times, which are this coarse";
  }
  return "";
}

double Drive::CommandFrom(double ctrl, const DriveState* state, double theta) const {
  if (std::isfinite(ctrl) && std::abs(ctrl) <= kMaxCommand) return ctrl;
  const bool velocity = config_.input == InputMode::kVelocity;
  if (state == nullptr || !state->started) return velocity ? 0.0 : theta;
  if (velocity) return state->omega_cmd;
  if (config_.input == InputMode::kSteps) return std::round(state->theta_cmd / step_angle_);
  if (layout_.profile > 0) {
    return Unpack<MotionProfile::State>(state->unit.data() + layout_.controller).target;
  }
  return state->theta_cmd;
}

AdvanceStatus Drive::Advance(DriveState* s, double t0, double t1, double theta1, double command,
                             double command_end) const {
  if (!(command_end >= t1)) command_end = t1;  // (NaN too)
  // Each check is written so that NaN fails it.
  if (!(std::isfinite(t0) && std::isfinite(t1) && t1 >= t0)) return AdvanceStatus::kBadTime;
  const bool input_ok = std::abs(theta1) <= kMaxCommand && std::abs(command) <= kMaxCommand;
  if (!input_ok) return AdvanceStatus::kBadInput;
  if (t1 - t0 > kMaxTicksPerAdvance * config_.isr_period) {
    // Too long a step to run tick by tick: the drive would have settled on its command.
    Restart(s, t1, theta1, command, /*keep_energies=*/true);
    return AdvanceStatus::kEventBound;
  }
  // A stored state no step makes (a user's write into plugin_state, a corrupt file) is restarted
  // before it runs, as the plugin does before its forces (Plausible): a stored rotor angle of
  // 1e303 made a rotor speed of 1e302 rad/s, whose phasors took seconds a step in the chopper's
  // crossing search (found by drive_fuzz, issue 33).
  if (!Plausible(reinterpret_cast<const double*>(static_cast<const DriveCoreState*>(s)))) {
    Restart(s, t1, theta1, command, /*keep_energies=*/false);
    return AdvanceStatus::kBadState;
  }
  // A clock far from its anchor re-anchors at its next tick, so that n stays a small integer.
  if (!(s->next_tick >= 0 && s->next_tick <= kMaxTicksFromAnchor)) {
    s->anchor_time = NextTickTime(*s);
    s->anchor_tick = std::fmod(s->anchor_tick + s->next_tick, kTickLabelRange);
    s->next_tick = 0;
  }
  const bool coarse = CoarseTime(t0) || CoarseTime(t1);
  const bool bounded = thermal_ ? AdvanceHot(s, t0, t1, theta1, command, command_end, coarse)
                                : std::visit(
                                      [&](const auto& unit) {
                                        double copper = 0;  // (unused without heat)
                                        return AdvanceWith(unit, ColdWinding(), s, t0, t1, theta1,
                                                           command, command_end, coarse, &copper);
                                      },
                                      config_.controller);
  // A stored double that is not finite (a user's write, a corrupt file) makes the loop's clock
  // resynchronise and its event bound end it, and the state it leaves is not finite: one check
  // here, after the step, finds it (from a finite state no input that passed the checks above
  // makes a value that is not finite, but the check costs little and makes it certain).
  if (!Finite(*s)) {
    Restart(s, t1, theta1, command, /*keep_energies=*/false);
    return AdvanceStatus::kBadState;
  }
  if (!bounded) return AdvanceStatus::kEventBound;
  return coarse ? AdvanceStatus::kCoarseTime : AdvanceStatus::kOk;
}

// Inlined into the event loop, as it was before heat (a call here costs 1 % of a chopper step).
[[gnu::always_inline]] inline DecayKernel Drive::DecayFor(const StepWinding& winding,
                                                          double length) {
  for (int i = 0; i < winding.kernel_count; ++i) {
    const DecayKernel& k = winding.kernels[i];
    if (std::abs(length - k.h) <= 1e-9 * length) {
      return winding.made == nullptr ? k : MadeKernel(winding, i);
    }
  }
  return DecayKernel(*winding.motor, length);
}

DecayKernel Drive::MadeKernel(const StepWinding& winding, int i) {
  DecayKernel& made = winding.made[i];
  if (made.h < 0) made = DecayKernel(*winding.motor, winding.kernels[i].h);
  return made;
}

bool Drive::AdvanceHot(DriveState* s, double t0, double t1, double theta1, double command,
                       double command_end, bool coarse) const {
  // The winding's constants over the step: R(T) and Km(T) at the step's starting winding
  // temperature (thermal.h), held over the step, with the clock's decay kernels for that R made
  // on first use.
  const double winding_temperature = s->winding_temperature;  // °C, at t0
  MotorParams hot = winding_motor_;                           // (no detent list: no allocation)
  hot.resistance = ResistanceAt(winding_temperature);
  hot.torque_constant = TorqueConstantAt(winding_temperature);
  std::array<DecayKernel, 3> made;  // h = −1: not made yet
  StepWinding winding = ColdWinding();
  winding.motor = &hot;
  winding.made = made.data();
  winding.loop_rate = loop_transient_.rate +  // (0 but for an averaged loop)
                      (hot.resistance - config_.motor.resistance) * loop_transient_.per_ohm;
  double copper = 0;  // J, the step's copper loss
  const bool bounded = std::visit(
      [&](const auto& unit) {
        return AdvanceWith(unit, winding, s, t0, t1, theta1, command, command_end, coarse, &copper);
      },
      config_.controller);
  if (t1 > t0) {
    // The network over the step with the copper loss's mean power held: exact (thermal.h).
    const double ambient = config_.heat->ambient_temperature;  // °C
    const std::array<double, 2> rise =
        thermal_->Step({winding_temperature - ambient, s->housing_temperature - ambient},
                       copper / (t1 - t0), t1 - t0);
    s->winding_temperature = ambient + rise[0];
    s->housing_temperature = ambient + rise[1];
  }
  return bounded;
}

template <class C>
bool Drive::AdvanceWith(const C& controller, const StepWinding& winding, DriveState* s, double t0,
                        double t1, double theta1, double command, double command_end, bool coarse,
                        double* copper) const {
  bool bounded = true;
  const MotorParams& motor = *winding.motor;
  double step_copper = 0;  // J
  // The signal voltage_peak: the held voltages over every interval the event loop integrates;
  // where no interval is (an averaged drive, a zero-length step), the step's two ends.
  const PhaseVector voltage_start = s->voltage();            // V
  double voltage_peak = -1;                                  // V; −1: no interval integrated
  const double h = t1 - t0;                                  // s
  const double theta0 = s->theta;                            // rad
  const double omega = h > 0 ? (theta1 - theta0) / h : 0.0;  // rad/s, constant over the step
  // At time t from `origin` (0, or t0 at a coarse time; see the event loop).
  double origin = 0;
  auto theta_at = [&](double t) { return theta0 + omega * (t - (t0 - origin)); };
  const PhaseVector phasor1 = UnitPhasor(constants_.rotor_teeth * theta1);  // e^{jx} at t1

  // The command over the step: the profile's plan, or ctrl itself.
  MotionProfile::State plan;
  const bool profiled = layout_.profile > 0;
  if (profiled) {
    plan = Unpack<MotionProfile::State>(s->unit.data() + layout_.controller);
    config_.profile.Update(&plan, t0, t1, command);
  }
  const double theta_cmd0 = s->theta_cmd;
  const bool steps = config_.input == InputMode::kSteps;
  // STEP/DIR from a list of pulse times (DriveConfig::step_times): the count is the list's at
  // each instant, counted on from the whole microstep θcmd rests at; every pulse is an edge.
  const StepTimes* list = steps ? config_.step_times.get() : nullptr;
  const double listed_from = list != nullptr ? std::round(theta_cmd0 / step_angle_) : 0.0;
  const double listed_base = list != nullptr ? list->Count(t0) : 0.0;
  auto listed_at = [&](double t_abs) {  // rad
    return (listed_from + list->Count(t_abs) - listed_base) * step_angle_;
  };
  // STEP/DIR through ctrl: the count's angle, reached at the step's end along a line (pulses
  // spread evenly); from a list, the list's at the step's end.
  const double target = list != nullptr ? listed_at(t1)
                        : steps         ? command * step_angle_
                                        : command;  // rad
  // STEP/DIR's pulses spread to the command's end: the step's, or its MuJoCo step's for a sub-step
  // (core/substep.h), so that a sub-step moves θcmd by its share only.
  const double command_span = steps && list == nullptr ? command_end - t0 : h;  // s
  const double omega_cmd = config_.input == InputMode::kVelocity
                               ? command
                               : (command_span > 0 ? (target - theta_cmd0) / command_span : 0.0);
  auto command_at = [&](double t) -> CommandSample {  // t from `origin`
    if (profiled) return config_.profile.Evaluate(plan, origin + t);
    if (list != nullptr) {
      return {.theta = listed_at(origin + t), .omega = list->Rate(origin + t) * step_angle_};
    }
    if (config_.input == InputMode::kVelocity || steps) {
      return {.theta = theta_cmd0 + omega_cmd * (t - (t0 - origin)), .omega = omega_cmd};
    }
    return {.theta = command, .omega = omega_cmd};
  };

  // SPEC §11, Kim's position law averaged (averaged_feed_forward.h): the law's continuous voltage
  // over the whole step on the winding's exact solution in the rotor's frame, (F-1)-(F-3); no
  // interrupts, whatever the clock. The law acts D + T/2 late (its staircase's lag), so a piece
  // [ta, tb] of the step reads the command and rotor over [ta − D − T/2, tb − D − T/2]; a step is
  // cut where the profile's polynomial changes, so that each piece's command is one polynomial.
  // A piece whose voltage might leave the stage's linear range sends the whole step to its
  // interrupts instead (the switching form below), so that the bus still cuts it.
  bool fed_forward = false;
  if constexpr (FeedForwardUnit<C> || HighGainFocUnit<C>) {
    if (config_.fidelity == Fidelity::kAveraged && h > 0) {
      typename C::State unit = Unpack<typename C::State>(s->unit.data());
      const KimMechanical& law = controller.mechanical;
      const double period = config_.isr_period;                 // T, s
      const double lag = config_.compute_delay + 0.5 * period;  // D + T/2, s
      const double r_nominal = constants_.resistance, km_nominal = constants_.torque_constant;
      const double l_nominal = constants_.inductance;            // H, the law's
      const double L = motor.inductance;                         // H
      const double electrical = constants_.rotor_teeth * omega;  // Ω, rad/s
      const PhaseVector held = Sinc(0.5 * electrical * period) * UnitPhasor(-electrical * lag);
      const PhaseVector j(0, 1);
      const double radius = stage_.LinearRadius();  // V
      PhaseVector current = s->current();           // A, stationary frame
      const PhaseVector start = current;
      IntervalEnergy energy;
      PhaseVector voltage;             // V, the law's at the last piece's end
      std::array<double, 5> torque{};  // τd of the last piece, N·m, in its s
      double piece_start = t0;
      bool linear = true;
      while (linear && piece_start < t1) {
        double piece_end = t1;
        if (profiled) {  // the profile's next change, where the lagged law meets it
          const double change = config_.profile.NextBreak(plan, piece_start - lag) + lag;
          if (change > piece_start + 1e-9 * h && change < t1 - 1e-9 * h) piece_end = change;
        }
        const double hp = piece_end - piece_start;  // s
        const double from = piece_start - lag;      // the law's time at s = 0
        // The command over the law's [from, from + hp] in s: θd a cubic (a profile's piece
        // exactly, by its Hermite cubic; a ctrl's constant or line as command_at gives it), θ̇d,
        // θ̈d and θ⃛d beside it.
        const CommandSample c0 = command_at(from), c1 = command_at(from + hp);
        std::array<double, 4> d;  // θd, rad, coefficients of s^0..s^3
        std::array<double, 3> v;  // θ̇d, rad/s
        std::array<double, 2> a;  // θ̈d, rad/s²
        double jerk = 0;          // θ⃛d, rad/s³
        if (profiled) {
          const double m0 = hp * c0.omega, m1 = hp * c1.omega;  // rad per unit s
          d = {c0.theta, m0, 3 * (c1.theta - c0.theta) - 2 * m0 - m1,
               2 * (c0.theta - c1.theta) + m0 + m1};
          v = {d[1] / hp, 2 * d[2] / hp, 3 * d[3] / hp};
          a = {2 * d[2] / (hp * hp), 6 * d[3] / (hp * hp)};
          jerk = 6 * d[3] / (hp * hp * hp);
        } else {
          d = {c0.theta, c1.theta - c0.theta, 0, 0};
          v = {c0.omega, c1.omega - c0.omega, 0};
          a = {c0.accel, c1.accel - c0.accel};
        }
        const double rotor0 = theta0 + omega * (from - t0);  // rad, the rotor at s = 0
        // e0 = ∫e1 dt over the law's time, e1 = θ − θd (K(20), K(22)), at s: rad·s.
        const double e0_start = unit.e0;
        auto e0_at = [&](double x) {
          const double rotor = rotor0 * x + 0.5 * omega * hp * x * x;
          const double command = x * (d[0] + x * (d[1] / 2 + x * (d[2] / 3 + x * d[3] / 4)));
          return e0_start + hp * (rotor - command);
        };
        // K(24)'s τd, a quartic in s, through five samples of the law itself; for the FOC also
        // K(33)'s τ̇d without its ω̇ term, and that term's gain.
        std::array<double, 5> torque_samples, rate_samples{};
        double rate_per_accel = 0;  // ∂τ̇d/∂ω̇, N·m·s
        for (int k = 0; k < 5; ++k) {
          const double x = 0.25 * k;
          const MechanicalSample in{.command = {.theta = d[0] + x * (d[1] + x * (d[2] + x * d[3])),
                                                .omega = v[0] + x * (v[1] + x * v[2]),
                                                .accel = a[0] + x * a[1],
                                                .jerk = jerk},
                                    .feedback = {.theta = rotor0 + omega * hp * x, .omega = omega}};
          const KimMechanical::Errors e = law.Track(in);
          torque_samples[k] = law.DesiredTorque(in, e, e0_at(x));
          if constexpr (HighGainFocUnit<C>) {
            rate_samples[k] = controller.TorqueRate(in, e, 0.0);
            if (k == 0) rate_per_accel = controller.TorqueRate(in, e, 1.0) - rate_samples[0];
          }
        }
        torque = QuarticThrough(torque_samples);  // N·m
        std::array<double, 5> rate{};             // N·m/s (the FOC's)
        if constexpr (HighGainFocUnit<C>) rate = QuarticThrough(rate_samples);
        // L·dI/dt = L·(α·I + β·Im I) + F(t), F a quartic (V): (F-1) for the STMMS (β = 0), (F-3)
        // for the FOC, whose ρ-feedback and ω̇ read the current.
        PhaseVector alpha(-motor.resistance / L, -electrical), beta(0, 0);  // 1/s
        ForcingPolynomial forcing;                                          // F, V
        if constexpr (FeedForwardUnit<C>) {  // K(28): v = R'·id + e'
          for (int m = 0; m < 5; ++m) forcing[m] = held * j * (r_nominal / km_nominal) * torque[m];
        } else {  // K(33): v = R'·i + e' + L'·(i̇d + ρ·(id − i)), i̇d with ω̇ from the current
          const double rho = controller.rho;  // 1/s
          // (R'·i − L'·ρ·i, the current read D + T/2 earlier in the stator: e^{−jΩ(D+T/2)}.)
          alpha += held * (r_nominal - l_nominal * rho) / L;
          beta = held * j * l_nominal * rate_per_accel / (law.inertia * L);
          const PhaseVector per = held * j * (l_nominal / km_nominal);  // V per N·m/s
          for (int m = 0; m < 5; ++m) {
            forcing[m] = per * (rate[m] + PhaseVector(rho, electrical) * torque[m]);
          }
          forcing[0] -=
              per * rate_per_accel * (law.damping * omega + law.load_torque) / law.inertia;
        }
        forcing[0] += j * omega * (held * km_nominal - motor.torque_constant);
        // On (Re I, Im I): D·dI/dt = A·I + F, A = L·(α·I + β·Im I). The FOC's feedback reads the
        // current D + T/2 earlier, I − (D + T/2)·dI/dt to first order, which moves those terms
        // into D.
        Eigen::Matrix2d weight, slope;  // D (H), A (H/s)
        slope << alpha.real(), -alpha.imag() + beta.real(), alpha.imag(),
            alpha.real() + beta.imag();
        slope *= L;
        weight = L * Eigen::Matrix2d::Identity();
        if constexpr (HighGainFocUnit<C>) {
          const PhaseVector late = lag * held * (r_nominal - l_nominal * controller.rho);  // H
          Eigen::Matrix2d times_late;  // late·I on (Re I, Im I)
          times_late << late.real(), -late.imag(), late.imag(), late.real();
          weight += times_late;
          weight(0, 1) += lag * L * beta.real();
          weight(1, 1) += lag * L * beta.imag();
        }
        const Eigen::Matrix2d inverse = weight.inverse();   // 1/H
        const Eigen::Matrix2d step = hp * inverse * slope;  // M of (F-1)
        auto vec = [](PhaseVector z) { return Eigen::Vector2d(z.real(), z.imag()); };
        // V(s) in the rotor's frame from I there: L·dI/dt + (R + jΩL)·I + j·Km·ω.
        auto voltage_at = [&](PhaseVector frame_current, double x) {
          PhaseVector f = 0;
          for (int m = 4; m >= 0; --m) f = f * x + forcing[m];
          const Eigen::Vector2d change = inverse * (slope * vec(frame_current) + vec(f));  // A/s
          return L * PhaseVector(change(0), change(1)) +
                 PhaseVector(motor.resistance, electrical * L) * frame_current +
                 j * motor.torque_constant * omega;
        };
        const PhaseVector phasor_a =
            s->rotor_phasor() * UnitPhasor(electrical * (piece_start - t0));
        const PhaseVector phasor_b =
            piece_end == t1 ? phasor1
                            : s->rotor_phasor() * UnitPhasor(electrical * (piece_end - t0));
        const PhaseVector start_frame = std::conj(phasor_a) * current;
        // (A piece over kFeedForwardMaxPieces pieces, a rotor turning tens of electrical cycles
        // in it, runs its interrupts: bounded by the event limit.)
        const double norm = step.cwiseAbs().rowwise().sum().maxCoeff();
        linear = norm <= kFeedForwardMaxPieces * kFeedForwardPieceMu;
        if constexpr (FeedForwardUnit<C>) {
          // |v| <= (R'/Km')·max|τd| + Km'·|ω| over the piece.
          double largest_torque = 0;  // N·m, >= max |τd|
          for (double q : torque) largest_torque += std::abs(q);
          linear = linear &&
                   r_nominal / km_nominal * largest_torque + km_nominal * std::abs(omega) <= radius;
        } else {
          // (The first-order delay stands for the loop's own only while ρ·(D + T/2) is small: a
          // slower clock runs its interrupts.)
          linear = linear && controller.rho * lag <= kFeedForwardLoopLag &&
                   std::abs(voltage_at(start_frame, 0)) <= kFeedForwardMargin * radius;
        }
        if (!linear) break;
        ForcingPolynomial g;  // G = hp·D⁻¹·F
        for (int m = 0; m < 5; ++m) {
          const Eigen::Vector2d gm = hp * inverse * vec(forcing[m]);
          g[m] = PhaseVector(gm(0), gm(1));
        }
        const RotatingFrameStep r =
            AdvanceRotatingFrame({step(0, 0), step(0, 1), step(1, 0), step(1, 1)}, g, start_frame);
        if constexpr (HighGainFocUnit<C>) {
          linear = std::abs(voltage_at(r.end, 1)) <= kFeedForwardMargin * radius;
          if (!linear) break;
        }
        // S-8: copper and mechanical from the solution.
        energy.copper += motor.resistance * hp * r.norm_integral;
        energy.mechanical += motor.torque_constant * omega * hp * r.integral.imag();
        voltage = voltage_at(r.end, 1) * phasor_b;
        current = r.end * phasor_b;
        unit.e0 = e0_at(1);
        piece_start = piece_end;
      }
      if (linear) {
        // S-8's input from the balance the solution meets.
        s->energy_copper += energy.copper;
        step_copper += energy.copper;
        s->energy_mechanical += energy.mechanical;
        s->energy_input +=
            energy.copper + energy.mechanical + 0.5 * L * (std::norm(current) - std::norm(start));
        const double torque_end = torque[0] + torque[1] + torque[2] + torque[3] + torque[4];
        const PhaseVector reference =
            j * (torque_end / km_nominal) * phasor1 * UnitPhasor(-electrical * lag);  // K(27)
        if constexpr (HighGainFocUnit<C>) {
          unit.previous_a = reference.real();
          unit.previous_b = reference.imag();
          unit.has_previous = 1;
        }
        Pack(unit, s->unit.data());
        s->current_a = current.real();
        s->current_b = current.imag();
        s->voltage_a = voltage.real();
        s->voltage_b = voltage.imag();
        s->current_ref_a = reference.real();
        s->current_ref_b = reference.imag();
        s->pending = 0;
        s->theta_meas = EncoderAngle(theta1, config_.encoder_counts);
        s->omega_est = omega;
        fed_forward = true;
      }
    }
  }
  if constexpr (IdealSourceUnit<C>) {
    const PhaseVector i = controller.setpoint.Phase(constants_, command_at(t1).theta);
    s->current_a = s->current_ref_a = i.real();
    s->current_b = s->current_ref_b = i.imag();
  } else if (RotatingVoltageUnit<C> && config_.fidelity == Fidelity::kAveraged) {
    if constexpr (RotatingVoltageUnit<C>) {
      // SPEC §11, an averaged voltage drive: K(5) as its interrupts' staircase carries it to the
      // winding, the staircase's fundamental Vmax·sinc(Ωc·T/2)·e^{jNr·θcmd(t − D − T/2)} (a hold
      // of T lags its samples by T/2 and scales them by the sinc; the compute delay D adds to
      // the lag), on the exact winding solution over the whole step: no interrupts, whatever the
      // clock. θcmd follows the step's chord (exact for velocity and STEP/DIR input, linear
      // within a step; a position command's jump is spread over the step), and the lag reaches
      // back along it. The stage never cuts it (Validate: Vmax within the stage's linear range).
      const double period = config_.isr_period;                            // T, s
      const double lag = config_.compute_delay + 0.5 * period;             // s
      const double theta_cmd1 = command_at(t1).theta;                      // rad
      const double omega_c = h > 0 ? (theta_cmd1 - theta_cmd0) / h : 0.0;  // rad/s
      const double wc = constants_.rotor_teeth * omega_c;                  // Ωc, rad/s
      const PhaseVector v0 = controller.RotatingAmplitude() * Sinc(0.5 * wc * period) *
                             UnitPhasor(constants_.rotor_teeth * (theta_cmd0 - omega_c * lag));
      PhaseVector current = s->current();
      if (h > 0) {
        IntervalEnergy e;
        current = AdvanceRotatingVoltage(motor, omega, current, v0, wc, h, s->rotor_phasor(), &e);
        s->energy_input += e.input;
        s->energy_copper += e.copper;
        step_copper += e.copper;
        s->energy_mechanical += e.mechanical;
      }
      const PhaseVector v1 = v0 * UnitPhasor(wc * h);  // V, at t1
      s->current_a = current.real();
      s->current_b = current.imag();
      s->voltage_a = v1.real();
      s->voltage_b = v1.imag();
      s->current_ref_a = v1.real() / constants_.resistance;  // K(4), as the tick's
      s->current_ref_b = v1.imag() / constants_.resistance;
      s->pending = 0;
      // The encoder and the speed estimate at the step's end, exact (no interrupts ran).
      s->theta_meas = EncoderAngle(theta1, config_.encoder_counts);
      s->omega_est = omega;
    }
  } else if (CurrentLoopUnit<C> && config_.fidelity == Fidelity::kAveraged) {
    if constexpr (CurrentLoopUnit<C>) {
      // SPEC §11, the averaged PI drive: the loop's continuous closed-loop response over the
      // step, exact (averaged_current_loop.h), along the command's chord; no interrupts.
      typename C::State unit = Unpack<typename C::State>(s->unit.data());
      const double theta_cmd1 = command_at(t1).theta;                      // rad
      const double omega_c = h > 0 ? (theta_cmd1 - theta_cmd0) / h : 0.0;  // rad/s
      PhaseVector integral(unit.integral_d, unit.integral_q);              // V
      const AveragedLoopResult r =
          AdvanceAveragedLoop(controller.setpoint, controller.loop, constants_, motor, stage_,
                              {.theta_frame = theta_cmd0,
                               .omega_frame = omega_c,
                               .omega = omega,
                               .rotor_phasor = s->rotor_phasor(),
                               .rotor_phasor_end = phasor1,
                               .h = h,
                               .compute_delay = config_.compute_delay,
                               .transient_rate = winding.loop_rate},
                              s->current(), &integral);
      unit.integral_d = integral.real();
      unit.integral_q = integral.imag();
      Pack(unit, s->unit.data());
      s->energy_input += r.energy.input;
      s->energy_copper += r.energy.copper;
      step_copper += r.energy.copper;
      s->energy_mechanical += r.energy.mechanical;
      const PhaseVector ref = controller.setpoint.Phase(constants_, theta_cmd1);
      s->current_a = r.current.real();
      s->current_b = r.current.imag();
      s->voltage_a = r.voltage.real();
      s->voltage_b = r.voltage.imag();
      s->current_ref_a = ref.real();
      s->current_ref_b = ref.imag();
      s->pending = 0;
      s->theta_meas = EncoderAngle(theta1, config_.encoder_counts);
      s->omega_est = omega;
    }
  } else if (!fed_forward) {
    typename C::State unit = Unpack<typename C::State>(s->unit.data());
    const double period = config_.isr_period;  // T
    // Tick times and step times meant to coincide differ by round-off only: of the period, and of
    // the simulation time's own accumulation (a few ulp of t). At a coarse time that round-off is
    // capped at kCoarseTimeFraction·T, so that ticks are still told apart in the step's frame.
    const double eps =
        1e-9 * period + std::min(8 * std::numeric_limits<double>::epsilon() * std::abs(t1),
                                 kCoarseTimeFraction * period);
    // The step's times are taken from `origin`: 0 (absolute time, as the clock's grid) normally,
    // t0 at a coarse time, where t + T would not be a different time but t − t0 + T is. Offsets
    // from the anchor are added to anchor_time − origin, exact (Sterbenz) when the two are close.
    origin = coarse ? t0 : 0.0;
    const double start = t0 - origin;
    const double t_next = (s->anchor_time - origin) + s->next_tick * period;
    // The next tick is within a period of the start, or (an averaged StealthChop's span at
    // standstill) within the longest span.
    double reach = 1;  // periods
    if constexpr (SpanUnit<C>) {
      if (config_.fidelity == Fidelity::kAveraged) reach = controller.LongestSpan(constants_);
    }
    if (!(t_next >= start - eps && t_next <= start + reach * period + eps)) {
      // Time jumped forward or was moved back under the drive: resynchronise its clock.
      AnchorAt(s, coarse ? t0 : t0 - eps, coarse);
      s->pending = 0;
    } else if (std::abs(t_next - start) <=
               eps) {                  // the next tick is the step's start: anchor there
      s->anchor_tick += s->next_tick;  // exact below 2^53; only a label beyond (k_anchor below)
      s->next_tick = 0;
      s->anchor_time = t0;
    }
    const double anchor = s->anchor_time - origin;
    const double end = t1 - origin;
    // The pending voltage's apply time: stored absolute, or at a coarse time rebuilt from its
    // tick, the one before next_tick (D < T, so it is always that one).
    double apply_at =
        coarse ? anchor + (s->next_tick - 1) * period + config_.compute_delay : s->apply_time;
    double n = s->next_tick;  // ticks from the anchor: an integer in [0, kMaxTicksFromAnchor]
    // k of the ticks, for the controllers (Sample::tick), from the anchor's label (below 2^53 in
    // magnitude unless the stored state was made up).
    const long k_anchor =
        std::abs(s->anchor_tick) < kTickLabelRange ? static_cast<long>(s->anchor_tick) : 0;
    PhaseVector current = s->current();
    PhaseVector voltage = s->voltage();
    double t = start;
    // The rotor's electrical phasor e^{jx(t)}, carried from interval to interval by each kernel's
    // rotation e^{jΩh}; the last kernel is reused while intervals keep their length (to 1e-9).
    PhaseVector phasor = s->rotor_phasor();  // at θ0
    WindingKernel kernel;
    std::optional<SpeedKernel> speed;  // shared by the step's kernels: ω is constant over it
    // A switching bridge's charge since its cycle began (PhaseSwitch::Ripple), A·s.
    const bool cycle_means = SwitchingUnit<C> && config_.fidelity == Fidelity::kSwitching;
    auto cycle_charge = [&]([[maybe_unused]] PhaseVector charge) {
      if constexpr (SwitchingUnit<C>) {
        if (!cycle_means) return;
        unit.phase[0].charge += charge.real();
        unit.phase[1].charge += charge.imag();
      }
    };
    auto integrate_to = [&](double t_end) {
      // An interval shorter than eps is round-off between tick times and step times: skipped.
      if (t_end <= t + eps) {
        t = std::max(t, t_end);
        return;
      }
      voltage_peak = std::max({voltage_peak, std::abs(voltage.real()), std::abs(voltage.imag())});
      if (config_.solver == WindingSolver::kExact) {
        const double length = t_end - t;
        if (std::abs(length - kernel.h) > 1e-9 * length) {
          if (!speed) speed.emplace(motor, omega, h, s->rotor_phasor(), phasor1);
          kernel = WindingKernel(*speed, DecayFor(winding, length));
        }
        IntervalEnergy e;
        current = AdvanceInterval(motor, kernel, current, voltage, phasor, &e);
        phasor *= kernel.rotation;
        s->energy_input += e.input;
        s->energy_copper += e.copper;
        step_copper += e.copper;
        s->energy_mechanical += e.mechanical;
        cycle_charge(e.charge);
      } else {
        const PhaseVector before = current;
        current = IntegrateWindingRk4(motor, current, voltage, theta_at(t), omega, t_end - t,
                                      config_.rk4_step);
        cycle_charge(0.5 * (before + current) * (t_end - t));  // the trapezoid: a reference path
      }
      t = t_end;
    };
    // StallGuard and CoolStep at time t, for the command there (a tick's, or an averaged
    // interval's start).
    auto guard = [&]([[maybe_unused]] const CommandSample& command) {
      if constexpr (requires { controller.stallguard; }) {
        // StallGuard measures once per full step (sensors/stallguard.h), from the rotor's mean
        // speed over it; CoolStep follows. The step rate is the chip's (TSTEP): one full step
        // over the time since the last.
        const StallGuard& sg = controller.stallguard;
        const double step = FullStep(command.theta);
        if (sg.version != 0 && step != s->full_step) {
          const double now = origin + t;                // s
          const double theta_now = theta_at(t);         // rad
          const double span = now - s->full_step_time;  // s
          const bool timed = s->full_step_time >= 0 && span > 0;
          const double step_rate =
              timed ? std::abs(step - s->full_step) * kTwoPi / (4 * constants_.rotor_teeth) / span
                    : 0.0;                                                               // rad/s
          const double speed = timed ? (theta_now - s->full_step_theta) / span : omega;  // rad/s
          s->full_step = step;
          s->full_step_time = now;
          s->full_step_theta = theta_now;
          s->stallguard = sg.Result(TorqueConstantAt(s->winding_temperature), speed, current,
                                    UnitPhasor(constants_.rotor_teeth * theta_now));
          s->stall = sg.Stall(s->stallguard, step_rate) ? 1 : 0;
          if (s->stall != 0 && s->first_stall_time < 0) s->first_stall_time = now;
          sg.CoolStep(s->stallguard, step_rate, &s->current_scale, &s->coolstep_count);
        }
      }
    };
    // Interrupt k at time t: sample the sensors, run the controller, schedule the new voltage.
    auto tick = [&](long k, [[maybe_unused]] double ticks) {
      // Encoder (S-16) and the backward-difference velocity estimate (S-17), every tick.
      const double theta_meas = EncoderAngle(theta_at(t), config_.encoder_counts);
      velocity_estimator_.Update(velocity_gain_, theta_meas, &s->theta_meas, &s->omega_est);
      const CommandSample command = command_at(t);
      guard(command);
      const Sample sample{
          .command = command,
          .feedback = {.theta = theta_meas,
                       .omega = speed_feedback_ == SpeedFeedback::kExact ? omega : s->omega_est},
          .current = current,
          .current_scale = s->current_scale,
          .tick = k};
      TickOutput out;
      if constexpr (SpanUnit<C>) {  // (Tick is Span over one)
        out = controller.Span(constants_, C::Input::From(sample), static_cast<double>(k), ticks,
                              stage_, &unit);
      } else {
        out = controller.Tick(constants_, C::Input::From(sample), stage_, &unit);
      }
      // A switching unit's tick gives the phases' new targets, a voltage controller's the voltage.
      const PhaseVector next = SwitchingUnit<C> ? out.current_ref : out.bridge.voltage;
      s->pending_a = next.real();
      s->pending_b = next.imag();
      s->pending = 1;
      s->current_ref_a = out.current_ref.real();
      s->current_ref_b = out.current_ref.imag();
    };
    constexpr double kNever = std::numeric_limits<double>::infinity();
    // A switching bridge's next event on each phase (switching.h), from `origin`: found on the
    // exact solution from the state at t with the held voltage, valid until that phase's voltage
    // or comparator changes (the phases' windings are independent, S-3) or the step ends.
    double t_switch[2] = {kNever, kNever};
    auto predict = [&](int p) {
      if constexpr (SwitchingUnit<C>) {
        if (!speed) speed.emplace(motor, omega, h, s->rotor_phasor(), phasor1);
        t_switch[p] = NextSwitchTime(unit.phase[p], p, motor, *speed, current, voltage, phasor,
                                     origin + t, origin + end) -
                      origin;
      }
    };
    // Phase p's bridge decides again (SwitchReason) at t; its new voltage is held from there.
    auto switch_phase = [&](int p, SwitchReason why) {
      if constexpr (SwitchingUnit<C>) {
        const double mode = unit.phase[p].mode, volts = unit.phase[p].voltage;
        const double i = p == 0 ? current.real() : current.imag();  // A
        controller.Switch(stage_, why, p, origin + t, i, &unit);
        PhaseSwitch& sw = unit.phase[p];
        voltage = {unit.phase[0].voltage, unit.phase[1].voltage};
        if (cycle_means) {
          sw.NoteSwitch(mode != C::kOn && sw.mode == C::kOn, sw.voltage != volts, origin + t, i);
        }
      }
    };
    const bool averaged = SwitchingUnit<C> && config_.fidelity == Fidelity::kAveraged;
    // An averaged StealthChop (SpanUnit) runs the interrupts as the switching one while anything
    // moves; at standstill one interrupt stands for the next SpanTicks of them (below).
    [[maybe_unused]] const bool spans = SpanUnit<C> && config_.fidelity == Fidelity::kAveraged;
    if (!averaged) {
      predict(0);
      predict(1);
    }
    // STEP/DIR edges (issue 29, item 7): on a drive whose unit has an Edge (the chip drives), the
    // count moves where θcmd crosses a half microstep (Count rounds; the pulses of a step are
    // spread evenly over it, so x = θcmd/step angle is linear and integer at the step's ends),
    // each crossing an event that moves the table at once, not at the next interrupt. The PI
    // drives keep reading the count at their interrupts (the DSP's timing).
    constexpr bool kEdges =
        requires(const C& u, const DriveConstants& k, const PowerStage& ps, typename C::State* st) {
      u.Edge(k, 0.0, 0.0, 1.0, ps, st);
    };
    // An averaged chopper takes the same crossings as events under velocity input too (θcmd is
    // linear there as well): its intervals then end where the table moves, wherever the step or
    // a sub-step ends. Read at each interval's middle instead, a microstep's change fell at a
    // time set by the (sub-)step's ends, which a sub-stepped rotor turned into a growing
    // oscillation (a 17HS19 on a TMC2209 ramped to 300 r/min, sub-stepped at 100 µs: 20.5 rad/s
    // RMS of speed error, now 0.015; `Averaged.AVelocityCommandMovesTheTableAtItsCrossings`).
    const double edge_rate = step_angle_ > 0 ? omega_cmd / step_angle_ : 0.0;  // microsteps/s
    const bool velocity_edges = averaged && config_.input == InputMode::kVelocity;
    // A list's pulses in the step, each an edge (as many as the list has there).
    const double listed = list != nullptr ? static_cast<double>(list->StepsIn(t0 - eps, t1)) : 0.0;
    const double travel = velocity_edges    ? std::abs(omega_cmd) * h
                          : list != nullptr ? listed * step_angle_
                                            : std::abs(target - theta_cmd0);  // rad
    const bool edges = kEdges && (steps || velocity_edges) &&
                       (list != nullptr ? listed > 0 : edge_rate != 0) &&
                       travel / step_angle_ <= kMaxEdgesPerAdvance;
    // The next crossing after time `from` (the step's frame), or never. A list's pulse within
    // eps of the step's start belongs to this step (`first`): the step before left it.
    auto next_edge = [&](double from, bool first = false) {
      if (!edges) return kNever;
      if (list != nullptr) {  // the next pulse of the list: its own time
        const double next = list->NextTime(origin + from - (first ? eps : 0.0)) - origin;
        return std::isfinite(next) ? std::max(next, from) : kNever;
      }
      const double x = command_at(from).theta / step_angle_;  // microsteps
      const double sign = edge_rate > 0 ? 1.0 : -1.0;
      double half = edge_rate > 0 ? std::floor(x + 0.5) + 0.5 : std::ceil(x - 0.5) - 0.5;
      if (!((half - x) / edge_rate > eps)) half += sign;  // on a crossing now: the next one
      return from + (half - x) / edge_rate;
    };
    double t_edge = next_edge(start, /*first=*/true);
    const long max_events =
        kMaxEventsPerAdvance + (edges ? static_cast<long>(travel / step_angle_) + 2 : 0L);
    // Every event moves t forward by at least eps or is the step's last, and n only grows: with
    // h <= kMaxTicksPerAdvance·T (Advance) the loop ends well before its hard stop. (A switching
    // bridge's events each start an on-time, an off-time or a decay of its own length, bounded
    // below by the unit's attributes.)
    long events = 0;
    if constexpr (SwitchingUnit<C>) {
      if (averaged) {
        // SPEC §11, averaged_bridge.h: no interrupts and no chopper events. The table's count
        // moves at the STEP edges (input = steps; exact events) or with the command (the other
        // inputs; an interval ends at the next microstep); each interval aims at the table's
        // target at its end (MicroPlyer's interpolation included, read at any instant through the
        // edge's fractional tick label) with the deadbeat voltage, within the bus, on the exact
        // winding solution.
        const double vbus = stage_.bus_voltage;                 // V
        const double emf_gain = motor.torque_constant * omega;  // V: |e| = Km·ω (S-2)
        const double electrical =
            constants_.rotor_teeth * std::max(std::abs(omega), std::abs(omega_cmd));  // rad/s
        const double rotation_limit =
            electrical > 0 ? kAveragedRotation / electrical : kNever;  // s
        // Without edges, an interval ends at the next microstep, but a jump of the command (a
        // new position without a profile, a step count beyond kMaxEdgesPerAdvance) is read in
        // at most kMaxAveragedReads intervals, as the interrupts would read it at once.
        const double microstep_time =
            !edges && step_angle_ > 0 && omega_cmd != 0
                ? std::max(step_angle_ / std::abs(omega_cmd), h / kMaxAveragedReads)
                : kNever;                 // s
        auto label_at = [&](double at) {  // the tick label of time `at` (fractional)
          return static_cast<double>(k_anchor) + (at - anchor) / period;
        };
        // The table's targets at `at` with the count `count` (microsteps).
        auto table_at = [&](double count, double at) {
          const TickOutput out =
              controller.Edge(constants_, count, label_at(at), s->current_scale, stage_, &unit);
          C::SetTarget(0, out.current_ref.real(), &unit);
          C::SetTarget(1, out.current_ref.imag(), &unit);
          s->current_ref_a = out.current_ref.real();
          s->current_ref_b = out.current_ref.imag();
        };
        while (t < end - eps) {
          if (++events > max_events) {
            bounded = false;
            integrate_to(end);
            break;
          }
          if (t_edge <= t + eps) {  // a STEP edge now: the count moves at its own time
            table_at(
                std::round(command_at(t_edge).theta / step_angle_ + (edge_rate > 0 ? 0.25 : -0.25)),
                t);
            t_edge = next_edge(t);
          }
          guard(command_at(t));
          // The interval: to the next edge, microstep or step end, at most kAveragedRotation of
          // electrical rotation; its target, the table's at its end (the count is constant
          // within it: read at its middle); a phase off its target first slews there (SlewTime).
          double t_next = std::min({end, t_edge, t + rotation_limit, t + microstep_time});
          table_at(std::round(command_at(0.5 * (t + t_next)).theta / step_angle_), t_next);
          const PhaseVector table(unit.phase[0].target, unit.phase[1].target);  // A
          const PhaseVector emf = PhaseVector(0, emf_gain) * phasor;  // V, j·Km·ω·e^{jx}
          const PhaseVector hold = motor.resistance * table + emf;    // V
          // The cycle's mean, not the table's entry, is what the phase carries: a place in the
          // chopper's band about the entry (RippleOffsets::BandAt), the nearest to where the
          // phase's mean is now. A step down leaves it at the band's top, from where it follows
          // the slow decay; a step up takes it to the band's bottom, the steady cycle.
          const OffsetBand band[2] = {ripple_.BandAt(table.real(), hold.real()),
                                      ripple_.BandAt(table.imag(), hold.imag())};
          auto in_band = [&](const PhaseVector& i) {  // A
            return PhaseVector(band[0].Nearest(table.real(), i.real()),
                               band[1].Nearest(table.imag(), i.imag()));
          };
          PhaseVector target = in_band(current);                                 // A
          const double tolerance = kOnTargetFraction * vbus / motor.resistance;  // A
          bool saturated[2] = {false, false};  // the bus cannot move the phase to its target
          bool idle[2] = {false, false};       // a zero target: decaying to 0, then shorted
          for (int p = 0; p < 2; ++p) {
            const double i = p == 0 ? current.real() : current.imag();
            const double i_target = p == 0 ? target.real() : target.imag();
            PhaseSwitch& sw = unit.phase[p];
            idle[p] = (p == 0 ? table.real() : table.imag()) == 0;
            if (!idle[p]) {
              sw.mode = kAveragedRegulating;
            } else if (sw.mode != kAveragedShorted) {
              sw.mode = std::abs(i) <= tolerance ? kAveragedShorted : kAveragedDecaying;
            }
            if (idle[p] || std::abs(i - i_target) <= tolerance) continue;
            const double slew =
                SlewTime(i, i_target, p == 0 ? hold.real() : hold.imag(), motor.inductance, vbus);
            saturated[p] = !std::isfinite(slew);
            t_next = std::min(t_next, std::max(t + slew, t + 2 * eps));
          }
          t_next = std::min(t_next, end);
          const double length = t_next - t;
          if (std::abs(length - kernel.h) > 1e-9 * length) {
            if (!speed) speed.emplace(motor, omega, h, s->rotor_phasor(), phasor1);
            kernel = WindingKernel(*speed, DecayFor(winding, length));
          }
          // The end current with v = 0 (no energies: nullptr).
          const PhaseVector free_end =
              AdvanceInterval(motor, kernel, current, {0, 0}, phasor, nullptr);
          target = in_band(free_end);  // within the band, the slow decay's own course (v = 0)
          voltage = stage_
                        .Apply({DeadbeatVoltage(target.real(), free_end.real(), kernel.decay,
                                                motor.resistance),
                                DeadbeatVoltage(target.imag(), free_end.imag(), kernel.decay,
                                                motor.resistance)})
                        .voltage;
          for (int p = 0; p < 2; ++p) {  // an idle phase: reversed to 0, then shorted
            if (!idle[p]) continue;
            const double i = p == 0 ? current.real() : current.imag();
            const double v = unit.phase[p].mode == kAveragedShorted ? 0.0 : (i > 0 ? -vbus : vbus);
            voltage = p == 0 ? PhaseVector(v, voltage.imag()) : PhaseVector(voltage.real(), v);
            if (v == 0) continue;
            const double reach = FirstCrossing(motor, *speed, current, voltage, phasor, p,
                                               i > 0 ? -1 : 1, 0.0, 0.0, 0.0, 2 * eps, length);
            if (reach > 2 * eps && reach < length) t_next = std::min(t_next, t + reach);
          }
          // A saturated phase (its deadbeat voltage cut for the whole interval) is driven at
          // ±Vbus until its current reaches the target, found on the exact solution
          // (switching.h), as the on-time of a chopper ends at its comparator. (A slewing phase
          // ends its interval at its slew time already.)
          for (int p = 0; p < 2; ++p) {
            if (!saturated[p] || idle[p]) continue;
            const double v = p == 0 ? voltage.real() : voltage.imag();
            const double gap =
                (p == 0 ? target.real() - current.real() : target.imag() - current.imag());  // A
            if (std::abs(v) < vbus || gap * v <= 0) continue;  // not cut, or not toward it
            const double reach =
                FirstCrossing(motor, *speed, current, voltage, phasor, p, v > 0 ? 1 : -1,
                              p == 0 ? target.real() : target.imag(), 0.0, 0.0, 2 * eps, length);
            if (reach > 2 * eps && reach < length) t_next = std::min(t_next, t + reach);
          }
          integrate_to(t_next);
        }
        // The encoder and the speed estimate at the step's end, exact (no interrupts ran).
        s->theta_meas = EncoderAngle(theta1, config_.encoder_counts);
        s->omega_est = omega;
        // The clock skips to the step's end, so that the next step finds it in sync.
        n = std::max(n, std::ceil((end - anchor) / period - 1e-9));
        s->pending = 0;
      }
    }
    // SPEC §11, the averaged servo and identification: T(18)'s PI loop in the encoder's frame by
    // its continuous closed-loop response (averaged_current_loop.h) from one position update of
    // T(19) to the next, each at the interrupt it runs on (k % ticks_per_position = 0, the
    // switching form's own instants), so that the position loop keeps its sampling and its
    // delay; no other interrupt runs. The frame turns with the rotor over the step, half an
    // encoder count behind it (the fundamental of S-16's staircase, whose amplitude is within
    // 3e-4 of the rotor's at 4 000 counts on 50 teeth), S-17's estimate follows its exact course
    // at the step's constant speed, and identification's friction share Fs·sgn(ωfb) is read at
    // each step's start.
    [[maybe_unused]] bool field_averaged = false;
    if constexpr (FieldOrientedUnit<C>) {
      if (config_.fidelity == Fidelity::kAveraged) {
        field_averaged = true;
        PhaseVector integral(unit.integral_d, unit.integral_q);  // V, dq
        // S-16's floor lags the encoder's staircase by half a count on average.
        const double frame_lag =
            config_.encoder_counts > 0 ? 0.5 * kTwoPi / config_.encoder_counts : 0.0;  // rad
        // The sensors at time `at` >= t, tick k: the rotor along its chord, the estimate along
        // its course from t (the current is not read: the servo's position loop needs none).
        auto sample = [&](long k, double at) {
          double estimate = s->omega_est;  // rad/s
          velocity_estimator_.Advance(omega, at - t, &estimate);
          return Sample{
              .command = command_at(at),
              .feedback = {.theta = EncoderAngle(theta_at(at), config_.encoder_counts),
                           .omega = speed_feedback_ == SpeedFeedback::kExact ? omega : estimate},
              .current = current,
              .current_scale = s->current_scale,
              .tick = k};
        };
        auto advance_to = [&](double t_end, double iq) {  // iq*, A
          if (t_end <= t + eps) {
            t = std::max(t, t_end);
            return;
          }
          const double length = t_end - t;  // s
          const PhaseVector phasor_end =
              phasor * UnitPhasor(constants_.rotor_teeth * omega * length);
          const AveragedLoopResult r = AdvanceAveragedLoop(
              controller.LoopSetpoint(), controller.loop, constants_, motor, stage_,
              {.theta_frame = theta_at(t) - frame_lag,
               .omega_frame = omega,
               .omega = omega,
               .rotor_phasor = phasor,
               .rotor_phasor_end = phasor_end,
               .h = length,
               .compute_delay = config_.compute_delay,
               .iq = iq,
               .transient_rate = winding.loop_rate},
              current, &integral);
          s->energy_input += r.energy.input;
          s->energy_copper += r.energy.copper;
          step_copper += r.energy.copper;
          s->energy_mechanical += r.energy.mechanical;
          current = r.current;
          voltage = r.voltage;
          phasor = phasor_end;
          velocity_estimator_.Advance(omega, length, &s->omega_est);
          t = t_end;
        };
        if constexpr (requires { controller.Position(constants_, Sample{}, &unit); }) {
          // An update's iq* reaches the winding with its tick's voltage, D later: the closed form
          // applies it D after the update's tick, the one before until then. (The hold's T/2 is
          // in the loop's response, TransientRate. Applied at the tick itself, the damped servo's
          // ripple at 90 r/min is 6.5 % low against switching; with D, 1.5 %.)
          const long every = controller.ticks_per_position;
          auto ticks_past = [&](double m) {  // ticks from m back to the last update, >= 0
            const long label = k_anchor + static_cast<long>(m);
            return static_cast<double>((label % every + every) % every);
          };
          const double delay = config_.compute_delay;                                 // D, s
          double applies_at = anchor + (n - 1 - ticks_past(n - 1)) * period + delay;  // from origin
          // One closed form per position period, from one update's arrival to the next's: the
          // update itself reads only the rotor and the command, known along the step's chord.
          for (;;) {
            if (applies_at > t + eps) advance_to(std::min(applies_at, end), unit.iq_previous);
            const double update = n + std::fmod(every - ticks_past(n), every);  // the next one
            const double t_update = anchor + update * period;
            if (t_update > end - eps) break;
            unit.iq_previous = unit.iq_cmd;
            controller.Position(constants_, sample(k_anchor + static_cast<long>(update), t_update),
                                &unit);
            applies_at = t_update + delay;
            n = update + 1;
          }
          advance_to(end, unit.iq_cmd);
        } else {
          advance_to(end, controller.HeldIq(constants_, sample(0, t), unit));
        }
        unit.integral_d = integral.real();
        unit.integral_q = integral.imag();
        const PhaseVector park = UnitPhasor(constants_.rotor_teeth * theta1);  // ψ at t1
        const PhaseVector ref =
            park * (controller.LoopSetpoint().Dq(constants_, theta1) +
                    PhaseVector(0, controller.HeldIq(constants_, sample(0, t), unit)));
        s->current_ref_a = ref.real();
        s->current_ref_b = ref.imag();
        s->theta_meas = EncoderAngle(theta1, config_.encoder_counts);
        // The clock skips to the step's end, so that the next step finds it in sync.
        n = std::max(n, std::ceil((end - anchor) / period - 1e-9));
        s->pending = 0;
      }
    }
    while (!averaged && !field_averaged) {
      const double t_apply = s->pending ? apply_at : kNever;
      const double t_tick = anchor + n * period;             // t_k − origin
      const int p_next = t_switch[1] < t_switch[0] ? 1 : 0;  // the phase that switches first
      const double t_event = std::min({t_apply, t_tick, t_switch[p_next], t_edge});
      // Events in [t0, t1 − eps] belong to this step; one within eps of t1 is the next step's, so
      // that a tick at a step boundary samples the command set for the step that starts there.
      if (t_event > end - eps) {
        integrate_to(end);
        break;
      }
      if (++events > max_events) {  // the hard stop: hold the voltage to the step's end
        integrate_to(end);
        bounded = false;
        break;
      }
      integrate_to(std::min(t_event, end));
      if (t_edge <= std::min({t_apply, t_tick, t_switch[p_next]})) {  // a STEP edge: at once
        if constexpr (kEdges) {
          // The count just past the crossing, at the tick label of this instant.
          const double count =
              std::round(command_at(t_edge).theta / step_angle_ + (edge_rate > 0 ? 0.25 : -0.25));
          const double label = static_cast<double>(k_anchor) + (t - anchor) / period;
          const TickOutput out =
              controller.Edge(constants_, count, label, s->current_scale, stage_, &unit);
          s->current_ref_a = out.current_ref.real();
          s->current_ref_b = out.current_ref.imag();
          s->pending = 0;  // the edge's output is newer than the last tick's, not yet applied
          if constexpr (SwitchingUnit<C>) {
            C::SetTarget(0, out.current_ref.real(), &unit);
            C::SetTarget(1, out.current_ref.imag(), &unit);
            switch_phase(0, SwitchReason::kTarget);
            switch_phase(1, SwitchReason::kTarget);
            predict(0);
            predict(1);
          } else {
            voltage = out.bridge.voltage;
          }
        }
        t_edge = next_edge(t);
      } else if (t_switch[p_next] < std::min(t_apply, t_tick)) {  // a bridge switches
        if constexpr (SwitchingUnit<C>) {
          const PhaseSwitch& sw = unit.phase[p_next];
          const bool timed = sw.has_until != 0 && sw.until - origin <= t + eps;
          switch_phase(p_next, timed ? SwitchReason::kTime : SwitchReason::kLevel);
          predict(p_next);
        }
      } else if (t_apply <= t_tick) {      // S-15: v[k−1] reaches the phases at t_{k−1} + D
        if constexpr (SwitchingUnit<C>) {  // the tick's targets reach the comparators
          C::SetTarget(0, s->pending_a, &unit);
          C::SetTarget(1, s->pending_b, &unit);
          s->pending = 0;
          switch_phase(0, SwitchReason::kTarget);
          switch_phase(1, SwitchReason::kTarget);
          predict(0);
          predict(1);
        } else {  // the voltage, held until the next apply
          voltage = {s->pending_a, s->pending_b};
          s->pending = 0;
        }
      } else {  // interrupt k: sample, compute v[k]
        // Averaged StealthChop at standstill (SPEC §11): this interrupt stands for the next
        // SpanTicks of them within the step while the command's count stays (the chip's counters
        // advanced by them at once, its voltage held over them); the next runs after them.
        double ticks = 1;
        if constexpr (SpanUnit<C>) {
          if (spans) {
            // Ticks while the command holds (this step's, or its MuJoCo step's when a sub-step).
            const double within =
                std::floor((end + (command_end - t1) - eps - t_tick) / period) + 1;
            ticks =
                std::max(1.0, std::min(std::floor(controller.SpanTicks(constants_, unit)), within));
            if (ticks > 1 && controller.table.Count(constants_, command_at(t_tick).theta) !=
                                 controller.table.Count(
                                     constants_, command_at(t_tick + (ticks - 1) * period).theta)) {
              ticks = 1;
            }
          }
        }
        tick(k_anchor + static_cast<long>(n), ticks);
        apply_at = t_tick + config_.compute_delay;
        n += ticks;
      }
    }
    s->next_tick = n;
    s->apply_time = origin + apply_at;
    s->current_a = current.real();
    s->current_b = current.imag();
    if constexpr (SwitchingUnit<C>) {
      if (cycle_means) {  // the torque handed over is the cycles' means' (DriveCoreState)
        s->mean_offset_a = -unit.phase[0].Ripple(origin + t, h);
        s->mean_offset_b = -unit.phase[1].Ripple(origin + t, h);
      }
    }
    s->voltage_a = voltage.real();
    s->voltage_b = voltage.imag();
    Pack(unit, s->unit.data());
  }
  const CommandSample at_end = command_at(t1 - origin);
  s->theta = theta1;
  s->set_rotor_phasor(phasor1);
  // (STEP/DIR: the count's angle exactly at the command's end; a sub-step before it, its share.)
  s->theta_cmd = steps && !(command_end > t1) ? target : at_end.theta;
  // The signal (read nowhere else for a step list): from a list, its step rate at the step's end,
  // not the step's count change, which alternates between 0 and a microstep per step when the
  // pulses are slower than the steps (issue 32, item 4).
  s->omega_cmd = profiled          ? at_end.omega
                 : list != nullptr ? list->Rate(t1) * step_angle_
                                   : omega_cmd;
  if (profiled) Pack(plan, s->unit.data() + layout_.controller);
  if constexpr (C::kCountsSlips) {  // open loop: a slip is a whole electrical cycle lost or won
    const double cell = SlipCell(constants_.rotor_teeth * (s->theta_cmd - theta1), s->slip_cell);
    if (cell != s->slip_cell) {
      s->slip_cell = cell;
      s->last_slip_time = t1;
    }
  }
  s->voltage_peak = voltage_peak >= 0
                        ? voltage_peak
                        : std::max({std::abs(voltage_start.real()), std::abs(voltage_start.imag()),
                                    std::abs(s->voltage_a), std::abs(s->voltage_b)});
  *copper = step_copper;
  return bounded;
}

double Drive::FullStep(double theta_cmd) const {
  return std::floor(4.0 * constants_.rotor_teeth * theta_cmd / kTwoPi);  // S-1: 4 per cycle
}

double Drive::ResistanceAt(double winding_temperature) const {
  const double r20 = config_.motor.resistance;  // Ω
  return config_.heat
             ? r20 * TemperatureFactor(config_.heat->resistance_coefficient, winding_temperature)
             : r20;
}

double Drive::TorqueConstantAt(double winding_temperature) const {
  const double km20 = config_.motor.torque_constant;  // N·m/A
  return config_.heat ? km20 * TemperatureFactor(config_.heat->torque_constant_coefficient,
                                                 winding_temperature)
                      : km20;
}

PhaseVector Drive::RotorPhasor(bool started, double stored_theta, PhaseVector stored_phasor,
                               double theta) const {
  // e^{jx}, S-1: the one kept with the state's θ (Advance, Rest) when it is that angle.
  return started && theta == stored_theta ? stored_phasor
                                          : UnitPhasor(constants_.rotor_teeth * theta);
}

std::pair<double, double> Drive::Torques(PhaseVector current, PhaseVector z,
                                         double torque_constant) const {
  const double torque_em = torque_constant * (std::conj(z) * current).imag();  // S-4
  // S-5: −Σh Kdh·sin(h·x + φh) = −Im(Σh wh·z^h) = −Im(z·(w1 + z·(w2 + z·(...))))
  PhaseVector sum(0, 0);
  for (auto w = detent_weights_.rbegin(); w != detent_weights_.rend(); ++w) sum = z * (*w + sum);
  return {torque_em, -sum.imag()};
}

double Drive::Torque(const DriveCoreState& s, double theta) const {
  const auto [torque_em, torque_detent] =
      Torques(s.handed_current(), RotorPhasor(s.started, s.theta, s.rotor_phasor(), theta),
              TorqueConstantAt(s.winding_temperature));
  return torque_em + torque_detent;
}

bool Drive::Plausible(const double* values) const {
  using S = DriveCoreState;  // standard layout, all doubles: a field is values[offset / 8]
  auto field = [values](std::size_t offset) { return values[offset / sizeof(double)]; };
  auto within = [](double x, double bound) { return std::abs(x) <= bound; };  // NaN fails
  constexpr double kLeastTemperature = -273.15, kMostTemperature = 1e6;       // °C
  const double tw = field(offsetof(S, winding_temperature));
  const double th = field(offsetof(S, housing_temperature));
  return within(field(offsetof(S, theta)), 2 * kMaxCommand) &&
         within(field(offsetof(S, theta_cmd)), 2 * kMaxCommand) &&
         within(field(offsetof(S, rotor_cos)), 1.5) && within(field(offsetof(S, rotor_sin)), 1.5) &&
         within(field(offsetof(S, current_a)) + field(offsetof(S, mean_offset_a)),
                current_bound_) &&
         within(field(offsetof(S, current_b)) + field(offsetof(S, mean_offset_b)),
                current_bound_) &&
         tw >= kLeastTemperature && tw <= kMostTemperature && th >= kLeastTemperature &&
         th <= kMostTemperature;
}

Drive::StoredMotor Drive::ReadStored(const double* values, double theta) const {
  using S = DriveCoreState;  // standard layout, all doubles: a field is values[offset / 8]
  auto field = [values](std::size_t offset) { return values[offset / sizeof(double)]; };
  return {
      .rotor = RotorPhasor(field(offsetof(S, started)) != 0, field(offsetof(S, theta)),
                           {field(offsetof(S, rotor_cos)), field(offsetof(S, rotor_sin))}, theta),
      .current = {field(offsetof(S, current_a)) + field(offsetof(S, mean_offset_a)),
                  field(offsetof(S, current_b)) + field(offsetof(S, mean_offset_b))},
      // Km at the step's starting winding temperature, as over the step (Advance).
      .torque_constant = thermal_ ? TorqueConstantAt(field(offsetof(S, winding_temperature)))
                                  : constants_.torque_constant};
}

double Drive::StoredTorque(const double* values, double theta) const {
  const StoredMotor s = ReadStored(values, theta);
  const auto [torque_em, torque_detent] = Torques(s.current, s.rotor, s.torque_constant);
  return torque_em + torque_detent;
}

double Drive::StoredStiffness(const double* values, double theta) const {
  return StiffnessOf(ReadStored(values, theta));
}

std::pair<double, double> Drive::StoredTorqueAndStiffness(const double* values,
                                                          double theta) const {
  const StoredMotor s = ReadStored(values, theta);
  const auto [torque_em, torque_detent] = Torques(s.current, s.rotor, s.torque_constant);
  return {torque_em + torque_detent, StiffnessOf(s)};
}

std::pair<double, double> Drive::TorqueAndStiffness(const DriveCoreState& s, double theta) const {
  const StoredMotor m{.rotor = RotorPhasor(s.started != 0, s.theta, s.rotor_phasor(), theta),
                      .current = s.handed_current(),
                      .torque_constant = thermal_ ? TorqueConstantAt(s.winding_temperature)
                                                  : constants_.torque_constant};
  const auto [torque_em, torque_detent] = Torques(m.current, m.rotor, m.torque_constant);
  return {torque_em + torque_detent, StiffnessOf(m)};
}

void Drive::Relocate(DriveCoreState* s, double theta) const {
  s->theta = theta;
  s->set_rotor_phasor(UnitPhasor(constants_.rotor_teeth * theta));
}

double Drive::StiffnessOf(const StoredMotor& s) const {
  // S-4: ∂/∂θ Km·Im(z̄·i) = −Nr·Km·Re(z̄·i), z = e^{jNrθ}; S-5: ∂/∂θ −Im(Σh wh·z^h) =
  // −Nr·Re(Σh h·wh·z^h).
  PhaseVector detent(0, 0), power(1, 0);
  for (std::size_t h = 0; h < detent_weights_.size(); ++h) {
    power *= s.rotor;
    detent += static_cast<double>(h + 1) * detent_weights_[h] * power;
  }
  return constants_.rotor_teeth *
         (s.torque_constant * (std::conj(s.rotor) * s.current).real() + detent.real());
}

DriveSignals Drive::Signals(const DriveState& s, double theta) const {
  const MotorParams& motor = config_.motor;
  DriveSignals out;
  out.current_a = s.current_a;
  out.current_b = s.current_b;
  out.voltage_a = s.voltage_a;
  out.voltage_b = s.voltage_b;
  out.voltage_peak = s.voltage_peak;
  const PhaseVector dq = ToDq(s.current(), motor.rotor_teeth * s.theta_cmd);  // S-9, ψ = Nr·θcmd
  out.current_d = dq.real();
  out.current_q = dq.imag();
  out.current_ref_a = s.current_ref_a;
  out.current_ref_b = s.current_ref_b;
  out.theta_cmd = s.theta_cmd;
  out.omega_cmd = s.omega_cmd;
  std::tie(out.torque_em, out.torque_detent) =
      Torques(s.handed_current(), RotorPhasor(s.started, s.theta, s.rotor_phasor(), theta),
              TorqueConstantAt(s.winding_temperature));
  out.torque_total = out.torque_em + out.torque_detent;
  out.load_angle = motor.rotor_teeth * (s.theta_cmd - theta);  // S-12
  out.position_error = theta - s.theta_cmd;
  out.lost_steps = 4.0 * (s.slip_cell - s.slip_origin) + 0.0;  // + 0.0: never −0
  out.last_slip_time = s.last_slip_time;
  out.energy_input = s.energy_input;
  out.energy_copper = s.energy_copper;
  out.energy_mechanical = s.energy_mechanical;
  out.theta_meas = s.theta_meas;
  out.omega_est = s.omega_est;
  out.stallguard = s.stallguard;
  out.stall = s.stall;
  out.first_stall_time = s.first_stall_time;
  out.current_scale = s.current_scale;
  out.winding_temperature = s.winding_temperature;
  out.housing_temperature = s.housing_temperature;
  out.resistance = ResistanceAt(s.winding_temperature);
  return out;
}

double Drive::RestCurrentMagnitude() const {
  DriveState s = Rest(0.0, 0.0, 0.0);
  return std::abs(s.current());
}

double Drive::DetentStiffness() const {
  double sum = 0;  // Σh h·Kdh, N·m
  for (const DetentHarmonic& h : config_.motor.detent) sum += h.order * std::abs(h.amplitude);
  return constants_.rotor_teeth * sum;
}

double Drive::HoldingStiffness() const {
  const PhaseVector rest_current = Rest(0.0, 0.0, 0.0).current();
  return std::visit(
      [&](const auto& unit) { return unit.HoldingStiffness(constants_, rest_current); },
      config_.controller);
}

}  // namespace mjstepper
