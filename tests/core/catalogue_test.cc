// Catalogue motors from their datasheets (presets.h, issue 17 item 4): each preset, driven by the
// `chopper` drive at its defaults (run_current = the rated current), holds the datasheet's rated
// current in both phases at the full-step position and gives the datasheet's holding torque at
// the load angle of peak torque (δ = 90° electrical, S-12).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/controllers/registry.h"
#include "core/drive.h"
#include "core/presets.h"

namespace mjstepper {
namespace {

TEST(CatalogueMotor, HoldingTorqueAndRatedCurrentReproduceTheDatasheet) {
  int catalogue = 0;
  for (const std::string& name : PresetNames()) {
    const Preset preset = *FindPreset(name);
    if (!preset.datasheet) continue;
    ++catalogue;
    const Datasheet& sheet = *preset.datasheet;
    DriveConfig c;
    c.motor = preset.motor;
    const DriveConstants k{.rotor_teeth = c.motor.rotor_teeth,
                           .resistance = c.motor.resistance,
                           .inductance = c.motor.inductance,
                           .torque_constant = c.motor.torque_constant,
                           .isr_period = c.isr_period};
    // The drive as a user gets it with no attribute but drive = chopper.
    c.controller =
        MakeController("chopper", AttributeSource([](const char*) { return ""; }), c.motor, k);
    c.bus_voltage = 24.0;
    c.isr_period = 10e-6;
    c.compute_delay = 0;
    c.encoder_counts = 0;
    const Drive drive(c);
    const int Nr = c.motor.rotor_teeth;
    EXPECT_EQ(Nr, sheet.step_angle == 0.9 ? 100 : 50) << name;  // 360°/(4·step angle)
    // Command at the full-step position ψ = π/4 (both phases at √2·I_r·cos 45° = I_r); rotor
    // 90° electrical behind it, where τm = Km·|i| peaks and the 4th detent harmonic is 0.
    const double theta_cmd = (std::numbers::pi / 4) / Nr;
    const double theta = theta_cmd - (std::numbers::pi / 2) / Nr;
    DriveState s = drive.Rest(0.0, theta, theta_cmd);
    double torque = 0, ia = 0, ib = 0;
    int n = 0;
    const double h = 1e-6;
    for (long j = 0; j < 5000; ++j) {
      ASSERT_EQ(drive.Advance(&s, j * h, (j + 1) * h, theta, theta_cmd), AdvanceStatus::kOk);
      if (j >= 3000) {
        torque += drive.Torque(s, theta);
        ia += s.current_a;
        ib += s.current_b;
        ++n;
      }
    }
    torque /= n, ia /= n, ib /= n;
    std::printf("%-14s T_H %.3f N·m: %.4f N·m; I_r %.2f A: phases %.4f, %.4f A\n", name.c_str(),
                sheet.holding_torque, torque, sheet.rated_current, ia, ib);
    // The chopper's mean current sits below its trip point by half its ripple, ≈ t_off·R·I/(2L):
    // at most 1.3 % here (qsh4218_35, R/L = 803 /s); the tolerance is 2 %.
    EXPECT_NEAR(torque, sheet.holding_torque, 0.02 * sheet.holding_torque) << name;
    EXPECT_NEAR(ia, sheet.rated_current, 0.02 * sheet.rated_current) << name;
    EXPECT_NEAR(ib, sheet.rated_current, 0.02 * sheet.rated_current) << name;
    // At least six common motors, NEMA 17 and 23, 0.9° and 1.8° (issue 17).
  }
  EXPECT_GE(catalogue, 6);
}

TEST(CatalogueMotor, EveryRowCitesItsDatasheet) {
  bool nema17 = false, nema23 = false, fine = false, coarse = false;
  for (const std::string& name : PresetNames()) {
    const Preset preset = *FindPreset(name);
    if (!preset.datasheet) continue;
    EXPECT_GT(std::string(preset.datasheet->source).size(), 20u) << name;
    nema17 |= preset.description.find("NEMA 17") != std::string::npos;
    nema23 |= preset.description.find("NEMA 23") != std::string::npos;
    fine |= preset.datasheet->step_angle == 0.9;
    coarse |= preset.datasheet->step_angle == 1.8;
  }
  EXPECT_TRUE(nema17 && nema23 && fine && coarse);
}

}  // namespace
}  // namespace mjstepper
