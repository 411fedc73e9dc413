// Issue 31, item 6: a real print's step stream replayed on the printer. models/prints/square20
// holds Klipper's MCU commands for square20.gcode (one 20 mm X move at 100 mm/s, then two 20 mm
// squares) on a printer.cfg matching models/corexy.xml, from its batch mode with and without its
// MZV input shaper (generated once outside the build: models/prints/README.md).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>

#include "accel_log.h"
#include "core/klipper_steps.h"
#include "runner.h"

namespace mjstepper::tools {
namespace {

const std::string kPrint = MJSTEPPER_SOURCE_DIR "/models/prints/square20/";
const std::string kCoreXy = MJSTEPPER_SOURCE_DIR "/models/corexy.xml";

// The decoded stream is the G-code's motion. Klipper's corexy turns motor A by x + y and B by
// x − y, 6400 microsteps per 40 mm: the first move (+X 20 mm) is +3200 steps on both; the squares
// (+Y, −X, −Y, +X, +Y, −X, −Y) are A +3200, −6400, +6400, −6400 and B −6400, +6400, −6400, +3200
// in net, back to 0. Each step of the first move falls where the trapezoid (100 mm/s, 3000 mm/s²,
// from 0.25 s, Klipper's first clock) crosses its microstep's middle, at most Klipper's 25 µs
// early (its stepcompress's MAX_STEPCOMPRESS_ERROR) and never late (1 tick of rounding).
TEST(KlipperReplay, TheDecodedStreamIsTheGcodesMotion) {
  const auto lists = ReadKlipperSteps(kPrint + "noshaper.map");
  ASSERT_EQ(lists.size(), 2u);
  for (const char* name : {"stepper_a", "stepper_b"}) {
    SCOPED_TRACE(name);
    const StepTimes& s = lists.at(name);
    EXPECT_EQ(s.size(), 25600u);
    EXPECT_EQ(s.CountAt(s.size() - 1), 0);             // back where it started
    EXPECT_EQ(s.CountAt(3199), 3200);                  // the first move
    EXPECT_GT(s.TimeAt(3200) - s.TimeAt(3199), 0.15);  // then the 200 ms dwell
  }
  constexpr double kStart = 0.25, kSpeed = 100, kAccel = 3000, kMm = 20;  // s, mm/s, mm/s², mm
  const double ramp = kSpeed / kAccel, cruise = (kMm - kSpeed * ramp) / kSpeed;  // s
  auto position = [&](double t) {                                                // mm
    t -= kStart;
    if (t < ramp) return 0.5 * kAccel * t * t;
    if (t < ramp + cruise) return 0.5 * kSpeed * ramp + kSpeed * (t - ramp);
    const double u = t - ramp - cruise;
    return kMm - 0.5 * kSpeed * ramp + kSpeed * u - 0.5 * kAccel * u * u;
  };
  const StepTimes& a = lists.at("stepper_a");
  double earliest = 0, latest = -1;  // s: a step's time less the trapezoid's
  for (int k = 1; k <= 3200; ++k) {
    double lo = kStart, hi = kStart + 2 * ramp + cruise;  // the time x = (k − ½)·40/6400 mm
    for (int i = 0; i < 60; ++i) {
      (position(0.5 * (lo + hi)) < (k - 0.5) * 40.0 / 6400 ? lo : hi) = 0.5 * (lo + hi);
    }
    const double early = a.TimeAt(k - 1) - hi;
    earliest = std::min(earliest, early);
    latest = std::max(latest, early);
  }
  std::printf("first move: steps from %.1f to %+.3f µs of the trapezoid's\n", 1e6 * earliest,
              1e6 * latest);
  EXPECT_GE(earliest, -25e-6 - 1 / 50e6);
  EXPECT_LE(latest, 1 / 50e6);
}

// Replayed on models/corexy.xml, the print loses no step on either motor, and the toolhead's
// ringing after the first move (its ADXL345 x 20-120 ms after the move's end, less the sensor's
// own noise) falls under Klipper's MZV to less than a quarter (measured 217 → 45 mm/s², 0.21; the
// CoreXY study's own shaped tower moves give 0.20-0.26: docs/studies/printer.md).
TEST(KlipperReplay, ThePrintReplaysWithoutLostStepsAndItsShaperCutsTheRinging) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("mjstepper_klipper_replay_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  RunOptions o;
  o.model = kCoreXy;
  o.duration = 0.62;  // the first move ends at 0.482 s; the next starts at 0.68 s
  o.progress = false;
  std::ostringstream progress;
  o.accel_log = (dir / "still.csv").string();
  tools::Run(o, progress);
  const auto still = ReadAccelLog(o.accel_log);
  double ringing[2] = {0, 0};  // mm/s²: no shaper, MZV
  for (int v = 0; v < 2; ++v) {
    o.klipper = kPrint + (v == 0 ? "noshaper.map" : "mzv.map");
    o.accel_log = (dir / "moved.csv").string();
    const RunResult r = tools::Run(o, progress);
    for (const StepperSummary& s : r.steppers) EXPECT_EQ(s.lost_steps, 0) << s.name;
    ringing[v] = RingingRms(ReadAccelLog(o.accel_log), still, 0, 0.502, 0.602);
  }
  std::filesystem::remove_all(dir);
  std::printf("ringing after the first move: %.1f mm/s² unshaped, %.1f with Klipper's MZV\n",
              ringing[0], ringing[1]);
  EXPECT_GT(ringing[0], 100);  // there is ringing to cut (twice the sensor's quantum and more)
  EXPECT_LT(ringing[1], 0.25 * ringing[0]);
}

// The map names actuators and oids that must exist; --klipper and --ctrl may not drive one
// actuator both.
TEST(KlipperReplay, AMapMustFitTheModel) {
  RunOptions o;
  o.model = kCoreXy;
  o.duration = 0.01;
  o.progress = false;
  o.klipper = kPrint + "mzv.map";
  o.ctrl = {{"stepper_a", "constant(0rpm)"}};
  auto refused = [](const RunOptions& options) {
    std::ostringstream progress;
    try {
      tools::Run(options, progress);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("(ran)");
  };
  EXPECT_THAT(refused(o), ::testing::HasSubstr("both drive 'stepper_a'"));
  o.model = MJSTEPPER_SOURCE_DIR "/models/bedslinger.xml";
  o.ctrl.clear();
  EXPECT_THAT(refused(o), ::testing::HasSubstr("has no stepper actuator 'stepper_a'"));
}

}  // namespace
}  // namespace mjstepper::tools
