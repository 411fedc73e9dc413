// `mjstepper pullout` and `mjstepper map` (issue 9): the pull-out torque curve and the resonance
// map have the shapes physics gives them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "core/units.h"
#include "sweep.h"

namespace mjstepper::tools {
namespace {

// The Tsui motor (current microstepping at I = 1.9 A on a 48 V bus) on the compliant coupling of
// models/tsui_coupling.xml, whose slow two-mass mode is at f1 = 72.2 Hz (tests/plugin/
// loads_test.cc).
constexpr double kKm = 0.3, kCurrent = 1.9, kR = 0.9, kL = 2.2e-3, kNr = 50, kBus = 48;
constexpr double kFriction = 0.029;  // N·m, the joint's frictionloss: it takes its share
constexpr double kSlowMode = 72.23;  // Hz

// The speed (rad/s) above which the bus cannot hold I against the back-EMF with the current at
// the pull-out angle (in phase with the EMF): |V| = √((R·I + Km·ω)² + (Nr·ω·L·I)²) = Vbus.
double CornerSpeed() {
  const double a = kKm * kKm + std::pow(kNr * kL * kCurrent, 2);
  const double b = 2 * kR * kCurrent * kKm;
  const double c = std::pow(kR * kCurrent, 2) - kBus * kBus;
  return (-b + std::sqrt(b * b - 4 * a * c)) / (2 * a);
}

// The known shape, on one run over 16 speeds:
// - near Km·I − Fs at low speed: within 0.023 N·m (4 % of Km·I), the detent's three harmonics
//   (0.031 N·m together) moving the weakest point of the cycle and the load ramp's lag;
// - still above 80 % of the low-speed value at 60 % of the back-EMF corner speed (1217 r/min),
//   collapsed below 20 % at 125 % of it: the bus voltage runs out there, as the closed form says.
//   (Between the two the PI loop's finite bandwidth already costs torque, and a fast load ramp
//   finds a dip near 900 r/min, where the unloaded drive breaks into a 200 Hz oscillation; a slow
//   ramp does not: not in the closed form, and not tested.)
// - dips at the resonant speeds of the slow mode, n_h = 60·f1/(h·Nr) for the detent's harmonics
//   h = 4 and 2 (21.7 and 43.3 r/min): the curve there lies 0.005 N·m (about 1 %) or more below
//   both neighbours 7.5 r/min away.
TEST(PullOut, CurveHasThePhysicalShape) {
  const double corner = CornerSpeed();
  const double n4 = 60 * kSlowMode / (4 * kNr), n2 = 60 * kSlowMode / (2 * kNr);  // r/min
  PullOutOptions o;
  o.model = MJSTEPPER_SOURCE_DIR "/models/tsui_coupling.xml";
  o.progress = false;
  const std::vector<double> rpm = {10,        15,      20,        22.5,      30,       35,
                                   40,        42.5,    45,        50,        n4 - 7.5, n4 + 7.5,
                                   n2 - 7.5,  n2 + 7.5, RadPerSecToRpm(0.6 * corner),
                                   RadPerSecToRpm(1.25 * corner)};
  for (double n : rpm) o.speeds.push_back(RpmToRadPerSec(n));
  std::ostringstream progress;
  const std::vector<PullOutPoint> points = PullOut(o, progress);
  auto at = [&](double n) {
    for (size_t i = 0; i < rpm.size(); ++i) {
      if (rpm[i] == n) return points[i].torque;
    }
    ADD_FAILURE() << "no point at " << n << " r/min";
    return 0.0;
  };
  // Within ±3 r/min of a resonant speed, the lowest point.
  auto dip = [&](double n) {
    double lowest = 1e9;
    for (size_t i = 0; i < rpm.size(); ++i) {
      if (std::abs(rpm[i] - n) <= 3) lowest = std::min(lowest, points[i].torque);
    }
    return lowest;
  };
  for (const PullOutPoint& p : points) EXPECT_FALSE(p.held_max) << p.speed;
  const double low = at(10);
  EXPECT_NEAR(low, kKm * kCurrent - kFriction, 0.04 * kKm * kCurrent);
  EXPECT_GT(at(RadPerSecToRpm(0.6 * corner)), 0.8 * low);
  EXPECT_LT(at(RadPerSecToRpm(1.25 * corner)), 0.2 * low);
  for (double n : {n4, n2}) {
    EXPECT_LT(dip(n), std::min(at(n - 7.5), at(n + 7.5)) - 0.005) << "resonant speed " << n;
  }
}

// The slow two-mass mode of the coupling model with coupling stiffness k, Hz (closed form, as in
// tests/plugin/loads_test.cc; T' = 28.5 N·m/rad, J_r = 0.36e-4, J_l = 0.72e-4 kg·m²).
double SlowMode(double k) {
  const double jr = 0.36e-4, jl = 0.72e-4, t = kKm * kCurrent * kNr;
  const double a = jr * jl, b = -(jr * k + jl * (t + k)), c = t * k;
  return std::sqrt((-b - std::sqrt(b * b - 4 * a * c)) / (2 * a)) / (2 * std::numbers::pi);
}

// The resonance map's ridges follow SPEC §1's n_h = 60·fn/(h·Nr) with fn the two-mass slow mode,
// as the coupling stiffness moves it: for k = 20, 50 and 120 N·m/rad, the peak velocity ripple
// within ±20 % of n_2 and n_1 lies within 4 % (or one 2.5 r/min grid step) of them. The rigid
// coupling's n_1 (fn = 81.8 Hz: 98 r/min) is 25 % off at k = 20: the two-mass model is needed.
TEST(Map, RidgesFollowTheTwoMassResonantSpeeds) {
  MapOptions o;
  o.sweep.model = MJSTEPPER_SOURCE_DIR "/models/tsui_coupling.xml";
  o.sweep.speeds = ParseSpeedList("30:100:2.5rpm");
  o.sweep.settle = 0.3;
  o.sweep.measure = 0.3;
  o.sweep.progress = false;
  o.parameter = "stiffness:coupling";
  o.values = {20, 50, 120};
  std::ostringstream progress;
  const std::vector<MapPoint> points = Map(o, progress);
  ASSERT_EQ(points.size(), o.values.size() * o.sweep.speeds.size());
  for (double k : o.values) {
    for (int h : {2, 1}) {
      const double predicted = 60 * SlowMode(k) / (h * kNr);  // r/min
      double peak_speed = 0, peak = -1;
      for (const MapPoint& p : points) {
        const double n = RadPerSecToRpm(p.point.speed);
        if (p.value == k && std::abs(n - predicted) <= 0.2 * predicted &&
            p.point.peak_to_peak_error > peak) {
          peak = p.point.peak_to_peak_error;
          peak_speed = n;
        }
      }
      EXPECT_NEAR(peak_speed, predicted, std::max(0.04 * predicted, 2.5))
          << "k = " << k << " N·m/rad, h = " << h;
    }
  }
}

// Full stepping (microsteps = 1) excites the rotor at the step rate 4·Nr·n/60, which equals
// fn = 141.6 Hz at n = 42.5 r/min: there the velocity ripple is several times the microstepped
// motor's (the sine's residual excitation is the detent alone), while at 120 r/min, where the
// step rate is 2.8·fn, both stay small.
TEST(Sweep, FullSteppingRingsAtTheStepRateResonance) {
  auto ripple = [](const char* microsteps, double rpm) {
    SweepOptions o;
    o.model = MJSTEPPER_SOURCE_DIR "/models/tsui_rigid.xml";
    o.speeds = {RpmToRadPerSec(rpm)};
    o.settle = 0.3;
    o.measure = 0.3;
    o.progress = false;
    o.overrides = {{.actuator = "shaft", .key = "microsteps", .value = microsteps}};
    std::ostringstream progress;
    return RadPerSecToRpm(Sweep(o, progress)[0].peak_to_peak_error);
  };
  const double full = ripple("1", 42.5), smooth = ripple("0", 42.5);
  EXPECT_GT(full, 5 * smooth) << full << " vs " << smooth << " r/min peak-to-peak";
  EXPECT_GT(full, 3 * ripple("1", 120));
}

// A stall at (mid-band) resonance, counted. An L/R drive (voltage microstepping, 24 V through a
// series resistor: R = 8 Ω in all, 3 A at rest) on the rigid Tsui rotor, unloaded: above about
// 850 r/min the rotor's own oscillation (its load-angle mode, 64-89 Hz at these speeds, well below
// the 667-800 Hz step rates) loses its damping to the winding's lag and grows with speed, the
// classic mid-band instability, until at 940 r/min the rotor falls out of step. The counter counts
// that stall, where 850 r/min runs without a lost step.
TEST(Sweep, MidBandResonanceStallIsCounted) {
  SweepOptions o;
  o.model = MJSTEPPER_SOURCE_DIR "/models/tsui_rigid.xml";
  o.speeds = {RpmToRadPerSec(850), RpmToRadPerSec(925), RpmToRadPerSec(940)};
  o.progress = false;
  o.overrides = {{.actuator = "shaft", .key = "drive", .value = "voltage_microstep"},
                 {.actuator = "shaft", .key = "resistance", .value = "8"},
                 {.actuator = "shaft", .key = "voltage_amplitude", .value = "24"}};
  std::ostringstream progress;
  const std::vector<SweepPoint> p = Sweep(o, progress);
  EXPECT_EQ(p[0].lost_steps, 0);
  EXPECT_EQ(p[1].lost_steps, 0);
  // The growing oscillation is the rotor's mode, not the step rate.
  for (int i : {0, 1}) {
    EXPECT_GT(p[i].dominant_frequency, 50) << RadPerSecToRpm(p[i].speed);
    EXPECT_LT(p[i].dominant_frequency, 100) << RadPerSecToRpm(p[i].speed);
  }
  EXPECT_GT(p[1].peak_to_peak_error, 4 * p[0].peak_to_peak_error);
  EXPECT_GT(p[2].lost_steps, 4 * 50);  // it fell out of step: many electrical cycles lost
}

// A sweep CSV read back (the paper tests share one sweep this way) gives the points written, to
// the bit; a damaged row fails naming the file and the row, not as zeros.
TEST(Sweep, CsvReadsBackExactlyAndNamesADamagedRow) {
  const std::vector<SweepPoint> points = {{.speed = 4.45,
                                           .rms_error = 0.1 / 3,
                                           .peak_to_peak_error = 2.0 / 7,
                                           .dominant_frequency = 141.59265358979,
                                           .lost_steps = 0},
                                          {.speed = -17.9,
                                           .rms_error = 1e-9,
                                           .peak_to_peak_error = 3.0,
                                           .dominant_frequency = 0,
                                           .lost_steps = -4}};
  const auto dir = std::filesystem::temp_directory_path() / "mjstepper_sweep_csv_test";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "sweep.csv").string();
  WriteSweepCsv(path, points);
  const std::vector<SweepPoint> read = ReadSweepCsv(path);
  ASSERT_EQ(read.size(), points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    EXPECT_EQ(read[i].speed, points[i].speed);
    EXPECT_EQ(read[i].dominant_frequency, points[i].dominant_frequency);
    EXPECT_EQ(read[i].lost_steps, points[i].lost_steps);
    // Stored in r/min and back: within a few ulps of rad/s.
    EXPECT_NEAR(read[i].rms_error, points[i].rms_error, 1e-15 * points[i].rms_error);
    EXPECT_NEAR(read[i].peak_to_peak_error, points[i].peak_to_peak_error,
                1e-15 * points[i].peak_to_peak_error);
  }
  std::ofstream(path, std::ios::app) << "1,2,3,x,5,6\n";
  try {
    ReadSweepCsv(path);
    ADD_FAILURE() << "a damaged row was read";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path + ":4: not 6 numbers"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(ReadSweepCsv((dir / "absent.csv").string()), std::runtime_error);
}

}  // namespace
}  // namespace mjstepper::tools
