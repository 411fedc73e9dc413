// Issue 29, item 1: every drive with every motion profile and every driver chip loads and moves.
// A chip together with the drive's own profile failed to load ("Drive: 56 unit state doubles
// exceed 40"): the drive's state had a fixed room that the chopper units plus a profile's plan
// outgrew. The room is now computed from the registered units' own state types.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "core/controllers/driver_chip.h"
#include "core/controllers/registry.h"
#include "core/drive.h"
#include "test_model.h"

namespace mjstepper::testing {
namespace {

struct Combination {
  std::string chip;     // "" or a chip's name
  std::string drive;    // a registered controller
  std::string profile;  // none, trapezoid, scurve
};

// Every combination a user can write: with no chip every drive; each chip with its own drive and,
// on a Trinamic chip (one with a clock), StealthChop too; each with each profile.
std::vector<Combination> AllCombinations() {
  std::vector<std::pair<std::string, std::string>> drives;  // chip, drive
  for (const std::string& drive : ControllerNames()) drives.emplace_back("", drive);
  for (const DriverChip& chip : DriverChips()) {
    drives.emplace_back(chip.name, chip.drive);
    if (chip.clock_frequency > 0) drives.emplace_back(chip.name, "stealthchop");
  }
  std::vector<Combination> all;
  for (const auto& [chip, drive] : drives) {
    for (const char* profile : {"none", "trapezoid", "scurve"}) {
      all.push_back({chip, drive, profile});
    }
  }
  return all;
}

// The catalogue NEMA 17 of the issue's minimal model on a 1e-4 kg·m² load, a drive's profile to
// 1 rad at 20 rad/s and 400 rad/s².
std::string Model(const Combination& c) {
  std::string configs = Config("motor", "17hs19_2004s1") + Config("drive", c.drive);
  if (!c.chip.empty()) configs += Config("driver", c.chip);
  if (c.profile != "none") {
    configs += Config("profile", c.profile) + Config("profile_speed", "20") +
               Config("profile_accel", "400") + Config("profile_jerk", "20000");
  }
  const std::string actuator =
      fmt::format(R"(<plugin name="m1" joint="j1" plugin="mjstepper.stepper" armature="1e-4" )"
                  R"(damping="1e-3">{}</plugin>)",
                  configs);
  return RotorModel(
      actuator, "",
      R"(<plugin name="s" plugin="mjstepper.stepper" objtype="actuator" objname="m1"/>)", 1, 2e-5);
}

TEST(DriveMatrix, EveryDriveProfileAndChipLoadsAndMoves) {
  const std::vector<Combination> all = AllCombinations();
  // No chip × every drive, 5 chips × their drives (3 Trinamic ones also StealthChop), × 3 profiles.
  ASSERT_EQ(all.size(), 3 * (ControllerNames().size() + 5 + 3));
  int moved = 0;
  for (const Combination& c : all) {
    SCOPED_TRACE(fmt::format("driver={} drive={} profile={}", c.chip.empty() ? "none" : c.chip,
                             c.drive, c.profile));
    std::string error;
    const ModelPtr m = LoadModel(Model(c), &error);
    ASSERT_TRUE(m) << error;
    const DataPtr d(mj_makeData(m.get()));
    // ctrl 1 rad: the profile's target, or the position command itself.
    for (int k = 0; k < 2500; ++k) {  // 50 ms
      d->ctrl[0] = 1.0;
      mj_step(m.get(), d.get());
    }
    ASSERT_TRUE(std::isfinite(d->qpos[0]));
    const double theta_cmd = d->sensordata[kThetaCmd];
    ASSERT_TRUE(std::isfinite(theta_cmd));
    // A position drive goes to its command; one whose ctrl is no angle (identification) does not.
    if (std::abs(theta_cmd) > 0.1) ++moved;
  }
  // Every position drive moved its command toward 1 rad (identification, Kim's drives with
  // their own reference, may not).
  EXPECT_GE(moved, static_cast<int>(all.size()) - 3 * 6);
}

// The room is the largest unit state plus a profile's plan: the largest combination fits.
TEST(DriveMatrix, StateRoomIsTheLargestCombination) {
  int largest = 0;
  for (const Combination& c : AllCombinations()) {
    std::string error;
    const ModelPtr m = LoadModel(Model(c), &error);
    ASSERT_TRUE(m) << error;
    // Less the instance's copy of the constraint forces (a flag, one per dof; plugin/stepper.h).
    largest = std::max(largest, static_cast<int>(m->plugin_statenum[0] - 1 - m->nv));
  }
  const int core = sizeof(DriveCoreState) / sizeof(double);
  EXPECT_LE(largest - core, kMaxUnitState);
  // Without a computed room the chopper drives with a profile needed more than the old 40.
  EXPECT_GT(largest - core, 40);
}

}  // namespace
}  // namespace mjstepper::testing
