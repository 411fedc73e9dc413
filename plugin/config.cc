#include "config.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <optional>
#include <stdexcept>

#include "core/averaged_current_loop.h"
#include "core/presets.h"

namespace mjstepper::plugin {
namespace {

using Rule = AttributeSource::Rule;

// The drive's own attributes (controllers declare theirs in their files).
constexpr AttributeSpec kAttrMotor{
    "motor", "name", "`tsui2009`", "—",
    "Preset (SPEC §4): `tsui2009` (hybrid 1.8°, 3 A, 1.27 N·m, detent h = 4, 2, 1), `kim2016` "
    "(PM, PK268-02B class, reconstructed: Kim's Table 1 is lost), `bodson1993`; or a catalogue "
    "motor from its datasheet (SPEC §8, Km = T_H/(√2·I_r), Kd4 = T_det): `qsh4218_35`, "
    "`qsh4218_41`, `qsh4218_51` (NEMA 17, 1.8°), `qsh5718_51`, `qsh5718_76` (NEMA 23, 1.8°), "
    "`17hm19_2004s` (NEMA 17, 0.9°), `17hs19_2004s1`, and PAROL6's `17hs24_2104s`, "
    "`17hs16_2004s1`, `17hs08_1004s` (NEMA 17, 1.8°); see \"Motor presets\"."};
constexpr AttributeSpec kAttrDrive{
    "drive", "name",
    "`current_microstep`; with a `driver` chip, the chip's (`spreadcycle`, "
    "`chopper`)",
    "—", "The controller; see \"Drives\" above."};
constexpr AttributeSpec kAttrInput{
    "input", "name", "`position`", "—",
    "`position`: ctrl is θcmd in rad (rotor side), or the target angle when `profile` is set. "
    "`velocity`: ctrl is dθcmd/dt in rad/s; the drive integrates θcmd, starting at the rotor's "
    "angle. `steps` (STEP/DIR, SPEC §8): ctrl is the motion controller's microstep count n at "
    "the drive's `microsteps` M (an integer, as a driver counts pulses; θcmd = n·2π/(4·Nr·M)); "
    "the pulses from one step's count to the next are spread evenly over the step. A chip drive "
    "(`chopper`, `spreadcycle`, `stealthchop`) moves its table at each pulse's own time, an event "
    "of its own; `current_microstep` and `ideal_current` read the count at their interrupts (the "
    "DSP's timing). Needs a drive with a microstep table (`chopper`, `spreadcycle`, "
    "`stealthchop`, or `current_microstep`/`ideal_current` with `microsteps` ≥ 1)."};
constexpr AttributeSpec kAttrRotorTeeth{"rotor_teeth", "integer", "preset (50)", "—",
                                        "Nr (\"pole pairs\" in Tsui): x = Nr·θ, full step "
                                        "2π/(4·Nr)."};
constexpr AttributeSpec kAttrResistance{
    "resistance", "real", "preset (0.9)", "Ω",
    "R per phase; > 0. With `heat` on, R at 20 °C (R20 of R(T), as datasheets print it)."};
constexpr AttributeSpec kAttrInductance{"inductance", "real", "preset (2.2e-3)", "H",
                                        "L per phase; > 0."};
constexpr AttributeSpec kAttrRotorInertia{
    "rotor_inertia", "real", "preset (0.36e-4)", "kg·m²",
    "J, the rotor's inertia, >= 0. The actuator's `armature` must be at least J (MuJoCo reflects "
    "it through gear²), or loading fails naming the value to add; 0: the model carries the rotor "
    "itself (a body, or the joint's armature), nothing is checked."};
constexpr AttributeSpec kAttrTorqueConstant{
    "torque_constant", "real", "preset (0.3)", "N·m/A (= V·s/rad)",
    "Km, torque and back-EMF constant; > 0. Datasheet: Km = T_H/(√2·I_rated). With `heat` on, "
    "Km at 20 °C."};
constexpr AttributeSpec kAttrDetent{
    "detent", "list", "preset", "—, N·m, rad",
    "Detent harmonics of S-5 as triplets `order amplitude phase` separated by `;`, e.g. `4 0.006 "
    "0; 2 0.014 3.1416; 1 0.011 1.5708`, or `none`."};
constexpr AttributeSpec kAttrBusVoltage{
    "bus_voltage", "real", "48; 24 with a `driver` chip (a printer's supply)", "V",
    "Vbus of the bridges: \\|va\\|, \\|vb\\| ≤ Vbus (S-13), or the SVPWM range (S-14); every "
    "drive is limited by it. Tsui needs ≥ 19 V at 250 r/min, ≥ 145 V at 1920 r/min; Kim's "
    "supply is 24 V. With a `driver` chip, at most the chip's supply range (TMC2209 29 V, "
    "TMC2130 46 V, TMC5160 60 V, A4988 35 V, DRV8825 45 V)."};
constexpr AttributeSpec kAttrIsrPeriod{
    "isr_period", "real", "50e-6", "s",
    "Interrupt (control) period T: sample and compute at t_k = k·T (absolute time), S-15. May be "
    "much shorter than the timestep (1e-6: 1 MHz, Kim's continuous-time designs) or longer; at "
    "most 10 000 interrupts per timestep (a step runs each one)."};
constexpr AttributeSpec kAttrComputeDelay{
    "compute_delay", "real", "25e-6", "s",
    "D: the voltage computed at t_k applies from t_k + D and is held until t_{k+1} + D (S-15). "
    "0 ≤ D < T."};
constexpr AttributeSpec kAttrPowerStage{
    "power_stage", "name", "`h_bridge`", "—",
    "`h_bridge`: two full bridges, \\|va\\|, \\|vb\\| ≤ Vbus (S-13). `svpwm`: Tsui's three legs "
    "with a common return (S-14): linear while max(va, vb, 0) − min(va, vb, 0) ≤ Vbus (a rotating "
    "vector up to Vbus/√2); beyond, (va, vb) is scaled down keeping its direction and the PI "
    "integrators hold (anti-windup)."};
constexpr AttributeSpec kAttrEncoderCounts{
    "encoder_counts", "integer", "preset (4000, 32000)", "counts/rev",
    "Encoder (S-16): θmeas = floor(θ·cpr/2π)·2π/cpr, the position feedback of every drive that "
    "reads one. 0: ideal."};
constexpr AttributeSpec kAttrVelocityCutoff{
    "velocity_cutoff", "real", "32", "Hz",
    "Corner of the first-order low-pass after the backward difference of θmeas at every "
    "interrupt (S-17)."};
constexpr AttributeSpec kAttrSpeedFeedback{
    "speed_feedback", "name", "`estimate` (Tsui's drives), `exact` (`stmms`, `foc`)", "—",
    "ωfb handed to the controller: `estimate` is S-17; `exact` is the rotor's true speed (the "
    "ideal sensor of Kim's simulations)."};
constexpr AttributeSpec kAttrStepTimes{
    "step_times", "file", "none", "—",
    "With `input` = `steps`: a file of STEP/DIR pulse times, one per line (a time in s, then "
    "optionally the direction +1 or -1; the format of `steps(FILE)`; a path as given, relative "
    "to the working folder, read whenever MuJoCo makes an mjData), counted on "
    "from the whole microstep the drive rests at. Each pulse moves the count at its own time, "
    "whatever the timestep, as a chip sees it; ctrl is then unused. Without it, ctrl is the "
    "count at each step's end and a step's pulses are spread evenly over it (up to half a step "
    "from their own times)."};
constexpr AttributeSpec kAttrProfile{
    "profile", "name", "`none`", "—",
    "The drive's own ramp generator: `none` (ctrl is the command), `trapezoid` or `scurve` "
    "(jerk-limited): ctrl is the target angle and the drive moves θcmd there within "
    "`profile_speed`, `profile_accel` (and `profile_jerk`), giving θd, θ̇d, θ̈d exactly to the "
    "controller. Needs `input` = `position`. Kim's trajectory (SPEC §4): `trapezoid`, speed "
    "6.2832, accel 12.566, start 0.5, ctrl 15.708."};
constexpr AttributeSpec kAttrProfileSpeed{"profile_speed", "real", "6.2832 (1 rev/s)", "rad/s",
                                          "Speed limit of the profile (rotor side); > 0."};
constexpr AttributeSpec kAttrProfileAccel{
    "profile_accel", "real", "12.566", "rad/s²",
    "Acceleration limit; ramp time = `profile_speed`/`profile_accel`. > 0."};
constexpr AttributeSpec kAttrProfileJerk{"profile_jerk", "real", "1000", "rad/s³",
                                         "Jerk limit of `scurve`; > 0."};
constexpr AttributeSpec kAttrProfileStart{"profile_start", "real", "0", "s",
                                          "No move starts before this simulation time."};
// The gear train (SPEC §12, src/core/transmission.h).
constexpr AttributeSpec kAttrEfficiency{
    "efficiency", "real", "1", "—",
    "The gear train's efficiency driven forward (motor → load, τ·ω > 0): the load receives "
    "efficiency·τ. A single planetary stage about 0.90 (cheap) to 0.95-0.98 (precision), a timing-"
    "belt stage 0.95-0.98 (models/README.md, \"Gear trains\"); its Coulomb and viscous friction "
    "are the joint's `frictionloss` and `damping`. Within ±1 rad/s of the rotor at rest it comes "
    "in "
    "linearly. In [0.01, 1]."};
constexpr AttributeSpec kAttrBackdriveEfficiency{
    "backdrive_efficiency", "real", "`efficiency`", "—",
    "The gear train's efficiency driven back (load → motor, τ·ω < 0: lowering a load, braking): "
    "the load must exert τ/backdrive_efficiency. Below `efficiency` for gear meshes (2 − "
    "1/efficiency for a mesh whose loss is its friction: an estimate). In [0.01, 1]."};
// The carriage of a rotary joint (issue 32, item 3; src/core/transmission.h).
constexpr AttributeSpec kAttrPulleyTeeth{
    "pulley_teeth", "integer", "none", "teeth",
    "A timing-belt pulley on the stepper's hinge joint: its tooth count. With `belt_pitch` it "
    "declares the carriage, which moves teeth × pitch per turn of the joint (Klipper's "
    "`rotation_distance`: 40 mm for a GT2 20-tooth pulley), so that profiles (`--ctrl`), "
    "`sweep`, `pullout`, `map`, `size` and the log speak mm, mm/s and N at the carriage "
    "(README, \"Linear axes\"). On a hinge joint only (a slide's or a tendon's gear is already "
    "rad per metre); where the hinge winds a fixed tendon with a slide joint in it (a belt), the "
    "tendon's coefficient must be the pulley's pitch radius, teeth × pitch / 2π, within 0.1 %. "
    "In [1, 1000]; not with `lead`."};
constexpr AttributeSpec kAttrBeltPitch{
    "belt_pitch", "real", "0.002 (GT2)", "m",
    "The belt's tooth pitch, with `pulley_teeth`: 2 mm for GT2 (Gates PowerGrip GT2, 2MGT), "
    "3 mm for GT2-3M, 5 mm for HTD-5M and T5. In [0.0005, 0.05]."};
constexpr AttributeSpec kAttrLead{
    "lead", "real", "none", "m",
    "A lead screw (or any carriage) on the stepper's hinge joint: the travel per turn of the "
    "joint (a screw's lead: 8 mm for the Tr8×8 of most printers' Z, 2 mm for Tr8×2; π·d for a "
    "rack's pinion of pitch diameter d). The same use as `pulley_teeth`, not with it. In "
    "[1e-5, 10]."};
// Heat (SPEC §8, src/core/thermal.h).
constexpr AttributeSpec kAttrHeat{
    "heat", "name", "`auto`", "—",
    "Winding and housing temperatures (SPEC §8): a two-node network, winding (`heat_capacity_"
    "winding`) → `thermal_resistance_winding` → housing (`heat_capacity_housing`) → "
    "`thermal_resistance_housing` → ambient, heated by the copper loss R(T)·(ia² + ib²) (iron "
    "loss is not modelled), integrated exactly over each step; R(T) = R·(1 + α·(T − 20 °C)) and "
    "Km(T) = Km·(1 + β·(T − 20 °C)) at the winding temperature, held over a step (`resistance` "
    "and `torque_constant` are then the values at 20 °C). The drive's electronics keep the "
    "nominal R and Km. `auto`: on when the four network constants are known (the catalogue "
    "presets carry them; see \"Motor presets\") and the drive has windings (not "
    "`ideal_current`); `on`: the same, an error if one is missing; `off`: R and Km fixed. "
    "Signals `winding_temperature`, `housing_temperature`, `resistance`; a warning when the "
    "winding passes `insulation_class`."};
constexpr AttributeSpec kAttrAmbientTemperature{
    "ambient_temperature", "real", "25", "°C",
    "T_a, the air around the motor (`heat`). In [−50, 150]."};
constexpr AttributeSpec kAttrInitialTemperature{
    "initial_temperature", "real", "`ambient_temperature`", "°C",
    "Winding and housing temperature when the drive starts (load, reset, keyframe: the plugin "
    "state restarts there). In [−50, 400]."};
// The network's bounds (issue 33: 1e6 K/W on 1e-6 J/K put a winding at 1.4e7 °C after 1 s): the
// catalogue presets span R_wh 0.56-1.2 and R_ha 2.6-6 K/W, C_w 10-46 and C_h 200-830 J/K
// (src/core/presets.cc); the bounds leave two decades beyond on each side, from a NEMA 8 in still
// air to a NEMA 34 on a machine's frame.
constexpr double kLeastThermalResistance = 0.01, kMostThermalResistance = 100;  // K/W
constexpr double kLeastHeatCapacity = 0.1, kMostHeatCapacity = 1e5;             // J/K
constexpr AttributeSpec kAttrThermalResistanceWinding{
    "thermal_resistance_winding", "real", "preset", "K/W",
    "R_wh, winding → housing (`heat`); in [0.01, 100]. Catalogue presets: fitted to the "
    "datasheet's thermal time constants and temperature rise (`src/core/presets.cc`)."};
constexpr AttributeSpec kAttrThermalResistanceHousing{
    "thermal_resistance_housing", "real", "preset", "K/W",
    "R_ha, housing → ambient (`heat`); in [0.01, 100]. The steady winding rise is "
    "P·(R_wh + R_ha)."};
constexpr AttributeSpec kAttrHeatCapacityWinding{
    "heat_capacity_winding", "real", "preset", "J/K",
    "C_w, the winding's heat capacity (`heat`); in [0.1, 1e5]."};
constexpr AttributeSpec kAttrHeatCapacityHousing{
    "heat_capacity_housing", "real", "preset", "J/K",
    "C_h, the housing's (stator, end caps, what it is mounted on) heat capacity (`heat`); in "
    "[0.1, 1e5]."};
constexpr AttributeSpec kAttrInsulationClass{
    "insulation_class", "name", "`B`", "—",
    "The winding's thermal class (IEC 60085): `A` 105 °C, `E` 120 °C, `B` 130 °C (the "
    "catalogue motors'), `F` 155 °C, `H` 180 °C. A winding that passes it is said once per "
    "actuator through `mju_warning`; the simulation goes on (`heat`)."};
constexpr AttributeSpec kAttrResistanceCoefficient{
    "resistance_temperature_coefficient", "real", "0.00393", "1/K",
    "α of R(T) (`heat`): 0.00393 for annealed copper (IEC 60028). In [0, 0.01]."};
constexpr AttributeSpec kAttrTorqueConstantCoefficient{
    "torque_constant_temperature_coefficient", "real", "−0.0011", "1/K",
    "β of Km(T) (`heat`): the magnet's remanence, −0.09 to −0.12 %/K for sintered NdFeB "
    "(hybrid steppers), about −0.2 %/K for ferrite. In [−0.002, 0.002]."};
constexpr AttributeSpec kAttrGauge{
    "gauge", "name", "`on`", "—",
    "`on`: draw the load-angle gauge on the rotor in every MuJoCo scene (viewer, renders), just "
    "beyond the rotor body's geoms along the joint axis on the side the camera looks from (on a "
    "slide joint, on the carriage's face towards the camera, the slide's axis its reference, "
    "its size 0.3 of the carriage's bounding radius): a "
    "long thin green arrow for the commanded electrical angle and a short thick magenta one for "
    "the rotor's; the angle between them is δ, and a magenta arrow sweeping full turns is lost "
    "steps. Its size is the rotor body's radius, kept within 2.5-50 % of the model's extent "
    "(`stat.extent`), so that a small pulley's gauge reads at the scene's scale. `off`: draw "
    "nothing."};

constexpr AttributeSpec kAttrCoupling{
    "coupling", "name", "`consistent`", "—",
    "How the torque is handed to MuJoCo each step (SPEC §10, `src/core/coupling.h`). "
    "`consistent`: the torque that makes MuJoCo's Euler step the exact map of the linearised "
    "rotor (its stiffness −∂τ/∂θ this step, the rotor-side inertia and the other forces' "
    "acceleration read from `mjData`), so the rotor rings at its own frequency at coarse "
    "timesteps (ωn·h up to about 1) and static equilibria stay where they are. `explicit`: the "
    "torque at the step's start, whose ring is fast by (ωn·h)²/24. `substepped`: the rotors and "
    "their drives integrated in sub-steps within MuJoCo's step against the load as `mjData` "
    "presents it at the step's start (`src/core/substep.h`), their end angles handed to MuJoCo "
    "as its positions and their end speeds kept in the plugin's state, so the ring, the ripple "
    "and slips are resolved at coarse timesteps; Euler, implicit and implicitfast only, no "
    "actuator `dyntype`, and the model's steppers coupled one way (`consistent` or "
    "`substepped`, `explicit` beside either). Its fidelity is measured up to 2 ms "
    "(`docs/coupling.md`): where no mode bounds the step, `info` recommends at most that and "
    "`info` and `run` note a coarser step."};

constexpr AttributeSpec kAttrFidelity{
    "fidelity", "name", "`switching`", "—",
    "How the drive's current regulation is simulated (SPEC §11). `switching`: every interrupt and "
    "every bridge event, the reference. `averaged`: a chopper's cycle average "
    "(`src/core/averaged_bridge.h`): each phase holds its target by the deadbeat voltage within "
    "the bus and slews to a new one at the bus's rate, with STEP/DIR edges exact; its cost does "
    "not grow with the chopper frequency or the clock. `stealthchop`: the chip's counters "
    "(TSTEP, the autoscale regulator) advanced by the time between events, one voltage per span "
    "instead of one per interrupt; at standstill a span lasts to the regulator's next step. "
    "`voltage_microstep`: K(5)'s rotating voltage itself, continuous, lagging by D + T/2 as its "
    "interrupts' staircase does, on the exact winding solution over each step. "
    "`current_microstep`: the PI loop's continuous closed-loop response, each current part "
    "meeting the loop's own sampled, held and delayed feedback at its frequency "
    "(`src/core/averaged_current_loop.h`), exact over each step; where the bus cuts the request "
    "it runs the interrupts. `servo` and `identification`: the same loop in the encoder's frame, "
    "the position loop of T(19) still run at each of its own ticks. `ideal_current` has no "
    "clock: it is the same in both. `stmms` and `foc`: K(28)'s or K(33)'s voltage from the law's "
    "continuous τd, a polynomial over each step, lagging by D + T/2, on the exact winding "
    "solution in the rotor's frame (`src/core/averaged_feed_forward.h`), with `encoder_counts` 0, "
    "`speed_feedback` exact and (`foc`) `foc_derivative` analytic; where the voltage might leave "
    "the stage's linear range it runs the interrupts."};

const std::vector<const AttributeSpec*>& DriveAttributes() {
  static const std::vector<const AttributeSpec*> list = {&kAttrMotor,
                                                         &kAttrDrive,
                                                         &kAttrInput,
                                                         &kAttrStepTimes,
                                                         &kAttrRotorTeeth,
                                                         &kAttrResistance,
                                                         &kAttrInductance,
                                                         &kAttrTorqueConstant,
                                                         &kAttrRotorInertia,
                                                         &kAttrDetent,
                                                         &kAttrBusVoltage,
                                                         &kAttrIsrPeriod,
                                                         &kAttrComputeDelay,
                                                         &kAttrPowerStage,
                                                         &kAttrEncoderCounts,
                                                         &kAttrVelocityCutoff,
                                                         &kAttrSpeedFeedback,
                                                         &kAttrProfile,
                                                         &kAttrProfileSpeed,
                                                         &kAttrProfileAccel,
                                                         &kAttrProfileJerk,
                                                         &kAttrProfileStart,
                                                         &kAttrEfficiency,
                                                         &kAttrBackdriveEfficiency,
                                                         &kAttrPulleyTeeth,
                                                         &kAttrBeltPitch,
                                                         &kAttrLead,
                                                         &kAttrHeat,
                                                         &kAttrAmbientTemperature,
                                                         &kAttrInitialTemperature,
                                                         &kAttrThermalResistanceWinding,
                                                         &kAttrThermalResistanceHousing,
                                                         &kAttrHeatCapacityWinding,
                                                         &kAttrHeatCapacityHousing,
                                                         &kAttrInsulationClass,
                                                         &kAttrResistanceCoefficient,
                                                         &kAttrTorqueConstantCoefficient,
                                                         &kAttrGauge,
                                                         &kAttrCoupling,
                                                         &kAttrFidelity};
  return list;
}

// A number in [low, high] if set (the attribute's own error otherwise), else `fallback`.
double RealWithin(const AttributeSource& a, const AttributeSpec& spec, double fallback, double low,
                  double high) {
  const double value = a.Real(spec, fallback, Rule::kAny);
  if (!(value >= low && value <= high)) {
    ThrowBad(spec, a.Raw(spec).value_or(fmt::format("{:g}", value)),
             fmt::format("must be in [{:g}, {:g}] ({})", low, high, spec.unit));
  }
  return value;
}

// Heat (SPEC §8): on, off or by what is known (kAttrHeat), with its attributes.
std::optional<HeatParams> ParseHeat(const AttributeSource& a, const Preset& preset,
                                    const std::string& drive) {
  const std::string mode = a.Choice(kAttrHeat, "auto", {"auto", "on", "off"});
  ThermalParams net = preset.thermal.value_or(ThermalParams{});  // zeros: unknown
  const std::pair<const AttributeSpec*, double*> constants[] = {
      {&kAttrThermalResistanceWinding, &net.resistance_winding},
      {&kAttrThermalResistanceHousing, &net.resistance_housing},
      {&kAttrHeatCapacityWinding, &net.capacity_winding},
      {&kAttrHeatCapacityHousing, &net.capacity_housing}};
  std::vector<std::string> missing;
  for (const auto& [spec, value] : constants) {
    const bool resistance = spec == constants[0].first || spec == constants[1].first;
    *value = a.Real(*spec, *value, resistance ? kLeastThermalResistance : kLeastHeatCapacity,
                    resistance ? kMostThermalResistance : kMostHeatCapacity);
    if (!(*value > 0)) missing.emplace_back(spec->name);
  }
  const bool windings = drive != "ideal_current";
  if (mode == "on" && !windings) {
    ThrowBad(kAttrHeat, "on", "drive ideal_current has no windings, so no copper loss to heat");
  }
  if (mode == "on" && !missing.empty()) {
    ThrowBad(kAttrHeat, "on",
             fmt::format("motor {} has no thermal network: give {}", preset.name,
                         fmt::join(missing, ", ")));
  }
  const bool on = mode == "on" || (mode == "auto" && missing.empty() && windings);
  const AttributeSpec* const heat_only[] = {
      &kAttrAmbientTemperature,       &kAttrInitialTemperature,    &kAttrThermalResistanceWinding,
      &kAttrThermalResistanceHousing, &kAttrHeatCapacityWinding,   &kAttrHeatCapacityHousing,
      &kAttrInsulationClass,          &kAttrResistanceCoefficient, &kAttrTorqueConstantCoefficient};
  if (!on) {
    for (const AttributeSpec* spec : heat_only) {
      if (const auto raw = a.Raw(*spec)) {
        const std::string why =
            mode == "off" ? "heat = off"
            : !windings   ? "heat off (drive ideal_current has no windings)"
                          : fmt::format("heat off (motor {} has no thermal network; give {})",
                                        preset.name, fmt::join(missing, ", "));
        ThrowBad(*spec, *raw, fmt::format("has no effect with {}", why));
      }
    }
    return std::nullopt;
  }
  HeatParams heat{.network = net};
  heat.ambient_temperature =
      RealWithin(a, kAttrAmbientTemperature, heat.ambient_temperature, -50, 150);
  heat.initial_temperature =
      RealWithin(a, kAttrInitialTemperature, heat.ambient_temperature, -50, 400);
  const std::string insulation = a.Choice(kAttrInsulationClass, "B", {"A", "E", "B", "F", "H"});
  heat.insulation_limit = insulation == "A"   ? 105
                          : insulation == "E" ? 120
                          : insulation == "F" ? 155
                          : insulation == "H" ? 180
                                              : 130;
  heat.resistance_coefficient =
      RealWithin(a, kAttrResistanceCoefficient, heat.resistance_coefficient, 0, 0.01);
  heat.torque_constant_coefficient = RealWithin(a, kAttrTorqueConstantCoefficient,
                                                heat.torque_constant_coefficient, -0.002, 0.002);
  return heat;
}

DriveConfig Parse(const AttributeSource& a) {
  DriveConfig c;
  const std::string motor = a.Raw(kAttrMotor).value_or("tsui2009");
  const std::optional<Preset> preset = FindPreset(motor);
  if (!preset) {
    ThrowBad(kAttrMotor, motor,
             fmt::format("unknown preset; known: {}", fmt::join(PresetNames(), ", ")));
  }
  c.motor = preset->motor;
  c.motor.rotor_teeth = a.Integer(kAttrRotorTeeth, c.motor.rotor_teeth, 1, 1000);
  c.motor.resistance = a.Real(kAttrResistance, c.motor.resistance, Rule::kPositive);
  c.motor.inductance = a.Real(kAttrInductance, c.motor.inductance, Rule::kPositive);
  c.motor.torque_constant = a.Real(kAttrTorqueConstant, c.motor.torque_constant, Rule::kPositive);
  c.motor.rotor_inertia = a.Real(kAttrRotorInertia, c.motor.rotor_inertia, Rule::kNonNegative);
  c.motor.detent = a.Harmonics(kAttrDetent).value_or(c.motor.detent);

  const std::string input = a.Choice(kAttrInput, "position", {"position", "velocity", "steps"});
  c.input = input == "velocity" ? InputMode::kVelocity
            : input == "steps"  ? InputMode::kSteps
                                : InputMode::kPosition;
  if (const auto path = a.Raw(kAttrStepTimes)) {
    if (c.input != InputMode::kSteps) {
      ThrowBad(kAttrStepTimes, *path, "needs input = steps (STEP/DIR pulses)");
    }
    try {
      c.step_times = std::make_shared<const StepTimes>(StepTimes::Read(*path));
    } catch (const std::invalid_argument& e) {
      ThrowBad(kAttrStepTimes, *path, e.what());
    }
  }
  // A driver chip (driver_chip.h) picks the drive and bounds the supply.
  const DriverChip* chip = FindDriver(a);
  c.bus_voltage = a.Real(kAttrBusVoltage, chip != nullptr ? 24.0 : c.bus_voltage, Rule::kPositive);
  if (chip != nullptr && c.bus_voltage > chip->max_bus_voltage) {
    ThrowBad(kAttrBusVoltage, *a.Raw(kAttrBusVoltage),
             fmt::format("exceeds {}'s supply range, at most {:g} V", chip->name,
                         chip->max_bus_voltage));
  }
  if (chip != nullptr && c.bus_voltage < chip->min_bus_voltage) {  // (the default 24 V never is)
    ThrowBad(kAttrBusVoltage, *a.Raw(kAttrBusVoltage),
             fmt::format("is below {}'s supply range, at least {:g} V", chip->name,
                         chip->min_bus_voltage));
  }
  c.isr_period = a.Real(kAttrIsrPeriod, c.isr_period, Rule::kPositive);
  c.compute_delay = a.Real(kAttrComputeDelay, c.compute_delay, Rule::kNonNegative);
  if (!(c.compute_delay < c.isr_period)) {
    ThrowBad(kAttrComputeDelay, a.Raw(kAttrComputeDelay).value_or("25e-6"),
             fmt::format("must be < isr_period = {} (s)", c.isr_period));
  }
  c.power_stage = a.Choice(kAttrPowerStage, "h_bridge", {"h_bridge", "svpwm"}) == "svpwm"
                      ? PowerStageKind::kThreeLegSvpwm
                      : PowerStageKind::kTwoHBridges;
  c.encoder_counts = a.Integer(kAttrEncoderCounts, preset->encoder_counts, 0, 1000000000);
  c.velocity_cutoff = a.Real(kAttrVelocityCutoff, c.velocity_cutoff, Rule::kPositive);
  if (const auto feedback = a.Raw(kAttrSpeedFeedback)) {
    c.speed_feedback = a.Choice(kAttrSpeedFeedback, "", {"estimate", "exact"}) == "exact"
                           ? SpeedFeedback::kExact
                           : SpeedFeedback::kEstimate;
  }
  const std::string profile = a.Choice(kAttrProfile, "none", {"none", "trapezoid", "scurve"});
  c.profile.kind = profile == "trapezoid" ? ProfileKind::kTrapezoid
                   : profile == "scurve"  ? ProfileKind::kSCurve
                                          : ProfileKind::kNone;
  c.profile.max_speed = a.Real(kAttrProfileSpeed, c.profile.max_speed, Rule::kPositive);
  c.profile.max_accel = a.Real(kAttrProfileAccel, c.profile.max_accel, Rule::kPositive);
  c.profile.max_jerk = a.Real(kAttrProfileJerk, c.profile.max_jerk, Rule::kPositive);
  c.profile.start_time = a.Real(kAttrProfileStart, 0.0, Rule::kNonNegative);
  c.transmission.efficiency = a.Real(kAttrEfficiency, 1.0, 0.01, 1.0);
  c.transmission.backdrive_efficiency =
      a.Real(kAttrBackdriveEfficiency, c.transmission.efficiency, 0.01, 1.0);
  c.transmission.pulley_teeth = a.Integer(kAttrPulleyTeeth, 0, 1, 1000);
  c.transmission.belt_pitch = a.Real(kAttrBeltPitch, 0.002, 0.0005, 0.05);
  c.transmission.lead = a.Real(kAttrLead, 0.0, 1e-5, 10.0);
  if (c.transmission.pulley_teeth > 0 && c.transmission.lead > 0) {
    ThrowBad(kAttrLead, *a.Raw(kAttrLead),
             fmt::format("the carriage is declared twice: pulley_teeth = {} and lead; give one "
                         "(a belt pulley: pulley_teeth, belt_pitch; a lead screw: lead)",
                         c.transmission.pulley_teeth));
  }
  if (a.Raw(kAttrBeltPitch) && c.transmission.pulley_teeth == 0) {
    ThrowBad(kAttrBeltPitch, *a.Raw(kAttrBeltPitch),
             "a belt's pitch needs its pulley: set pulley_teeth too");
  }
  if (c.transmission.pulley_teeth == 0) c.transmission.belt_pitch = 0;
  if (c.profile.kind != ProfileKind::kNone && c.input != InputMode::kPosition) {
    ThrowBad(kAttrProfile, profile,
             "a motion profile moves to a target angle: it needs input = position (ctrl in rad)");
  }
  for (const AttributeSpec* spec :
       {&kAttrProfileSpeed, &kAttrProfileAccel, &kAttrProfileJerk, &kAttrProfileStart}) {
    if (c.profile.kind == ProfileKind::kNone && a.Raw(*spec)) {
      ThrowBad(*spec, *a.Raw(*spec), "has no effect without profile = trapezoid or scurve");
    }
  }

  const std::vector<std::string> names = ControllerNames();
  const std::string drive =
      a.Choice(kAttrDrive, chip != nullptr ? chip->drive : "current_microstep", names);
  const DriveConstants constants{.rotor_teeth = c.motor.rotor_teeth,
                                 .resistance = c.motor.resistance,
                                 .inductance = c.motor.inductance,
                                 .torque_constant = c.motor.torque_constant,
                                 .isr_period = c.isr_period,
                                 .bus_voltage = c.bus_voltage};
  c.controller = MakeController(drive, a, c.motor, constants);
  if (a.Choice(kAttrFidelity, "switching", {"switching", "averaged"}) == "averaged") {
    if (const std::size_t harmonics = LoopSetpointHarmonics(c.controller);
        harmonics > kAveragedLoopHarmonics) {
      ThrowBad(kAttrDamping, a.Raw(kAttrDamping).value_or(""),
               fmt::format("switches on {} harmonics; fidelity = averaged carries at most {} "
                           "(use fewer, or fidelity = switching)",
                           harmonics, kAveragedLoopHarmonics));
    }
    c.fidelity = Fidelity::kAveraged;
    // Kim's laws averaged read the rotor's exact angle and speed (averaged_feed_forward.h).
    if (std::holds_alternative<Stmms>(c.controller) ||
        std::holds_alternative<HighGainFoc>(c.controller)) {
      if (c.encoder_counts != 0) {
        ThrowBad(kAttrEncoderCounts, fmt::format("{}", c.encoder_counts),
                 fmt::format("must be 0 with fidelity = averaged on drive {}, whose averaged law "
                             "reads the rotor's exact angle (or use fidelity = switching)",
                             drive));
      }
      if (c.speed_feedback.value_or(SpeedFeedback::kExact) != SpeedFeedback::kExact) {
        ThrowBad(kAttrSpeedFeedback, "estimate",
                 fmt::format("must be exact with fidelity = averaged on drive {}, whose averaged "
                             "law reads the rotor's exact speed (or use fidelity = switching)",
                             drive));
      }
    }
    if (const auto* foc = std::get_if<HighGainFoc>(&c.controller);
        foc != nullptr && foc->derivative != HighGainFoc::Derivative::kAnalytic) {
      ThrowBad(kAttrFocDerivative, "numeric",
               "must be analytic with fidelity = averaged: a difference over one control period "
               "is the clock itself (or use fidelity = switching)");
    }
  }
  c.heat = ParseHeat(a, *preset, drive);
  // An attribute the chosen controller does not read is a mistake, not a silent no-op.
  const std::vector<const AttributeSpec*> used = ControllerAttributes(drive);
  for (const AttributeSpec* spec : AllControllerAttributes()) {
    if (std::find(used.begin(), used.end(), spec) != used.end()) continue;
    if (const auto raw = a.Raw(*spec)) {
      ThrowBad(*spec, *raw,
               fmt::format("not read by drive {} (read by {})", drive,
                           fmt::join(ControllersReading(spec->name), ", ")));
    }
  }
  if (const auto* v = std::get_if<VoltageMicrostep>(&c.controller);
      v != nullptr && v->voltage_amplitude > c.bus_voltage) {
    ThrowBad(kAttrVoltageAmplitude, fmt::format("{}", v->voltage_amplitude),
             fmt::format("must be <= bus_voltage = {} for voltage_microstep (V)", c.bus_voltage));
  }
  // The averaged rotating voltage is never cut: on SVPWM (S-14) a phasor at 135° spans √2·Vmax.
  if (const auto* v = std::get_if<VoltageMicrostep>(&c.controller);
      v != nullptr && c.fidelity == Fidelity::kAveraged &&
      c.power_stage == PowerStageKind::kThreeLegSvpwm &&
      v->voltage_amplitude * std::numbers::sqrt2 > c.bus_voltage) {
    ThrowBad(kAttrVoltageAmplitude, fmt::format("{}", v->voltage_amplitude),
             fmt::format("must be <= bus_voltage/√2 = {:.4g} for voltage_microstep averaged on "
                         "power_stage svpwm (V), whose linear range the averaged voltage keeps; "
                         "or use fidelity switching",
                         c.bus_voltage / std::numbers::sqrt2));
  }
  if (c.input == InputMode::kSteps && Microsteps(c.controller) == 0) {
    ThrowBad(kAttrInput, "steps",
             fmt::format("counts microsteps: drive {} has no microstep table; use a chopper drive "
                         "(chopper, spreadcycle, stealthchop) or set microsteps >= 1",
                         drive));
  }
  // StealthChop's largest phase voltage is Vbus·255/256·248/256: at standstill it must drive
  // R·√2·run_current, or autoscale regulates toward a current the bridge cannot give.
  if (const auto* st = std::get_if<StealthChop>(&c.controller);
      st != nullptr && st->pwm_autoscale &&
      c.motor.resistance * st->table.peak_current >
          StealthChop::kFullScale * StealthChop::VoltsPerUnit(c.bus_voltage)) {
    ThrowBad(kAttrRunCurrent, a.Raw(kAttrRunCurrent).value_or(kAttrRunCurrent.default_text),
             fmt::format("at standstill StealthChop needs R·√2·run_current = {:.4g} V, more than "
                         "its largest phase voltage bus_voltage·255/256·248/256 = {:.4g} V",
                         c.motor.resistance * st->table.peak_current,
                         StealthChop::kFullScale * StealthChop::VoltsPerUnit(c.bus_voltage)));
  }
  Validate(c);  // the core's own checks, as a backstop
  // The start state respects the bus (S-13): the drive starts at rest holding its current with
  // v = R·i, which the bridges must be able to give. Named by the attribute that sets the current.
  const DriveState rest = Drive(c).Rest(0.0, 0.0, 0.0);
  const double needed = std::max(std::abs(rest.voltage_a), std::abs(rest.voltage_b));  // V
  if (needed > c.bus_voltage) {
    const bool by_hold = std::find(used.begin(), used.end(), &kAttrHoldCurrent) != used.end();
    const AttributeSpec& culprit = by_hold ? kAttrHoldCurrent : kAttrBusVoltage;
    ThrowBad(culprit, a.Raw(culprit).value_or(culprit.default_text),
             fmt::format("at rest the drive needs R·I = {:.4g} V on a phase, more than bus_voltage "
                         "= {:g} V: the motor would burn or the bridges saturate",
                         needed, c.bus_voltage));
  }
  return c;
}

}  // namespace

const std::vector<const AttributeSpec*>& AttributeTable() {
  static const std::vector<const AttributeSpec*> table = [] {
    std::vector<const AttributeSpec*> all = DriveAttributes();
    for (const AttributeSpec* spec : AllControllerAttributes()) all.push_back(spec);
    return all;
  }();
  return table;
}

const std::vector<const char*>& AttributeNames() {
  static const std::vector<const char*> names = [] {
    std::vector<const char*> list;
    for (const AttributeSpec* spec : AttributeTable()) list.push_back(spec->name);
    return list;
  }();
  return names;
}

std::variant<DriveConfig, std::string> ParseConfig(const AttributeReader& read) {
  try {
    return Parse(AttributeSource(read));
  } catch (const std::exception& e) {
    return std::string(e.what());
  }
}

std::variant<StepperConfig, std::string> ParseStepperConfig(const AttributeReader& read) {
  std::variant<DriveConfig, std::string> drive = ParseConfig(read);
  if (std::string* error = std::get_if<std::string>(&drive)) return *error;
  StepperConfig c{.drive = std::get<DriveConfig>(drive)};
  try {
    c.gauge = AttributeSource(read).Choice(kAttrGauge, "on", {"on", "off"}) == "on";
    const std::string coupling = AttributeSource(read).Choice(
        kAttrCoupling, "consistent", {"consistent", "explicit", "substepped"});
    c.coupling = coupling == "explicit"     ? Coupling::kExplicit
                 : coupling == "substepped" ? Coupling::kSubstepped
                                            : Coupling::kConsistent;
  } catch (const std::exception& e) {
    return std::string(e.what());
  }
  return c;
}

std::string AttributeTableMarkdown() {
  std::string out =
      "| Attribute | Type | Default | Unit | Read by | Meaning |\n"
      "|---|---|---|---|---|---|\n";
  const std::vector<const AttributeSpec*>& own = DriveAttributes();
  for (const AttributeSpec* spec : AttributeTable()) {
    const bool common = std::find(own.begin(), own.end(), spec) != own.end();
    const std::string readers =
        common ? "all" : fmt::format("{}", fmt::join(ControllersReading(spec->name), ", "));
    out += fmt::format("| `{}` | {} | {} | {} | {} | {} |\n", spec->name, spec->type,
                       spec->default_text, spec->unit, readers, spec->meaning);
  }
  return out;
}

std::string PresetTableMarkdown() {
  constexpr const char* kRow =
      "| `{}` | {} | {} | {:g} | {:g} | {:g} | {:g} | {:g} | {:g} | {:g} | {:.3g} | {} | {:g} | {} "
      "|\n";
  std::string out =
      "| `motor` | what | Nr | R (Ω) | L (H) | Km (N·m/A) | J (kg·m²) | B (N·m·s/rad) | Fs (N·m) | "
      "rated current (A) | holding torque √2·Km·I (N·m) | detent harmonics | τl (N·m) | heat: "
      "R_wh, R_ha (K/W); C_w, C_h (J/K) |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const std::string& name : PresetNames()) {
    const Preset preset = *FindPreset(name);
    const MotorParams& m = preset.motor;
    std::vector<std::string> detent;
    for (const DetentHarmonic& h : m.detent) {
      detent.push_back(fmt::format("h {}: {:g} N·m", h.order, h.amplitude));
    }
    const std::string heat =
        preset.thermal
            ? fmt::format("{:g}, {:g}; {:g}, {:g} ({})", preset.thermal->resistance_winding,
                          preset.thermal->resistance_housing, preset.thermal->capacity_winding,
                          preset.thermal->capacity_housing,
                          preset.thermal_sheet ? preset.thermal_sheet->source : "")
            : std::string("none (`heat` off unless all four are given)");
    const std::string what = preset.datasheet
                                 ? fmt::format("{}; from its datasheet: {}", preset.description,
                                               preset.datasheet->source)
                                 : preset.description;
    out += fmt::format(fmt::runtime(kRow), name, what, m.rotor_teeth, m.resistance, m.inductance,
                       m.torque_constant, m.rotor_inertia, m.viscous_damping, m.static_friction,
                       m.rated_current, std::sqrt(2.0) * m.torque_constant * m.rated_current,
                       detent.empty() ? "none" : fmt::format("{}", fmt::join(detent, ", ")),
                       m.load_torque, heat);
  }
  return out;
}

std::string DriveListMarkdown() {
  std::string out;
  ForEachControllerType(
      [&]<class C>() { out += fmt::format("- `{}`: {}\n", C::kName, C::kSummary); });
  return out;
}

}  // namespace mjstepper::plugin
