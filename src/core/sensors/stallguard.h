// StallGuard and CoolStep (SPEC §8): Trinamic's sensorless load measurement and the current
// scaling it drives, as a documented model (Trinamic's algorithm is not published).
//
// What the chip measures: the back-EMF at the coil current's zero crossing (TMC5160 datasheet
// §11 "StallGuard2 Load Measurement": "the measurement is based on the motor's back EMF ... At
// maximum motor load, the value goes to zero or near to zero. This corresponds to a load angle of
// 90° between the magnetic field of the coils and magnets in the rotor"). A phase's back-EMF is
// Km·ω times a sinusoid of the rotor's electrical angle (S-2); where that phase's current
// crosses zero, it is Km·ω·cos δi, with δi = arg(i·e^{−jNrθ}) the angle between the current
// vector and the rotor (τm = Km·|i|·sin δi, S-4). So the model reads
//   e⊥ = Km·|ω|·cos δi                                    (V; 0 at the pull-out angle δi = 90°)
//   StallGuard4 (TMC2209, StealthChop):  SG_RESULT = clamp(510·e⊥/V_sg, 0, 510),
//                                        stall when SG_RESULT ≤ 2·SGTHRS (TMC2209 §11)
//   StallGuard2 (TMC2130/5160, SpreadCycle): SG_RESULT = clamp(1023·e⊥/V_sg + 16·SGT, 0, 1023),
//                                        stall when SG_RESULT = 0; "a higher [SGT] makes
//                                        StallGuard2 less sensitive and requires more torque to
//                                        indicate a stall" (TMC2130 §14)
// updated once per full step, at the current's zero crossing ("updated once per full step",
// TMC5160 §11), from the rotor's speed and the current vector there. V_sg, the back-EMF that
// reads full scale, is this model's calibration (an estimate: 2 V puts a NEMA 17 at Klipper's
// homing speed, half a turn per second, near 150 of 510); the factor 16 per SGT step spreads
// −64..63 over the 0..1023 range.
// Limits of the model: no dependence on the current's magnitude or the chopper's duty (the chip's
// reading changes with both, and its SpreadCycle measurement fails when the back-EMF nears the
// supply), no measurement noise, and cos δi of the current at the measuring tick (the
// chopper's ripple included), not of a current averaged over the step.
// The blind region: below the speed the chip's TCOOLTHRS sets (here `stallguard_min_speed`),
// the stall flag and CoolStep are off; Klipper sets it for homing and warns that "sensorless
// homing ... may not work at speeds below 10 RPM" (too little back-EMF), where e⊥ of a free
// rotor is already below a stall threshold tuned at the homing speed.
//
// CoolStep (TMC2209 §12): after each measurement, the current scale rises by SEUP steps (1, 2, 4
// or 8 of 1/32) when SG_RESULT < 32·SEMIN, and falls by one step after 32, 8, 2 or 1 (SEDN)
// measurements ≥ 32·(SEMIN + SEMAX + 1), between 1/2 or 1/4 (SEIMIN) and 1; SEMIN = 0 turns it
// off.
#ifndef MJSTEPPER_CORE_SENSORS_STALLGUARD_H_
#define MJSTEPPER_CORE_SENSORS_STALLGUARD_H_

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/attributes.h"
#include "core/motor.h"

namespace mjstepper {

inline constexpr AttributeSpec kAttrSgt{
    "sgt", "integer", "0", "—",
    "StallGuard2 (`spreadcycle` on `driver` = `tmc2130`, `tmc5160`): SGT, −64..63; SG_RESULT "
    "gains 16·SGT, and a stall is SG_RESULT = 0, so a higher SGT needs more load to stall."};
inline constexpr AttributeSpec kAttrSgthrs{
    "sgthrs", "integer", "0", "—",
    "StallGuard4 (`stealthchop` on `driver` = `tmc2209`): SGTHRS, 0..255; a stall is SG_RESULT "
    "≤ 2·SGTHRS."};
inline constexpr AttributeSpec kAttrStallguardVoltage{
    "stallguard_voltage", "real", "2", "V",
    "The back-EMF at the current's zero crossing, Km·|ω|·cos δi, that reads SG_RESULT's full "
    "scale: this model's calibration (see the `stallguard` signal). In [0.01, 1000]."};
inline constexpr AttributeSpec kAttrStallguardMinSpeed{
    "stallguard_min_speed", "real", "1.0472 (10 r/min)", "rad/s",
    "TCOOLTHRS as a speed: below this commanded rotor speed the stall flag and CoolStep are off "
    "(the chip's blind region; Klipper: sensorless homing fails below about 10 r/min). >= 0."};
inline constexpr AttributeSpec kAttrSemin{
    "semin", "integer", "0 (CoolStep off)", "—",
    "CoolStep: SEMIN 0..15; the current rises when SG_RESULT < 32·SEMIN. 0: CoolStep off."};
inline constexpr AttributeSpec kAttrSemax{
    "semax", "integer", "0", "—",
    "CoolStep: SEMAX 0..15; the current falls when SG_RESULT ≥ 32·(SEMIN + SEMAX + 1)."};
inline constexpr AttributeSpec kAttrSeup{
    "seup", "integer", "0", "—",
    "CoolStep: SEUP 0..3, the rise per measurement: 1, 2, 4, 8 steps of 1/32."};
inline constexpr AttributeSpec kAttrSedn{
    "sedn", "integer", "0", "—",
    "CoolStep: SEDN 0..3, measurements per one-step fall: 32, 8, 2, 1."};
inline constexpr AttributeSpec kAttrSeimin{
    "seimin", "integer", "0", "—", "CoolStep: SEIMIN 0..1, the least scale: 1/2 (0) or 1/4 (1)."};

/// The StallGuard model of one drive, and its CoolStep; version 0: the drive has none.
struct StallGuard {
  int version = 0;            ///< 0: none; 2: StallGuard2; 4: StallGuard4
  double full_scale_emf = 2;  ///< V_sg, V
  int sgt = 0;                ///< StallGuard2 offset, −64..63
  int sgthrs = 0;             ///< StallGuard4 threshold, 0..255
  double min_speed = 2 * 3.14159265358979323846 * 10 / 60;   ///< rad/s (TCOOLTHRS)
  int semin = 0, semax = 0, seup = 0, sedn = 0, seimin = 0;  ///< CoolStep registers

  double FullScale() const { return version == 2 ? 1023.0 : 510.0; }

  /// SG_RESULT for a rotor turning at ω (rad/s) at electrical phasor z = e^{jNrθ}, with the
  /// current vector i (A): the model above.
  double Result(double torque_constant, double omega, PhaseVector current, PhaseVector z) const {
    const double magnitude = std::abs(current);
    const double cos_delta = magnitude > 0 ? (current * std::conj(z)).real() / magnitude : 0.0;
    const double emf = torque_constant * std::abs(omega) * cos_delta;  // e⊥, V
    const double raw = FullScale() * emf / full_scale_emf + (version == 2 ? 16.0 * sgt : 0.0);
    return std::clamp(std::round(raw), 0.0, FullScale());
  }

  /// Whether SG_RESULT flags a stall at a commanded speed ω_cmd (rad/s).
  bool Stall(double result, double omega_cmd) const {
    if (version == 0 || std::abs(omega_cmd) < min_speed) return false;
    return version == 2 ? result <= 0 : result <= 2.0 * sgthrs;
  }

  /// CoolStep after one measurement: the new scale (of the run current) and count of high
  /// readings, from the old ones.
  void CoolStep(double result, double omega_cmd, double* scale, double* high_count) const {
    if (semin == 0 || std::abs(omega_cmd) < min_speed) return;
    const double least = seimin == 0 ? 0.5 : 0.25;
    if (result < 32.0 * semin) {
      *scale = std::min(1.0, *scale + (1 << seup) / 32.0);
      *high_count = 0;
    } else if (result >= 32.0 * (semin + semax + 1)) {
      constexpr int kPerStep[4] = {32, 8, 2, 1};
      if (++*high_count >= kPerStep[sedn]) {
        *scale = std::max(least, *scale - 1 / 32.0);
        *high_count = 0;
      }
    }
  }

  static std::vector<const AttributeSpec*> Attributes() {
    return {&kAttrSgt,
            &kAttrSgthrs,
            &kAttrStallguardVoltage,
            &kAttrStallguardMinSpeed,
            &kAttrSemin,
            &kAttrSemax,
            &kAttrSeup,
            &kAttrSedn,
            &kAttrSeimin};
  }
  /// The chip's StallGuard `version` (0: none) configured from the attributes.
  static StallGuard FromAttributes(const AttributeSource& a, int version) {
    // A register the chip does not have in this drive is a mistake, not a silent no-op.
    for (const AttributeSpec* spec : Attributes()) {
      const bool unused = version == 0 || (version == 2 && spec == &kAttrSgthrs) ||
                          (version == 4 && spec == &kAttrSgt);
      if (unused && a.Raw(*spec)) {
        ThrowBad(*spec, *a.Raw(*spec),
                 version == 0 ? "this drive has no StallGuard: StallGuard2 is SpreadCycle's on "
                                "driver = tmc2130 or tmc5160, StallGuard4 StealthChop's on tmc2209"
                              : fmt::format("not a register of StallGuard{}", version));
      }
    }
    StallGuard g;
    g.version = version;
    g.full_scale_emf = a.Real(kAttrStallguardVoltage, g.full_scale_emf, 0.01, 1000.0);
    g.sgt = a.Integer(kAttrSgt, 0, -64, 63);
    g.sgthrs = a.Integer(kAttrSgthrs, 0, 0, 255);
    g.min_speed = a.Real(kAttrStallguardMinSpeed, g.min_speed, 0.0, 1e6);
    g.semin = a.Integer(kAttrSemin, 0, 0, 15);
    g.semax = a.Integer(kAttrSemax, 0, 0, 15);
    g.seup = a.Integer(kAttrSeup, 0, 0, 3);
    g.sedn = a.Integer(kAttrSedn, 0, 0, 3);
    g.seimin = a.Integer(kAttrSeimin, 0, 0, 1);
    return g;
  }
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_SENSORS_STALLGUARD_H_
