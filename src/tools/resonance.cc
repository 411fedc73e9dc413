#include "resonance.h"

#include <fmt/format.h>
#include <fmt/ostream.h>
#include <fmt/ranges.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <ostream>
#include <stdexcept>

#include "cancel.h"
#include "csv_writer.h"
#include "output_file.h"
#include "stepper_model.h"

namespace mjstepper::tools {
namespace {

constexpr double kMm = 1000;  // mm per m: Klipper's files are in mm/s²

// Each stepper's rotor angle per metre of toolhead motion along X, Y, Z (rad/m), from the model's
// <custom><numeric name="mjstepper:kinematics:NAME" data="kx ky kz"/>.
std::vector<std::array<double, 3>> Kinematics(const mjModel* m,
                                              const std::vector<StepperActuator>& steppers) {
  std::vector<std::array<double, 3>> out;
  for (const StepperActuator& s : steppers) {
    const std::string name = "mjstepper:kinematics:" + s.name;
    const int id = mj_name2id(m, mjOBJ_NUMERIC, name.c_str());
    if (id < 0 || m->numeric_size[id] != 3) {
      throw std::invalid_argument(fmt::format(
          "stepper '{}' has no <custom><numeric name=\"{}\" data=\"kx ky kz\"/>: the resonance "
          "test needs each stepper's rotor angle per metre of toolhead motion along X, Y, Z "
          "(rad/m; 1/r for a belt on a pulley of radius r)",
          s.name, name));
    }
    const mjtNum* k = m->numeric_data + m->numeric_adr[id];
    out.push_back({k[0], k[1], k[2]});
  }
  return out;
}

// A PSD value (mm/s²)²/Hz at frequency f (Hz) as Klipper keeps it once it has read a spectrum
// (shaper_calibrate.py, CalibrationData.normalize_to_frequencies): divided by f + 0.1 Hz, and below
// 2·MIN_FREQ = 10 Hz further by exp(1 − (10/(f + 0.1))²), "Remove low-frequency noise".
double KlipperNormalized(double f, double psd) {
  constexpr double kLowBand = 10;  // Hz: 2·Klipper's MIN_FREQ (5 Hz)
  double value = psd / (f + 0.1);
  if (f < kLowBand) value *= std::exp(1 - std::pow(kLowBand / (f + 0.1), 2));
  return value;
}

// The ADXL345's own noise floor on axis `axis`, (m/s²)²/Hz one-sided: its white noise (density²)
// and its rounding to the LSB (LSB²/12 spread over rate/2); sensors/adxl345.h.
double NoiseFloor(const Adxl345Options& adxl, int axis) {
  return std::pow(adxl.noise_density[axis], 2) + std::pow(adxl.resolution, 2) / (6 * adxl.rate);
}

// A peak is taken as a resonance only this far above the noise floor: Klipper counts the PSD
// above a twentieth of its peak as vibration (shaper_calibrate.py, SHAPER_VIBRATION_REDUCTION),
// so a peak under 20 floors leaves the sensor's noise counted as vibration everywhere.
constexpr double kPeakOverNoise = 20;
// The tested axis' acceleration, less the sensor's noise, must reach this fraction of the
// commanded one (RMS over the sweep) for the sensor to move with the axis: a sensor on the part
// the axis moves reads about the command or more (a resonance amplifies it: the bed-slinger's
// bed 2.1×), one on another part its own noise (its toolhead for the bed's Y: 0.3 %).
constexpr double kMovesWithTheAxis = 0.1;

// The names of the model's accelerometer sensors, for a message.
std::string AccelerometerNames(const mjModel* m) {
  std::vector<std::string> names;
  for (int i = 0; i < m->nsensor; ++i) {
    const char* name = mj_id2name(m, mjOBJ_SENSOR, i);
    if (m->sensor_type[i] == mjSENS_ACCELEROMETER && name != nullptr) names.push_back(name);
  }
  return names.empty() ? "none" : fmt::format("{}", fmt::join(names, ", "));
}

// The placement checks (issue 31, item 4): does the accelerometer move with the tested axis (its
// acceleration along it, less its noise, against the commanded acceleration's RMS over the
// sweep, accel_per_hz·f at f rising linearly), and is the response's peak above its noise floor?
void PlacementWarnings(const ResonanceOptions& o, const mjModel* m,
                       const std::vector<AccelSample>& samples, ResonanceResult* r) {
  const int axis = o.axis == 'x' ? 0 : 1;
  const double floor = NoiseFloor(o.adxl, axis);  // (m/s²)²/Hz
  double mean = 0, square = 0;
  for (const AccelSample& s : samples) mean += s.accel[axis];
  mean /= static_cast<double>(samples.size());
  for (const AccelSample& s : samples) square += std::pow(s.accel[axis] - mean, 2);
  square /= static_cast<double>(samples.size());
  const double moved = std::sqrt(std::max(0.0, square - floor * o.adxl.rate / 2));  // m/s² RMS
  const double lo = o.test.min_freq, hi = o.test.max_freq;
  const double mean_f2 = (hi * hi + hi * lo + lo * lo) / 3;               // Hz², ⟨f²⟩
  const double commanded = o.test.accel_per_hz * std::sqrt(mean_f2 / 2);  // m/s² RMS
  if (moved < kMovesWithTheAxis * commanded) {
    r->warnings.push_back(fmt::format(
        "the accelerometer '{}' does not move with the {} axis: along {} it read {:.1f} % of the "
        "commanded acceleration ({:.0f} mm/s² RMS over the sweep, less its own noise), so the "
        "fits below follow its noise; give --accelerometer the sensor on the part the {} axis "
        "moves (the model's accelerometers: {}; on a bed-slinger's Y axis, its bed's)",
        o.accelerometer, o.axis, o.axis, 100 * moved / commanded, commanded * kMm, o.axis,
        AccelerometerNames(m)));
  }
  const double peak = *std::max_element(r->psd.begin(), r->psd.end());  // (m/s²)²/Hz
  if (peak < kPeakOverNoise * floor) {
    r->warnings.push_back(fmt::format(
        "the {} axis' largest response, {:.3g} (mm/s²)²/Hz at {:.1f} Hz, is not above the "
        "accelerometer's noise floor ({:.3g} (mm/s²)²/Hz; a resonance is taken from {:g}× it): the "
        "peak and the fits may be noise",
        o.axis, peak * kMm * kMm, r->peak_frequency, floor * kMm * kMm, kPeakOverNoise));
  }
}

// The PSD's segment in samples (0.5 s, SPEC §9), after checking that `samples` accelerometer
// samples fill one and that the tested band holds at least three of its bins (k·rate/segment Hz).
// Called before the simulation with the samples it will give (issue 33: the test checked only
// after simulating, and left PREFIX_raw.csv behind) and on the samples it gave.
std::size_t CheckSpectrumFits(const ResonanceOptions& o, std::size_t samples) {
  const double rate = o.adxl.rate;  // Hz
  const auto segment = static_cast<std::size_t>(std::lround(0.5 * rate));
  if (samples < segment) {
    throw std::invalid_argument(fmt::format(
        "the test gives {} accelerometer samples, fewer than one 0.5 s segment ({}): lengthen it "
        "(--min-freq, --max-freq, --hz-per-sec)",
        samples, segment));
  }
  const double bin = rate / static_cast<double>(segment);  // Hz
  const double bins = std::floor(o.test.max_freq / bin) - std::ceil(o.test.min_freq / bin) + 1;
  if (bins < 3) {
    throw std::invalid_argument(fmt::format(
        "--min-freq {:g} to --max-freq {:g}: the PSD's bins are {:g} Hz apart (0.5 s segments); "
        "give a band of at least three of them",
        o.test.min_freq, o.test.max_freq, bin));
  }
  return segment;
}

// The PSDs (Welch, 0.5 s Hann segments, SPEC §9) of the three axes in Klipper's units, the shapers
// fitted to the tested axis' and PREFIX_psd.csv.
void WriteResponse(const ResonanceOptions& o, const std::vector<AccelSample>& samples,
                   ResonanceResult* r) {
  const double rate = o.adxl.rate;  // Hz
  const std::size_t segment = CheckSpectrumFits(o, samples.size());
  std::array<Spectrum, 3> spectra;
  for (int a = 0; a < 3; ++a) {
    std::vector<double> values(samples.size());
    for (size_t i = 0; i < samples.size(); ++i) values[i] = samples[i].accel[a] * kMm;
    spectra[a] = Welch(values, rate, segment);
  }
  const int axis = o.axis == 'x' ? 0 : 1;
  std::vector<double> band_f, band_psd;
  std::vector<std::array<double, 4>> rows;  // x, y, z, xyz
  for (size_t k = 0; k < spectra[0].frequency.size(); ++k) {
    const double f = spectra[0].frequency[k];
    if (f < o.test.min_freq || f > o.test.max_freq) continue;
    const double x = spectra[0].psd[k], y = spectra[1].psd[k], z = spectra[2].psd[k];
    band_f.push_back(f);
    band_psd.push_back(spectra[axis].psd[k]);
    rows.push_back({x, y, z, x + y + z});
  }
  r->frequency = band_f;
  r->psd = band_psd;  // to (m/s²)²/Hz, as ResonanceResult documents it
  for (double& v : r->psd) v /= kMm * kMm;
  // The largest bin, refined by the parabola through it and its neighbours: the bins are 2 Hz
  // apart (0.5 s segments), several percent of a printer's 30-120 Hz resonance.
  const size_t top = std::max_element(band_psd.begin(), band_psd.end()) - band_psd.begin();
  r->peak_frequency = band_f[top];
  if (top > 0 && top + 1 < band_psd.size()) {
    const double below = band_psd[top - 1], at = band_psd[top], above = band_psd[top + 1];
    const double curvature = below - 2 * at + above;
    if (curvature < 0) {
      r->peak_frequency += 0.5 * (below - above) / curvature * (band_f[top + 1] - band_f[top]);
    }
  }
  FitOptions fit;
  fit.min_frequency = o.test.min_freq;
  fit.max_frequency = o.test.max_freq;
  r->fits = FitShapers(band_f, band_psd, fit);
  const ShaperFit best = Recommend(r->fits);
  for (size_t i = 0; i < r->fits.size(); ++i) {
    if (r->fits[i].type == best.type) r->recommended = static_cast<int>(i);
  }

  // Klipper's calibration CSV, as `calibrate_shaper.py --csv` writes it (its
  // ShaperCalibrate.save_calibration_data) and reads it back (its parse_log): the header
  // `freq,psd_x,psd_y,psd_z,psd_xyz,shapers:,NAME(FREQ),…`, then per frequency `%.1f`, the four
  // PSDs `%.3e`, an empty column under `shapers:` and each shaper's remaining vibration `%.3f`.
  // With shapers in it Klipper takes the PSDs as already normalized to frequency, so they are
  // written so (KlipperNormalized): (mm/s²)²/Hz per Hz. The units are documented in resonance.h
  // and the README, not in the header, which Klipper matches as text.
  std::string text = "freq,psd_x,psd_y,psd_z,psd_xyz,shapers:";
  for (const ShaperFit& f : r->fits) text += fmt::format(",{}({:.1f})", f.shaper.name, f.frequency);
  text += "\n";
  for (size_t k = 0; k < rows.size(); ++k) {
    text += fmt::format("{:.1f}", band_f[k]);
    for (double psd : rows[k]) text += fmt::format(",{:.3e}", KlipperNormalized(band_f[k], psd));
    text += ",";
    for (const ShaperFit& f : r->fits) {  // the worst over the test dampings, as fitted
      double v = 0;
      for (double zeta : fit.test_dampings) {
        v = std::max(v, RemainingVibration(f.shaper, band_f[k], zeta));
      }
      text += fmt::format(",{:.3f}", v);
    }
    text += "\n";
  }
  OutputFile csv(o.out + "_psd.csv");
  csv.Write(text.data(), text.size());
  csv.Commit();
}

}  // namespace

void WriteKlipperAccelLog(const std::string& path, const std::vector<AccelSample>& samples) {
  CsvWriter raw(path, {"#time", "accel_x", "accel_y", "accel_z"});
  for (const AccelSample& s : samples) {
    const double row[] = {s.time, s.accel[0] * kMm, s.accel[1] * kMm, s.accel[2] * kMm};
    raw.Row(row);
  }
  raw.Commit();
}

ResonanceResult RunResonanceTest(const ResonanceOptions& o, std::ostream& progress) {
  Validate(o.test);
  if (o.axis != 'x' && o.axis != 'y') {
    throw std::invalid_argument(fmt::format("--axis {}: must be x or y", o.axis));
  }
  CheckSpectrumFits(o, static_cast<std::size_t>(o.test.Duration() * o.adxl.rate));
  const StepperModel sm = LoadStepperModel(o.model, o.overrides);
  const mjModel* m = sm.model.get();
  const auto kinematics = Kinematics(m, sm.steppers);
  const int accel_adr = AccelerometerAddress(m, o.accelerometer);
  DataPtr data(mj_makeData(m));
  mjData* d = data.get();
  mj_forward(m, d);

  // Each stepper's start angle and step angle; the commands follow the toolhead's excursion.
  const int axis = o.axis == 'x' ? 0 : 1;
  std::vector<double> theta0, step_angle;
  for (const StepperActuator& s : sm.steppers) {
    theta0.push_back(d->actuator_length[s.outadr]);
    step_angle.push_back(StepAngle(s.config));
    if (s.config.profile.kind != ProfileKind::kNone) {
      throw std::invalid_argument(fmt::format(
          "stepper '{}' has its own motion profile: the resonance test commands the rotor angle "
          "itself (set profile=none)",
          s.name));
    }
  }
  const double h = m->opt.timestep;
  const long steps = std::lround(o.test.Duration() / h);
  ResonanceExcitation excitation(o.test);
  Adxl345 adxl(o.adxl, d->time);
  std::vector<AccelSample> samples;
  samples.reserve(static_cast<size_t>(o.test.Duration() * o.adxl.rate) + 16);
  double previous = 0;  // m, the excursion at the step's start
  const auto start = std::chrono::steady_clock::now();
  auto last_report = start;
  for (long k = 0; k < steps; ++k) {
    const double t = d->time;
    const double next = excitation.Advance(h);  // m, at the step's end
    for (size_t i = 0; i < sm.steppers.size(); ++i) {
      const StepperActuator& s = sm.steppers[i];
      const double ratio = kinematics[i][axis];       // rad/m
      const double theta = theta0[i] + ratio * next;  // rad, at the step's end
      switch (s.config.input) {
        case InputMode::kSteps:
          d->ctrl[s.ctrladr] = std::round(theta / step_angle[i]);
          break;
        case InputMode::kVelocity:
          d->ctrl[s.ctrladr] = ratio * (next - previous) / h;
          break;
        case InputMode::kPosition:
          d->ctrl[s.ctrladr] = theta0[i] + ratio * 0.5 * (previous + next);
          break;
      }
    }
    previous = next;
    ThrowIfCancelled();  // (cancel.h)
    mj_step(m, d);
    if (const std::string unstable = InstabilityMessage(d, t); !unstable.empty()) {
      throw std::runtime_error(unstable);
    }
    // After mj_step the sensors describe the step's start: held over [t, t + h).
    const mjtNum* a = d->sensordata + accel_adr;
    adxl.Add(t, t + h, {a[0], a[1], a[2]}, &samples);
    const auto now = std::chrono::steady_clock::now();
    if (o.progress && now - last_report > std::chrono::seconds(2)) {
      last_report = now;
      fmt::print(progress, "\r  {:5.1f} % ({:.1f} Hz, {:.1f} / {:.1f} s simulated)",
                 100.0 * (k + 1) / steps, excitation.frequency(), d->time, o.test.Duration());
      progress.flush();
    }
  }
  if (o.progress && last_report != start) fmt::print(progress, "\n");

  WriteKlipperAccelLog(o.out + "_raw.csv", samples);  // Klipper's raw accelerometer log

  ResonanceResult result;
  result.samples = static_cast<long>(samples.size());
  WriteResponse(o, samples, &result);
  PlacementWarnings(o, m, samples, &result);
  return result;
}

}  // namespace mjstepper::tools
