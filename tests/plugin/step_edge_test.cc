// Issue 29, item 7: STEP/DIR edges as events. A driver chip moves its microstep table on the STEP
// edge itself (TMC2209 datasheet Rev. 1.09 §13.3), not at the next interrupt: before this, the
// count was read at each 50 µs interrupt and the targets applied 25 µs later (Tsui's DSP timing),
// an electrical lag of ω_e·(D + T/2) = 7854 rad/s · 50 µs = 0.393 rad at 1500 r/min.
//
// Closed form, 1500 r/min (ω = 157.08 rad/s, ω_e = Nr·ω = 7854 rad/s), 16 microsteps without
// interpolation: at each step's end the count is round(ω·t/step angle); with edges the table
// holds that count (the last edge, at the half microstep before it, moved it there), so the lag of
// the targets' electrical angle behind Nr·ω·t is the rounding alone, mean 0 over many steps (its
// spread ±π/(4·16) = ±0.049 rad). Read at the interrupts, the targets signal (set at the tick)
// lagged by ω_e·T/2 = 0.196 rad (0.206 measured before the change), the comparators' targets
// (applied D later) by 0.393 rad.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "test_model.h"

namespace mjstepper::testing {
namespace {

constexpr double kSpeed = 1500 * 2 * std::numbers::pi / 60;  // rad/s
constexpr double kNr = 50;
constexpr int kMicrosteps = 16;
constexpr double kTimestep = 2.5e-6;  // s: 20 samples of each interrupt period

double MeanTargetLag(const std::string& driver, const std::string& drive) {
  const std::string configs = Config("motor", "17hs19_2004s1") + Config("driver", driver) +
                              Config("drive", drive) + Config("input", "steps") +
                              Config("microsteps", std::to_string(kMicrosteps)) +
                              Config("interpolate", "off");
  std::string error;
  const ModelPtr m =
      LoadModel(RotorModel(fmt::format(R"(<plugin name="m1" joint="j1" plugin="mjstepper.stepper" )"
                                       R"(armature="1e-2">{}</plugin>)",
                                       configs),
                           "",
                           R"(<plugin name="s" plugin="mjstepper.stepper" objtype="actuator" )"
                           R"(objname="m1"/>)",
                           1, kTimestep),
                &error);
  if (!m) {
    ADD_FAILURE() << error;
    return 0;
  }
  const DataPtr d(mj_makeData(m.get()));
  const double step_angle = 2 * std::numbers::pi / (4 * kNr * kMicrosteps);  // rad
  double sum = 0;
  int n = 0;
  while (d->time < 0.01) {
    // The command moves at 1500 r/min from t = 0 (the rotor, on a large inertia, need not follow:
    // the targets are the drive's alone).
    d->ctrl[0] = std::round(kSpeed * (d->time + kTimestep) / step_angle);
    mj_step(m.get(), d.get());
    if (d->time < 0.002) continue;
    // The sensors after mj_step describe the step's start, d->time − h.
    const double commanded = kNr * kSpeed * (d->time - kTimestep);  // electrical rad
    const double table = std::atan2(d->sensordata[kCurrentRefB], d->sensordata[kCurrentRefA]);
    sum += std::remainder(commanded - table, 2 * std::numbers::pi);
    ++n;
  }
  return sum / n;
}

TEST(StepEdges, TheTableMovesOnTheEdgeNotAtTheNextInterrupt) {
  for (const auto& [driver, drive] :
       {std::pair{"tmc2209", "spreadcycle"}, {"a4988", "chopper"}, {"tmc2209", "stealthchop"}}) {
    const double lag = MeanTargetLag(driver, drive);
    std::printf(
        "%s %s: mean lag of the targets at 1500 r/min %.4f rad (at the interrupts: "
        "%.4f)\n",
        driver, drive, lag, kNr * kSpeed * 50e-6);
    // 0.005 rad: the rounding's mean over 3200 samples (its spread 0.049 rad / √3200 = 0.001).
    EXPECT_NEAR(lag, 0.0, 0.005) << driver << " " << drive;
  }
}

// The speed of the first lost step on a slow ramp, against the pull-out at the bus limit.
//
// Closed form (rotor frame, SPEC S-2/S-3 with Km·ω the back-EMF's amplitude): in steady state at
// speed ω the phase voltages v_d = R·i_d − X·i_q, v_q = R·i_q + X·i_d + Km·ω, X = Nr·ω·L, must lie
// in the circle |v| ≤ V. The currents they allow are a circle of radius V/|Z| about
// i0 = −Km·ω·(X, R)/|Z|², so the largest torque is Km·i_q = Km·(V·|Z| − Km·ω·R)/|Z|², capped by
// Km·I. A chopper that cannot reach its target (every chip drive at these speeds) applies ±Vbus
// in the sign of its target: a square wave whose fundamental is V = 4·Vbus/π, and whose phase the
// rotor's load angle adjusts to the best one. A step is lost where that torque falls below the
// load, b·ω + J·α.
//
// 17HS19-2004S1 (R 1.4 Ω, L 3.0 mH, Km 0.2086 N·m/A), TMC2209 at 24 V and 16 microsteps, on a
// joint damped b = 1.5e-3 + 1e-4 (the motor's own) N·m·s/rad, J = 1.82e-5 kg·m², ramped at
// 1000 r/min/s: the closed form puts the first lost step at 1499 r/min.
double ClosedFormFirstLostStep(double damping, double inertia, double acceleration) {
  constexpr double kKm = 0.59 / (2 * std::numbers::sqrt2);  // N·m/A: holding / (√2·I_rated)
  constexpr double kR = 1.4, kL = 3.0e-3, kI = 2 * std::numbers::sqrt2;  // Ω, H, A (peak)
  const double v = 4 * 24.0 / std::numbers::pi;  // V: the square wave's fundamental
  auto margin = [&](double w) {
    const double x = kNr * w * kL, z2 = kR * kR + x * x;
    const double torque = kKm * std::min((v * std::sqrt(z2) - kKm * w * kR) / z2, kI);
    return torque - damping * w - inertia * acceleration;
  };
  double lo = 1, hi = 1000;  // rad/s: the margin is positive at lo, negative at hi
  for (int i = 0; i < 100; ++i) (margin(0.5 * (lo + hi)) > 0 ? lo : hi) = 0.5 * (lo + hi);
  return lo;
}

// The rotor's speed (rad/s) at the first lost step of the ramp below, simulated at step h (s).
double FirstLostStep(double h, double damping, double acceleration) {
  const std::string configs =
      Config("motor", "17hs19_2004s1") + Config("driver", "tmc2209") + Config("input", "steps");
  std::string error;
  const ModelPtr m = LoadModel(BenchRotorModel(configs, damping, h), &error);
  if (!m) throw std::runtime_error(error);
  const DataPtr d(mj_makeData(m.get()));
  const double step_angle = 2 * std::numbers::pi / (4 * kNr * kMicrosteps);  // rad
  while (d->time < 2.5) {
    const double t = d->time + h;
    d->ctrl[0] = std::round(0.5 * acceleration * t * t / step_angle);
    mj_step(m.get(), d.get());
    if (d->sensordata[kLostSteps] != 0) return acceleration * d->time;
  }
  return 0;
}

TEST(StepEdges, TheFirstLostStepIsAtThePullOutOfTheBusLimit) {
  constexpr double kDamping = 1.5e-3;                                 // N·m·s/rad on the joint
  constexpr double kAcceleration = 1000 * 2 * std::numbers::pi / 60;  // rad/s²
  constexpr double kBody = 1e-5, kArmature = 8.2e-6;                  // kg·m², BenchRotorModel's
  const double predicted =
      ClosedFormFirstLostStep(kDamping + 1e-4, kBody + kArmature, kAcceleration);
  const double rpm = 60 / (2 * std::numbers::pi);
  // 2.5 %: the closed form keeps the square wave's fundamental only, and a slip is counted half
  // an electrical cycle after the pull-out; at this damping both cost under 1 % (0.3 % measured
  // at 10 µs). With the count read at the 50 µs interrupts (the edges switched off) the first
  // step was lost at 1437 r/min, 4.1 % early, which this band refuses. At lighter damping the
  // harmonics' share grows (+4.6 % at 0.8e-3 N·m·s/rad) and below about 0.5e-3 mid-band
  // instability, which no closed form here predicts, loses the first step first: the test stays
  // at this point.
  // At 50 µs, a printer's step, the chopper's 20-40 kHz cycle is not resolved. Handed the
  // torque of the currents with their ripple, one sample per step, the rotor lost its first
  // step at 1377 r/min (−8.1 %); with the ripple taken out while the chopper repeats a steady
  // cycle (PhaseSwitch::Ripple), at 1442 (−3.8 %): 5 % there. What is left is the ripple of the
  // cycles in which the target moves (at 1400 r/min every 14 µs), which no template repeats.
  for (double h : {1e-5, 5e-5}) {
    const double lost_at = FirstLostStep(h, kDamping, kAcceleration);
    std::printf(
        "h = %g s: first lost step at %.0f r/min; the pull-out at the bus limit: %.0f "
        "r/min\n",
        h, lost_at * rpm, predicted * rpm);
    EXPECT_NEAR(lost_at / predicted, 1.0, h == 1e-5 ? 0.025 : 0.05) << "h = " << h;
  }
}

// The `step_times` attribute: a list of pulse times read at load, each pulse an edge at its own
// time. On the bench rotor (a 17HS19 on a TMC2209) the same list at 100 µs and at 10 µs leaves the
// same count, from the rotor's own microstep, and the rotor where the fine one rests; ctrl is
// unused (set to nonsense here). Refused with input other than steps, and a file that cannot be
// read, each naming the attribute.
TEST(StepEdges, AListOfPulseTimesDrivesTheCountAtItsOwnTimes) {
  const auto path = std::filesystem::temp_directory_path() / "mjstepper_step_edge_pulses.txt";
  {
    std::ofstream out(path);
    for (int k = 0; k < 64; ++k) out << 0.01 + 0.37e-3 * k << "\n";  // 4 full steps at 16
  }
  const std::string configs = Config("motor", "17hs19_2004s1") + Config("driver", "tmc2209") +
                              Config("input", "steps") + Config("step_times", path.string());
  auto final_state = [&](double h) {
    std::string error;
    const ModelPtr m = LoadModel(BenchRotorModel(configs, 1.5e-3, h), &error);
    EXPECT_TRUE(m) << error;
    if (!m) return std::vector<double>{};
    const DataPtr d(mj_makeData(m.get()));
    while (d->time < 0.06 - 0.5 * h) {
      d->ctrl[0] = 12345;  // unused with a list
      mj_step(m.get(), d.get());
    }
    return std::vector<double>{d->sensordata[kThetaCmd], d->sensordata[kCurrentA],
                               d->sensordata[kCurrentB], d->qpos[0]};
  };
  const std::vector<double> fine = final_state(1e-5), coarse = final_state(1e-4);
  ASSERT_EQ(fine.size(), 4u);
  ASSERT_EQ(coarse.size(), 4u);
  const double step_angle = 2 * std::numbers::pi / (4 * kNr * kMicrosteps);  // rad
  EXPECT_NEAR(fine[0], 64 * step_angle, 1e-12);  // θcmd: the list's count, not ctrl's
  EXPECT_NEAR(coarse[0], 64 * step_angle, 1e-12);
  EXPECT_NEAR(coarse[3], fine[3], 0.01 * step_angle);  // the rotor rests where the fine one does
  std::string error;
  EXPECT_FALSE(
      LoadModel(BenchRotorModel(Config("motor", "17hs19_2004s1") + Config("driver", "tmc2209") +
                                    Config("step_times", path.string()),
                                1.5e-3, 1e-4),
                &error));
  EXPECT_NE(error.find("step_times"), std::string::npos) << error;
  EXPECT_NE(error.find("needs input = steps"), std::string::npos) << error;
  EXPECT_FALSE(
      LoadModel(BenchRotorModel(Config("motor", "17hs19_2004s1") + Config("driver", "tmc2209") +
                                    Config("input", "steps") +
                                    Config("step_times", "/nonexistent/pulses.txt"),
                                1.5e-3, 1e-4),
                &error));
  EXPECT_NE(error.find("step_times"), std::string::npos) << error;
  EXPECT_NE(error.find("cannot be read"), std::string::npos) << error;
  std::filesystem::remove(path);
}

// Issue 32, item 4: with a list, the omega_cmd signal is the list's step rate (a microstep over
// the pulses' interval), steady at a steady rate; it was the step's count change, which alternated
// between 0 and a microstep per timestep (0 and 1875 r/min where the rate was 1500) when the
// pulses are slower than the steps.
TEST(StepEdges, AListsCommandedSpeedIsItsStepRate) {
  const auto path = std::filesystem::temp_directory_path() / "mjstepper_step_rate_pulses.txt";
  constexpr double kInterval = 0.37e-3;  // s between pulses: 3.7 timesteps
  {
    std::ofstream out(path);
    for (int k = 0; k < 100; ++k) out << 0.01 + kInterval * k << "\n";
  }
  std::string error;
  const ModelPtr m = LoadModel(
      BenchRotorModel(Config("motor", "17hs19_2004s1") + Config("driver", "tmc2209") +
                          Config("input", "steps") + Config("step_times", path.string()),
                      1.5e-3, 1e-4),
      &error);
  ASSERT_TRUE(m) << error;
  const DataPtr d(mj_makeData(m.get()));
  const double step_angle = 2 * std::numbers::pi / (4 * kNr * kMicrosteps);  // rad
  const int omega_cmd = SignalIndex("omega_cmd");
  int seen = 0;
  while (d->time < 0.04) {
    mj_step(m.get(), d.get());
    mj_forward(m.get(), d.get());  // the sensors after the step's end
    if (d->time < 0.012 || d->time > 0.04) continue;  // within the pulses, not at their ends
    EXPECT_NEAR(d->sensordata[omega_cmd], step_angle / kInterval, 1e-9 * step_angle / kInterval)
        << "t = " << d->time;
    ++seen;
  }
  EXPECT_GT(seen, 200);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace mjstepper::testing
