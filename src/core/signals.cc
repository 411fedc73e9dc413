#include "core/signals.h"

#include <fmt/format.h>

#include <stdexcept>

namespace mjstepper {

const std::array<SignalInfo, kNumSignals>& SignalTable() {
  using S = DriveSignals;
  static const std::array<SignalInfo, kNumSignals> table = {{
      {"current_a", "A", "phase A current ia", &S::current_a},
      {"current_b", "A", "phase B current ib", &S::current_b},
      {"voltage_a", "V", "phase A voltage va (held bridge output)", &S::voltage_a},
      {"voltage_b", "V", "phase B voltage vb", &S::voltage_b},
      {"voltage_peak", "V",
       "the largest |va|, |vb| the bridges held at any time within the last step (MuJoCo's step; "
       "every interrupt's and chopper event's voltage, where voltage_a/b are the one held at the "
       "step's end); the averaged drives: the larger of their mean voltages at the step's ends",
       &S::voltage_peak},
      {"current_d", "A", "id, Park frame at ψ = Nr·θcmd (S-9)", &S::current_d},
      {"current_q", "A", "iq, Park frame at ψ = Nr·θcmd (S-9)", &S::current_q},
      {"current_ref_a", "A",
       "the controller's phase-A current reference at the last interrupt (iad of K(27) for "
       "stmms/foc; the T(12)-(13) setpoint for the current drives; Vmax/R·cos(Nr·θcmd) for "
       "voltage_microstep)",
       &S::current_ref_a},
      {"current_ref_b", "A", "the same for phase B", &S::current_ref_b},
      {"theta_cmd", "rad", "commanded rotor angle θcmd (θd of the motion profile)", &S::theta_cmd},
      {"omega_cmd", "rad/s",
       "commanded rotor speed; from a step list (steps(FILE)), its step rate at the step's end: a "
       "microstep over the interval between the pulses around it",
       &S::omega_cmd},
      {"torque_em", "N·m",
       "electromagnetic torque τm (S-4), with Km(T_w) under `heat`; a switching chopper's from "
       "its currents less their ripple where the step does not resolve the chopper's cycle (a "
       "step over half a cycle: the ripple of the last cycle at the same time into it)",
       &S::torque_em},
      {"torque_detent", "N·m", "detent torque τdet (S-5)", &S::torque_detent},
      {"torque_total", "N·m",
       "τm + τdet, the torque the motor makes on its rotor: the actuator force before MuJoCo's "
       "forcerange clamp (with forcelimited, `actuator_force` is this clipped to forcerange, and "
       "the joint gets the clipped one)",
       &S::torque_total},
      {"load_angle", "rad (electrical)", "δ = Nr·(θcmd − θ) (S-12)", &S::load_angle},
      {"position_error", "rad", "θ − θcmd (rotor side): the tracking error, e1 of K(20)",
       &S::position_error},
      {"lost_steps", "full steps",
       "full steps slipped, signed (+: the rotor fell behind), 4 per electrical cycle, counted by "
       "the open-loop drives when δ passes 2π·k ± 5π/4; 0 under the closed-loop ones (servo, "
       "stmms, foc, identification), whose error is position_error",
       &S::lost_steps},
      {"last_slip_time", "s", "end of the step in which the last slip was counted; −1: none yet",
       &S::last_slip_time},
      {"energy_input", "J",
       "∫(va·ia + vb·ib) dt since the start; S-8 holds between the three energies; 0 under "
       "`ideal_current`, which has no windings",
       &S::energy_input},
      {"energy_copper", "J",
       "∫R·(ia² + ib²) dt, R = R(T_w) under `heat`: the heat the winding receives",
       &S::energy_copper},
      {"energy_mechanical", "J", "∫τm·ω dt", &S::energy_mechanical},
      {"theta_meas", "rad",
       "encoder angle at the last interrupt (S-16); `ideal_current` has no interrupts and keeps "
       "its start value",
       &S::theta_meas},
      {"omega_est", "rad/s", "velocity estimate at the last interrupt (S-17)", &S::omega_est},
      {"stallguard", "counts",
       "SG_RESULT of the StallGuard model (sensors/stallguard.h): 0..1023 (StallGuard2, "
       "`spreadcycle` on tmc2130/5160) or 0..510 (StallGuard4, `stealthchop` on tmc2209) from "
       "Km·|ω|·cos δi at each full step, full scale at rest; 0 for drives without StallGuard",
       &S::stallguard},
      {"stall", "0/1",
       "1 while SG_RESULT flags a stall (StallGuard2: 0; StallGuard4: ≤ 2·SGTHRS) above "
       "`stallguard_min_speed`: the chip's DIAG output",
       &S::stall},
      {"first_stall_time", "s", "time of the interrupt that first flagged a stall; −1: none yet",
       &S::first_stall_time},
      {"current_scale", "—",
       "CoolStep's scale of the run current (1 without CoolStep): the table's peak is "
       "√2·run_current·current_scale",
       &S::current_scale},
      {"winding_temperature", "°C",
       "winding temperature T_w (SPEC §8, two-node network winding → housing → ambient, heated by "
       "the copper loss); 20 (the temperature R and Km stand for) when `heat` is off",
       &S::winding_temperature},
      {"housing_temperature", "°C", "housing temperature T_h; 20 when `heat` is off",
       &S::housing_temperature},
      {"resistance", "Ω",
       "phase resistance at the winding temperature, R(T_w) = R·(1 + α·(T_w − 20 °C)); R when "
       "`heat` is off",
       &S::resistance},
      {"omega", "rad/s",
       "rotor speed (rotor side): MuJoCo's actuator_velocity; with `coupling=\"substepped\"` the "
       "sub-stepped rotor's own speed, MuJoCo's joint speed being the mean over the last step",
       &S::omega},
  }};
  return table;
}

int SignalIndex(const std::string& name) {
  const auto& table = SignalTable();
  for (int i = 0; i < kNumSignals; ++i) {
    if (name == table[i].name) return i;
  }
  throw std::out_of_range("no signal named " + name);
}

std::array<double, kNumSignals> SignalValues(const DriveSignals& s) {
  std::array<double, kNumSignals> values;
  const auto& table = SignalTable();
  for (int i = 0; i < kNumSignals; ++i) values[i] = s.*(table[i].field);
  return values;
}

std::string SignalTableMarkdown() {
  std::string out = "| # | name | unit | meaning |\n|---|---|---|---|\n";
  const auto& table = SignalTable();
  for (int i = 0; i < kNumSignals; ++i) {
    out +=
        fmt::format("| {} | `{}` | {} | {} |\n", i, table[i].name, table[i].unit, table[i].meaning);
  }
  return out;
}

}  // namespace mjstepper
