#include "core/signals.h"

namespace mjstepper {

const std::array<SignalInfo, kNumSignals>& SignalTable() {
  static const std::array<SignalInfo, kNumSignals> table = {{
      {"current_a", "A", "phase A current ia"},
      {"current_b", "A", "phase B current ib"},
      {"voltage_a", "V", "phase A voltage va (held bridge output)"},
      {"voltage_b", "V", "phase B voltage vb"},
      {"current_d", "A", "id, Park frame at ψ = Nr·θcmd (S-9)"},
      {"current_q", "A", "iq, Park frame at ψ = Nr·θcmd (S-9)"},
      {"theta_cmd", "rad", "commanded rotor angle θcmd"},
      {"omega_cmd", "rad/s", "commanded rotor speed over the last step"},
      {"torque_em", "N·m", "electromagnetic torque τm (S-4)"},
      {"torque_detent", "N·m", "detent torque τdet (S-5)"},
      {"torque_total", "N·m", "τm + τdet, the torque on the rotor (actuator force)"},
      {"load_angle", "rad (electrical)", "δ = Nr·(θcmd − θ) (S-12)"},
      {"lost_steps", "full steps", "4·round(δ/2π): full steps slipped, signed"},
      {"energy_input", "J", "∫(va·ia + vb·ib) dt since the start"},
      {"energy_copper", "J", "∫R·(ia² + ib²) dt"},
      {"energy_mechanical", "J", "∫τm·ω dt"},
      {"theta_meas", "rad", "encoder angle at the last interrupt (S-16)"},
      {"omega_est", "rad/s", "velocity estimate at the last interrupt (S-17)"},
  }};
  return table;
}

std::array<double, kNumSignals> SignalValues(const DriveSignals& s, const DriveState& state) {
  return {s.current_a,  s.current_b,        s.voltage_a,         s.voltage_b,
          s.current_d,  s.current_q,        s.theta_cmd,         s.omega_cmd,
          s.torque_em,  s.torque_detent,    s.torque_total,      s.load_angle,
          s.lost_steps, state.energy_input, state.energy_copper, state.energy_mechanical,
          s.theta_meas, s.omega_est};
}

}  // namespace mjstepper
