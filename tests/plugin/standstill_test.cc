// Issue 29, item 3: the standstill current of Trinamic chips (IHOLD, IHOLDDELAY, TPOWERDOWN;
// step_table.h) in the current, the holding torque and stiffness, and the heat.
//
// The closed form (TMC5160 datasheet, IHOLD_IRUN and TPOWERDOWN; f_CLK = 12 MHz): after the last
// step the chip detects standstill at 2^20 clocks (87.38 ms), waits TPOWERDOWN·2^18 clocks (2:
// 43.69 ms), then lowers CS from IRUN = 31 by one every IHOLDDELAY·2^18 clocks (1: 21.85 ms) to
// IHOLD; the current is (CS+1)/(IRUN+1) of the run current; the next step restores IRUN.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <variant>
#include <vector>

#include "config.h"
#include "core/drive.h"
#include "core/signals.h"
#include "test_model.h"

namespace mjstepper::testing {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

constexpr double kClock = 12e6;                   // Hz, TMC5160's f_CLK
constexpr double kDetect = 1048576.0 / kClock;    // s, 2^20 clocks
constexpr double kDelay = 2 * 262144.0 / kClock;  // s, TPOWERDOWN = 2
constexpr double kPerStep = 262144.0 / kClock;    // s, IHOLDDELAY = 1
constexpr int kIrun = 31, kIhold = 15;            // 2 A on a TMC5160 (GLOBALSCALER 167)
const double kRunPeak = std::sqrt(2.0) * 167.0 / 256 * 0.325 / 0.075 / std::sqrt(2.0);  // A
constexpr double kStepsPerMove = 64;  // microsteps, moved in kMoveTime
constexpr double kMoveTime = 0.02;    // s
constexpr double kTimestep = 2e-5;    // s

// 17HS19-2004S1 on a TMC5160 fed by STEP/DIR, a 1e-4 kg·m² load; `drive`: spreadcycle or
// stealthchop; `extra`: more <config>s.
std::string Model(const std::string& drive, const std::string& extra) {
  const std::string configs = Config("motor", "17hs19_2004s1") + Config("driver", "tmc5160") +
                              Config("drive", drive) + Config("input", "steps") + extra;
  return RotorModel(
      fmt::format(R"(<plugin name="m1" joint="j1" plugin="mjstepper.stepper" armature="1e-4" )"
                  R"(damping="1e-3">{}</plugin>)",
                  configs),
      "", R"(<plugin name="s" plugin="mjstepper.stepper" objtype="actuator" objname="m1"/>)", 1,
      kTimestep);
}

std::string Reduced() {
  return Config("ihold", std::to_string(kIhold)) + Config("iholddelay", "1") +
         Config("tpowerdown", "2");
}

double RefMagnitude(const mjData* d) {
  return std::hypot(d->sensordata[kCurrentRefA], d->sensordata[kCurrentRefB]);
}

// The closed form's current scale `idle` s after the last step.
double ExpectedScale(double idle) {
  const double ramp = idle - kDetect - kDelay;
  if (ramp < 0) return 1.0;
  const double cs = std::max<double>(kIhold, kIrun - std::floor(ramp / kPerStep));
  return (cs + 1) / (kIrun + 1);
}

// ctrl: 64 microsteps over the first 20 ms, then held; from `resume` on, moving again.
double Count(double t, double resume) {
  if (t >= resume) return kStepsPerMove + (t - resume) / kMoveTime * kStepsPerMove;
  return std::min(t / kMoveTime, 1.0) * kStepsPerMove;
}

// The targets (current_ref) follow the closed form's staircase at every step of a move, a long
// standstill and a resumed move, to the drive's clock: each tick (50 µs) samples the idle time
// and its target reaches the comparators 25 µs later, so a step of the staircase lands up to
// 75 µs late; samples within 0.1 ms of a staircase edge are skipped.
TEST(Standstill, TargetsFollowIholdIholddelayAndTpowerdown) {
  std::string error;
  const ModelPtr m = LoadModel(Model("spreadcycle", Reduced()), &error);
  ASSERT_TRUE(m) << error;
  const DataPtr d(mj_makeData(m.get()));
  // At rest from the start: stood still for ever, at IHOLD.
  mj_forward(m.get(), d.get());
  EXPECT_NEAR(RefMagnitude(d.get()), kRunPeak * (kIhold + 1.0) / (kIrun + 1), 1e-9);
  const double resume = 0.6;  // s
  // The count's last change as the drive sees it: the pulses are spread evenly over each step, the
  // count is round(θcmd/step angle), so 64 is reached at 63.5/64 of 20 ms (19.844 ms) and read at
  // the next tick, 19.85 ms.
  const double last_step = 0.01985;  // s
  int checked = 0, at_hold = 0;
  double least_while_moving = 1e9;
  while (d->time < resume + 0.05) {
    d->ctrl[0] = Count(d->time + kTimestep, resume);
    mj_step(m.get(), d.get());
    const double t = d->time;
    const double ref = RefMagnitude(d.get());
    if (t > 0.001 && t < last_step) least_while_moving = std::min(least_while_moving, ref);
    if (t > resume + 0.001) least_while_moving = std::min(least_while_moving, ref);
    if (t > last_step + 0.001 && t < resume) {
      const double idle = t - last_step;
      const double ramp = idle - kDetect - kDelay;
      const double from_edge = ramp < 0 ? -ramp : std::fmod(ramp, kPerStep);
      if (from_edge < 1e-4 || kPerStep - from_edge < 1e-4) continue;
      ASSERT_NEAR(ref / kRunPeak, ExpectedScale(idle), 1e-9) << "at t = " << t;
      ++checked;
      if (ExpectedScale(idle) == (kIhold + 1.0) / (kIrun + 1)) ++at_hold;
    }
  }
  EXPECT_GT(checked, 20000);
  EXPECT_GT(at_hold, 2000);  // the last 100 ms at IHOLD
  // While moving, before and after the standstill, the run current (the table's entries have
  // peak magnitude along the diagonal: |(sin, cos)| = 1 everywhere).
  EXPECT_NEAR(least_while_moving / kRunPeak, 1.0, 1e-9);
}

// Holding torque and stiffness follow IHOLD: a drive at rest holds with T' = Nr·Km·I_hold and
// T_H = Km·I_hold (S-4), I_hold = (IHOLD+1)/(IRUN+1) of the run current's peak.
TEST(Standstill, HoldingStiffnessIsAtTheHoldCurrent) {
  const auto parse = [](const std::string& ihold) {
    std::map<std::string, std::string> kv = {{"motor", "17hs19_2004s1"},
                                             {"driver", "tmc5160"},
                                             {"drive", "stealthchop"},
                                             {"input", "steps"}};
    if (!ihold.empty()) kv["ihold"] = ihold;
    const auto parsed = plugin::ParseConfig([&](const char* key) -> const char* {
      const auto it = kv.find(key);
      return it == kv.end() ? nullptr : it->second.c_str();
    });
    if (!std::holds_alternative<DriveConfig>(parsed)) {
      ADD_FAILURE() << std::get<std::string>(parsed);
      return Drive(DriveConfig{});
    }
    return Drive(std::get<DriveConfig>(parsed));
  };
  const Drive run = parse(""), hold = parse("21");  // PAROL6's J1: 0.7·31 = 21
  const double nr = 50, km = 0.59 / (std::sqrt(2.0) * 2.0);
  EXPECT_NEAR(run.RestCurrentMagnitude(), kRunPeak, 1e-9);
  EXPECT_NEAR(hold.RestCurrentMagnitude(), kRunPeak * 22.0 / 32, 1e-9);
  EXPECT_NEAR(hold.HoldingStiffness(), nr * km * kRunPeak * 22.0 / 32, 1e-9);
  EXPECT_NEAR(hold.HoldingStiffness() / run.HoldingStiffness(), 22.0 / 32, 1e-12);
}

// Heat: the copper loss at standstill is 2·R·I_rms² at the hold current, (16/32)² = 1/4 of the
// run current's, and the StealthChop chip's current itself (not only its target) settles there:
// measured over 100 ms after the ramp, within 3 %: StealthChop's autoscale regulates the mean
// |i| to the target and its PWM ripple adds 2.1 % to i², at IRUN as at IHOLD (measured);
// SpreadCycle's hysteresis ripple 0.3 %. Their ratio is (16/32)² within 1 %.
TEST(Standstill, CopperLossFollowsTheHoldCurrent) {
  const double r = 1.4;  // Ω, 17HS19-2004S1
  for (const char* drive : {"spreadcycle", "stealthchop"}) {
    SCOPED_TRACE(drive);
    double power[2] = {0, 0};  // W, without and with the reduction
    for (int reduced = 0; reduced < 2; ++reduced) {
      std::string error;
      const ModelPtr m = LoadModel(Model(drive, reduced ? Reduced() : ""), &error);
      ASSERT_TRUE(m) << error;
      const DataPtr d(mj_makeData(m.get()));
      auto run_to = [&](double t) {
        while (d->time < t) {
          d->ctrl[0] = Count(d->time + kTimestep, 1e9);
          mj_step(m.get(), d.get());
        }
      };
      run_to(0.55);  // the move, then 530 ms: past the ramp's end (481 ms after the last step)
      const double e0 = d->sensordata[kEnergyCopper], t0 = d->time;
      run_to(0.65);
      power[reduced] = (d->sensordata[kEnergyCopper] - e0) / (d->time - t0);
      const double rms = kRunPeak / std::sqrt(2.0) * (reduced ? 16.0 / 32 : 1.0);  // A
      std::printf("%s %s: copper %.4f W, 2·R·I² = %.4f W\n", drive, reduced ? "IHOLD 15" : "IRUN",
                  power[reduced], 2 * r * rms * rms);
      EXPECT_NEAR(power[reduced] / (2 * r * rms * rms), 1.0, 0.03);
    }
    EXPECT_NEAR(power[1] / power[0], 0.25, 0.01);
  }
}

// The attributes are a Trinamic chip's: refused on the A4988 class, and IHOLD above IRUN is
// refused naming both.
TEST(Standstill, AttributesNameTheirRule) {
  std::string error;
  EXPECT_FALSE(LoadModel(
      RotorModel(fmt::format(
          R"(<plugin name="m1" joint="j1" plugin="mjstepper.stepper" )"
          R"(armature="1e-4">{}</plugin>)",
          Config("motor", "17hs19_2004s1") + Config("driver", "a4988") + Config("ihold", "10"))),
      &error));
  EXPECT_THAT(error, AllOf(HasSubstr("ihold"), HasSubstr("10"), HasSubstr("spreadcycle")));
  // run_current 1 A on a TMC5160: GLOBALSCALER 84... CS 31 still; 1 A on a TMC2209 (0.110 Ω):
  // CS 17 with vsense, so IHOLD 20 is beyond it.
  EXPECT_FALSE(LoadModel(Model("spreadcycle", Config("ihold", "32")), &error));
  EXPECT_THAT(error, HasSubstr("ihold"));
  const std::string tmc2209 = RotorModel(fmt::format(
      R"(<plugin name="m1" joint="j1" plugin="mjstepper.stepper" armature="1e-4">{}</plugin>)",
      Config("motor", "17hs19_2004s1") + Config("driver", "tmc2209") + Config("run_current", "1") +
          Config("ihold", "20")));
  EXPECT_FALSE(LoadModel(tmc2209, &error));
  EXPECT_THAT(error, AllOf(HasSubstr("ihold"), HasSubstr("20")));
}

}  // namespace
}  // namespace mjstepper::testing
