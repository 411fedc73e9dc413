// `mjstepper resonance-test` (issue 18): the raw accelerometer log in Klipper's format exactly,
// the measured resonance of a belt axis against the closed form of its belt-and-mass mode in
// series with the stepper's magnetic stiffness, and the recommended shaper's frequency there.
#include "resonance.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "../plugin/printer_axes.h"
#include "core/presets.h"
#include "core/shaper.h"
#include "stepper_model.h"

namespace mjstepper::tools {
namespace {

using ::testing::HasSubstr;

std::filesystem::path TempDir() {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("mjstepper_resonance_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

constexpr double kRadius = 0.006366;  // m, GT2 20-tooth pulley
constexpr double kBelt = 2e4;         // N/m
constexpr double kCarriage = 0.5;     // kg

// A belt axis along X (belt stiffness `belt`, N/m, damping `belt_damping`, N·s/m) on a
// 17HS19-2004S1 (no published detent: no
// detent stiffness) on a TMC2209 in StealthChop (STEP/DIR), the carriage's site carrying the
// accelerometer; `extra` adds to the model (e.g. the kinematics).
std::string BeltModel(const std::string& custom, double belt = kBelt,
                      const std::string& drive = "stealthchop", double belt_damping = 2) {
  const MotorParams motor = FindPreset("17hs19_2004s1")->motor;
  std::ostringstream xml;
  xml << R"(<mujoco><option timestep="5e-5" integrator="implicitfast"/>
  <extension><plugin plugin="mjstepper.stepper"/></extension>
  <worldbody>
    <body name="rotor"><joint name="shaft" type="hinge" axis="0 0 1"/>
      <inertial pos="0 0 0" mass="0.001" diaginertia="1e-9 1e-9 1e-9"/></body>
    <body name="carriage"><joint name="carriage" type="slide" axis="1 0 0"/>
      <inertial pos="0 0 0" mass=")"
      << kCarriage << R"(" diaginertia="5e-4 5e-4 5e-4"/>
      <site name="toolhead_accel"/></body>
  </worldbody>
  <tendon><fixed name="belt" stiffness=")"
      << belt << R"(" damping=")" << belt_damping << R"(" springlength="0">
    <joint joint="carriage" coef="1"/><joint joint="shaft" coef="-)"
      << kRadius << R"("/></fixed></tendon>
  <actuator><plugin name="x" joint="shaft" plugin="mjstepper.stepper" armature=")"
      << motor.rotor_inertia << R"(" damping="1e-4">
      <config key="motor" value="17hs19_2004s1"/><config key="driver" value="tmc2209"/>
      <config key="drive" value=")"
      << drive << R"("/><config key="input" value="steps"/>
      <config key="run_current" value="1.4"/></plugin></actuator>
  <sensor><accelerometer name="toolhead_accel" site="toolhead_accel"/></sensor>
  )" << custom
      << "</mujoco>";
  return xml.str();
}

const std::string kKinematics = "<custom><numeric name=\"mjstepper:kinematics:x\" data=\"" +
                                std::to_string(1 / kRadius) + " 0 0\"/></custom>";

std::string Write(const std::string& name, const std::string& text) {
  const auto path = TempDir() / name;
  std::ofstream(path) << text;
  return path.string();
}

ResonanceOptions Options(const std::string& model, const std::string& out) {
  ResonanceOptions o;
  o.model = model;
  o.axis = 'x';
  o.test = {.min_freq = 20, .max_freq = 130, .accel_per_hz = 0.075, .hz_per_sec = 10};
  o.out = out;
  o.progress = false;
  return o;
}

TEST(ResonanceTest, RawLogIsKlippersFormatAndTheResonanceIsTheClosedForm) {
  // A short, stiff belt (2e5 N/m): the stepper's magnetic stiffness in series, T'/r² = 4.8e5 N/m
  // at the carriage, then lowers the mode by 16 % from the belt's own √(k/m), so the check below
  // tells the two apart.
  constexpr double kStiffBelt = 2e5;  // N/m
  // SpreadCycle regulates the current, so the rotor is held by T' at these frequencies too;
  // StealthChop's voltage-mode current answers a rotor ringing near the winding's corner
  // frequency R/(2π·L) = 74 Hz with motional currents of its own, which stiffen it.
  // The belt damped at ζ = 0.05 (c = 2ζ·√(k·m)), a printer's order (Klipper fits shapers for
  // 0.075-0.15): lighter, the swept mode rings up until the stepper's sin δ softens it.
  const double damping = 2 * 0.05 * std::sqrt(kStiffBelt * kCarriage);  // N·s/m
  const std::string model =
      Write("belt.xml", BeltModel(kKinematics, kStiffBelt, "spreadcycle", damping));
  const std::string out = (TempDir() / "x").string();
  std::stringstream progress;
  const ResonanceResult r = RunResonanceTest(Options(model, out), progress);

  // Klipper's raw format: the header line exactly, then time (s) and three accelerations (mm/s²)
  // per row at 3200 Hz; the z axis reads gravity (+9806.65 mm/s² up) within the ADXL345's noise.
  std::ifstream raw(out + "_raw.csv");
  std::string line;
  std::getline(raw, line);
  EXPECT_EQ(line, "#time,accel_x,accel_y,accel_z");
  std::vector<std::vector<double>> rows;
  while (std::getline(raw, line)) {
    std::vector<double> row;
    std::istringstream fields(line);
    for (std::string field; std::getline(fields, field, ',');) row.push_back(std::stod(field));
    ASSERT_EQ(row.size(), 4u) << line;
    rows.push_back(row);
  }
  ASSERT_GT(rows.size(), 1000u);
  EXPECT_EQ(static_cast<long>(rows.size()), r.samples);
  EXPECT_NEAR(rows[1][0] - rows[0][0], 1 / 3200.0, 1e-9);
  double z = 0;
  for (const auto& row : rows) z += row[3] / rows.size();
  EXPECT_NEAR(z, 9806.65, 5.0);  // mm/s²: 17 mg RMS noise over 11 s of samples averages out

  // The closed form: rotor (J, held by T' = Nr·Km·I) and carriage (m) on the belt (k, r):
  //   [J 0; 0 m]·q̈ + [T' + k·r², −k·r; −k·r, k]·q = 0, q = (θ, x);
  // the lower mode is the carriage's. T' at the TMC2209's rounded 1.4 A RMS.
  const MotorParams motor = FindPreset("17hs19_2004s1")->motor;
  // A: the TMC2209 sets 1.4 A RMS as CS 24 at 0.325 V, 25/32·0.325/(0.110 + 0.02)/√2 = 1.381 A
  const double peak = 25.0 / 32 * 0.325 / 0.130;
  const double stiffness = motor.rotor_teeth * motor.torque_constant * peak;  // T', N·m/rad
  const double J = motor.rotor_inertia, m = kCarriage;
  const double k = kStiffBelt;
  const double a = J * m, b = -(m * (stiffness + k * kRadius * kRadius) + J * k), c = stiffness * k;
  const double lower = (-b - std::sqrt(b * b - 4 * a * c)) / (2 * a);  // ω², rad²/s²
  const double closed = std::sqrt(lower) / (2 * std::numbers::pi);     // Hz
  std::printf(
      "belt axis: measured resonance %.2f Hz (closed form %.2f Hz; the belt alone %.2f Hz)\n",
      r.peak_frequency, closed, std::sqrt(k / m) / (2 * std::numbers::pi));
  EXPECT_NEAR(r.peak_frequency, closed, 0.05 * closed);  // issue 18: within 5 %
  // Without the stepper in series the closed form would be the belt's √(k/m): 16 % off.
  EXPECT_GT(std::abs(r.peak_frequency - std::sqrt(k / m) / (2 * std::numbers::pi)), 0.05 * closed);
  // The recommended shaper is tuned within 5 % of it (its frequency, not a shifted one).
  ASSERT_GE(r.recommended, 0);
  const ShaperFit& best = r.fits[r.recommended];
  std::printf("recommended %s at %.2f Hz, remaining vibration %.2f %%\n", best.shaper.name.c_str(),
              best.frequency, 100 * best.vibration);
  EXPECT_NEAR(best.frequency, closed, 0.05 * closed);

  // The PSD file is Klipper's calibration CSV (issue 31, item 3), as its calibrate_shaper.py
  // --csv writes it and its parse_log reads it back: the header exactly, with one NAME(FREQ)
  // column per fitted shaper; per row `%.1f`, four `%.3e`, an empty cell, `%.3f` per shaper. Its
  // PSDs are Klipper's normalized ones, psd/(f + 0.1 Hz): the tested axis' raw PSD (r.psd) over
  // f + 0.1 within the 4-digit rounding (from 10 Hz; below, Klipper damps it further).
  std::ifstream psd(out + "_psd.csv");
  std::getline(psd, line);
  std::string header = "freq,psd_x,psd_y,psd_z,psd_xyz,shapers:";
  for (const ShaperFit& f : r.fits)
    header += fmt::format(",{}({:.1f})", f.shaper.name, f.frequency);
  EXPECT_EQ(line, header);
  EXPECT_THAT(line, HasSubstr(",3hump_ei("));
  std::string shaper_cells;
  for (size_t i = 0; i < r.fits.size(); ++i) shaper_cells += R"(,[01]\.\d{3})";
  const std::regex row_format(R"(\d+\.\d(,\d\.\d{3}e[+-]\d{2}){4},)" + shaper_cells);
  size_t n = 0;
  while (std::getline(psd, line)) {
    ASSERT_TRUE(std::regex_match(line, row_format)) << line;
    double f = 0, x = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf", &f, &x), 2);
    ASSERT_LT(n, r.frequency.size());
    EXPECT_NEAR(f, r.frequency[n], 0.05);  // %.1f
    if (f >= 10) {
      // r.psd in (m/s²)²/Hz, the file in Klipper's mm.
      EXPECT_NEAR(x, 1e6 * r.psd[n] / (r.frequency[n] + 0.1), 1e-3 * x) << line;  // %.3e
    }
    ++n;
  }
  EXPECT_EQ(n, r.frequency.size());
}

// A 20 mm move along X (trapezoid: 100 mm/s, 5000 mm/s², a printer's) through the STEP/DIR
// stepper at 256 microsteps (a count is 0.78 µm, so the staircase excites little), its command
// optionally shaped: x_s(t) = Σ A_i·x(t − T_i). Returns the toolhead's X acceleration (MuJoCo's
// sensor, m/s²) over `window` s from `after` s past the command's end.
std::vector<double> Ringing(const mjModel* m, const InputShaper* shaper, double after,
                            double window) {
  constexpr double kDistance = 0.020, kSpeed = 0.100, kAccel = 5.0;         // m, m/s, m/s²
  const double ramp = kSpeed / kAccel, cruise = kDistance / kSpeed - ramp;  // s
  auto x = [&](double t) {  // the unshaped trapezoid, m
    if (t <= 0) return 0.0;
    if (t < ramp) return 0.5 * kAccel * t * t;
    if (t < ramp + cruise) return 0.5 * kAccel * ramp * ramp + kSpeed * (t - ramp);
    const double td = std::min(t - ramp - cruise, ramp);
    return kDistance - 0.5 * kAccel * (ramp - td) * (ramp - td);
  };
  auto shaped = [&](double t) {
    if (shaper == nullptr) return x(t);
    double sum = 0;
    for (size_t i = 0; i < shaper->times.size(); ++i)
      sum += shaper->amplitudes[i] * x(t - shaper->times[i]);
    return sum;
  };
  const double end = 2 * ramp + cruise + (shaper != nullptr ? shaper->duration() : 0.0);  // s
  const double step = 2 * std::numbers::pi / (200 * 256);  // rad per microstep
  DataPtr data(mj_makeData(m));
  mjData* d = data.get();
  const int accel = m->sensor_adr[mj_name2id(m, mjOBJ_SENSOR, "toolhead_accel")];
  std::vector<double> out;
  while (d->time < end + after + window) {
    d->ctrl[0] = std::round(shaped(d->time + m->opt.timestep) / kRadius / step);
    mj_step(m, d);
    if (d->time >= end + after) out.push_back(d->sensordata[accel]);
  }
  return out;
}

double Rms(const std::vector<double>& v) {
  double sum = 0;
  for (double x : v) sum += x * x;
  return std::sqrt(sum / v.size());
}

TEST(ResonanceTest, ShapedMoveLeavesThePredictedVibration) {
  // The belt axis at 256 microsteps. Its carriage mode, f and ζ, is measured from the unshaped
  // move's ringing (zero crossings and the log decrement over 0.3 s after the move); a ZV tuned
  // there leaves below 1/10 of the unshaped ringing (issue 18), and ZV and MZV detuned to 0.8·f
  // leave the fraction V(f, ζ) of SPEC §9 predicts, within 20 % (issue 18's tolerance).
  std::string xml = BeltModel(kKinematics);
  const std::string stealth = R"(<config key="run_current" value="1.4"/>)";
  xml.replace(xml.find(stealth), stealth.size(),
              stealth + R"(<config key="microsteps" value="256"/>)");
  std::string error(1000, '\0');
  LoadPluginLibrary();
  ModelPtr m(mj_loadXML(Write("shaped.xml", xml).c_str(), nullptr, error.data(), 1000));
  ASSERT_TRUE(m) << error;
  const double h = m->opt.timestep;
  const std::vector<double> free = Ringing(m.get(), nullptr, 0.0, 0.3);
  // f from the zero crossings of the acceleration, less gravity (none on X); ζ from the decay of
  // the RMS between the first and last 0.1 s: exp(−ζ·ω·0.2).
  int crossings = 0;
  for (size_t k = 1; k < free.size(); ++k) crossings += (free[k - 1] < 0) != (free[k] < 0);
  const double f = crossings / 2.0 / (free.size() * h);  // Hz
  const size_t tenth = static_cast<size_t>(0.1 / h);
  const double first = Rms({free.begin(), free.begin() + tenth});
  const double last = Rms({free.end() - tenth, free.end()});
  const double zeta = std::log(first / last) / (2 * std::numbers::pi * f * 0.2);
  std::printf("belt axis ringing after the move: %.2f Hz, ζ = %.4f\n", f, zeta);
  // The unshaped reference, over the same window the shaped runs are measured in.
  const double unshaped = Rms(Ringing(m.get(), nullptr, 0.02, 0.1));
  const InputShaper tuned = MakeShaper(ShaperType::kZV, f, zeta);
  const double tuned_ratio = Rms(Ringing(m.get(), &tuned, 0.02, 0.1)) / unshaped;
  std::printf("ZV at %.2f Hz: ringing %.4f of the unshaped (predicted %.4f)\n", f, tuned_ratio,
              RemainingVibration(tuned, f, zeta));
  EXPECT_LT(tuned_ratio, 0.1);
  for (ShaperType type : {ShaperType::kZV, ShaperType::kMZV}) {
    const InputShaper detuned = MakeShaper(type, 0.8 * f, zeta);
    const double ratio = Rms(Ringing(m.get(), &detuned, 0.02, 0.1)) / unshaped;
    const double predicted = RemainingVibration(detuned, f, zeta);
    std::printf("%s at %.2f Hz: ringing %.4f of the unshaped, predicted V = %.4f\n",
                detuned.name.c_str(), 0.8 * f, ratio, predicted);
    EXPECT_NEAR(ratio, predicted, 0.2 * predicted) << detuned.name;
  }
}

// Issue 18: each axis of each printer model, its resonance test against the closed form of its
// belt-and-mass mode in series with the steppers' magnetic stiffness (tests/plugin/
// printer_axes.h, models/README.md), within 5 %, and the recommended shaper's frequency within
// 5 % of it. (The chopper's shorted idle phase stiffens the rotors a little, README: +1-3 %.)
// 20-110 Hz at 10 Hz/s (9 s) instead of Klipper's 5-133 Hz at 1 Hz/s (128 s): the same moves,
// faster; the modes sit at 41-71 Hz.
TEST(ResonanceTest, EachPrinterAxisResonatesAtItsClosedForm) {
  struct Case {
    const char* model;
    char axis;
    const char* accelerometer;
    const testing::Axis& closed;
  };
  for (const Case& c : {Case{"corexy.xml", 'x', "toolhead_accel", testing::kCoreXYX},
                        Case{"corexy.xml", 'y', "toolhead_accel", testing::kCoreXYY},
                        Case{"bedslinger.xml", 'x', "toolhead_accel", testing::kBedslingerX},
                        Case{"bedslinger.xml", 'y', "bed_accel", testing::kBedslingerY}}) {
    ResonanceOptions o = Options(std::string(MJSTEPPER_SOURCE_DIR "/models/") + c.model,
                                 (TempDir() / fmt::format("{}_{}", c.model, c.axis)).string());
    o.axis = c.axis;
    o.accelerometer = c.accelerometer;
    o.test = {.min_freq = 20, .max_freq = 110, .accel_per_hz = 0.075, .hz_per_sec = 10};
    std::stringstream progress;
    const ResonanceResult r = RunResonanceTest(o, progress);
    const double closed = testing::ClosedFormModes(c.closed).first / (2 * std::numbers::pi);
    const ShaperFit& best = r.fits.at(r.recommended);
    std::printf(
        "%s %c: measured %.2f Hz, closed form %.2f Hz (%+.1f %%); recommended %s at %.1f Hz "
        "(%+.1f %%), remaining vibration %.2f %%, max acceleration %.0f mm/s²\n",
        c.model, c.axis, r.peak_frequency, closed, 100 * (r.peak_frequency / closed - 1),
        best.shaper.name.c_str(), best.frequency, 100 * (best.frequency / closed - 1),
        100 * best.vibration, 1000 * best.max_accel);
    EXPECT_NEAR(r.peak_frequency, closed, 0.05 * closed) << c.model << " " << c.axis;
    EXPECT_NEAR(best.frequency, closed, 0.05 * closed) << c.model << " " << c.axis;
    // Each sensor moves with its axis and its peak stands above its noise: no warning.
    EXPECT_TRUE(r.warnings.empty()) << c.model << " " << c.axis << ": " << r.warnings.front();
  }
}

// Issue 31, item 4: the bed-slinger's Y axis moves the bed, and the toolhead's accelerometer sees
// only its own noise (its Y acceleration, less that noise, 0.3 % of the commanded), so its fit is
// noise (3HUMP_EI at 68.6 Hz for the 50.4 Hz mode, the issue's report). The test warns, naming
// --accelerometer and the model's accelerometers, and that the peak (10.7 (mm/s²)²/Hz) is not
// above the ADXL345's noise floor (8.2, the threshold 20×). With the bed's sensor: none (above).
TEST(ResonanceTest, AnAccelerometerThatDoesNotMoveWithTheAxisIsWarnedOf) {
  ResonanceOptions o =
      Options(MJSTEPPER_SOURCE_DIR "/models/bedslinger.xml", (TempDir() / "misplaced").string());
  o.axis = 'y';
  o.accelerometer = "toolhead_accel";
  o.test = {.min_freq = 20, .max_freq = 110, .accel_per_hz = 0.075, .hz_per_sec = 10};
  std::stringstream progress;
  const ResonanceResult r = RunResonanceTest(o, progress);
  ASSERT_EQ(r.warnings.size(), 2u);
  EXPECT_THAT(r.warnings[0], HasSubstr("'toolhead_accel' does not move with the y axis"));
  EXPECT_THAT(r.warnings[0], HasSubstr("--accelerometer"));
  EXPECT_THAT(r.warnings[0], HasSubstr("toolhead_accel, bed_accel"));
  EXPECT_THAT(r.warnings[1], HasSubstr("not above the accelerometer's noise floor"));
}

TEST(ResonanceTest, ModelWithoutKinematicsOrAccelerometerIsRefusedByName) {
  std::stringstream progress;
  const std::string bare = Write("bare.xml", BeltModel(""));
  try {
    RunResonanceTest(Options(bare, (TempDir() / "bare").string()), progress);
    ADD_FAILURE() << "a model without kinematics ran";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("mjstepper:kinematics:x"));
  }
  ResonanceOptions narrow =
      Options(Write("n.xml", BeltModel(kKinematics)), (TempDir() / "n").string());
  narrow.test = {.min_freq = 20, .max_freq = 23, .accel_per_hz = 0.075, .hz_per_sec = 1};
  try {
    RunResonanceTest(narrow, progress);
    ADD_FAILURE() << "a band without PSD bins ran";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("bins are 2 Hz apart"));
  }
  // Issue 33: both are refused before the simulation, so no raw log is left behind.
  EXPECT_FALSE(std::filesystem::exists(TempDir() / "n_raw.csv"));
  narrow.test = {.min_freq = 20, .max_freq = 24, .accel_per_hz = 0.075, .hz_per_sec = 10};
  try {
    RunResonanceTest(narrow, progress);  // 0.4 s: less than one 0.5 s segment
    ADD_FAILURE() << "a test shorter than a PSD segment ran";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("fewer than one 0.5 s segment"));
  }
  EXPECT_FALSE(std::filesystem::exists(TempDir() / "n_raw.csv"));
  ResonanceOptions o = Options(Write("k.xml", BeltModel(kKinematics)), (TempDir() / "k").string());
  o.accelerometer = "nozzle";
  try {
    RunResonanceTest(o, progress);
    ADD_FAILURE() << "a missing accelerometer ran";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("--accelerometer nozzle"));
  }
}

}  // namespace
}  // namespace mjstepper::tools
