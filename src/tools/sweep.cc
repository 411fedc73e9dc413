#include "sweep.h"

#include <fmt/format.h>
#include <fmt/ostream.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <ostream>
#include <stdexcept>
#include <thread>

#include "config.h"
#include "core/analysis.h"
#include "core/command_profile.h"
#include "core/signals.h"
#include "core/units.h"
#include "csv_writer.h"
#include "stepper_model.h"

namespace mjstepper::tools {
namespace {

double ParseSpeed(const std::string& number, const std::string& unit, const std::string& whole) {
  double v = 0;
  if (!ParseFiniteDouble(number, &v)) {
    throw std::invalid_argument(fmt::format("--speeds {}: \"{}\" is not a number", whole, number));
  }
  if (unit == "rpm" || unit == "r/min") return RpmToRadPerSec(v);
  if (unit == "rad/s") return v;
  throw std::invalid_argument(fmt::format("--speeds {}: unit must be rpm, r/min or rad/s", whole));
}

// One constant-speed run on its own mjData.
SweepPoint RunOne(const mjModel* m, const StepperActuator& s, double speed, const SweepOptions& o) {
  DataPtr data(mj_makeData(m));
  mjData* d = data.get();
  mj_forward(m, d);
  const double theta_start = d->actuator_length[s.outadr];
  const double ramp = std::max(speed / o.acceleration, 1e-6);
  const CommandProfile profile =
      CommandProfile::Parse(fmt::format("ramp(0rad/s, {:.17g}rad/s, {:.17g}s)", speed, ramp));
  const double h = m->opt.timestep;
  const long start = std::lround((ramp + o.settle) / h);
  const long steps = start + std::lround(o.measure / h);
  std::vector<double> error;
  error.reserve(steps - start);
  for (long k = 0; k < steps; ++k) {
    const double t = d->time;
    d->ctrl[s.ctrladr] = profile.ControlForStep(t, h, s.config.input, theta_start);
    mj_step(m, d);
    if (k >= start) error.push_back(d->actuator_velocity[s.outadr] - profile.Speed(t));
  }
  SweepPoint p;
  p.speed = speed;
  p.rms_error = Rms(error);
  p.peak_to_peak_error = PeakToPeak(error);
  p.dominant_frequency = DominantFrequency(error, 1.0 / h, 5.0, 1000.0, 0.5);
  p.lost_steps = d->sensordata[s.sensor_adr + SignalIndex("lost_steps")];
  return p;
}

}  // namespace

std::vector<double> ParseSpeedList(const std::string& text) {
  size_t unit_at = text.find_last_of("0123456789.") + 1;
  if (unit_at == 0 || unit_at > text.size()) unit_at = text.size();
  const std::string unit = text.substr(unit_at);
  const std::string body = text.substr(0, unit_at);
  std::vector<double> speeds;
  if (body.find(':') != std::string::npos) {
    const size_t a = body.find(':'), b = body.find(':', a + 1);
    if (b == std::string::npos) {
      throw std::invalid_argument(fmt::format("--speeds {}: expected from:to:step", text));
    }
    const double from = ParseSpeed(body.substr(0, a), unit, text);
    const double to = ParseSpeed(body.substr(a + 1, b - a - 1), unit, text);
    const double step = ParseSpeed(body.substr(b + 1), unit, text);
    if (!(step > 0) || to < from) {
      throw std::invalid_argument(fmt::format("--speeds {}: need step > 0 and to >= from", text));
    }
    const long n = std::lround(std::floor((to - from) / step + 1e-9));
    for (long k = 0; k <= n; ++k) speeds.push_back(from + k * step);
  } else {
    size_t start = 0;
    while (start <= body.size()) {
      const size_t comma = body.find(',', start);
      speeds.push_back(ParseSpeed(body.substr(start, comma - start), unit, text));
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
  }
  return speeds;
}

std::vector<SweepPoint> Sweep(const SweepOptions& o, std::ostream& progress) {
  if (o.speeds.empty()) throw std::invalid_argument("--speeds: no speed to sweep");
  if (!(o.settle >= 0) || !(o.measure > 0) || !(o.acceleration > 0)) {
    throw std::invalid_argument(fmt::format(
        "sweep: settle = {} s (>= 0), measure = {} s (> 0), acceleration = {} rad/s² (> 0)",
        o.settle, o.measure, o.acceleration));
  }
  const StepperModel sm = LoadStepperModel(o.model, o.overrides);
  const StepperActuator* target = nullptr;
  for (const StepperActuator& s : sm.steppers) {
    if (o.actuator.empty() ? sm.steppers.size() == 1 : s.name == o.actuator) target = &s;
  }
  if (target == nullptr) {
    std::string names;
    for (const StepperActuator& s : sm.steppers) names += (names.empty() ? "" : ", ") + s.name;
    throw std::invalid_argument(
        fmt::format("--actuator '{}': not a stepper of {} (steppers: {}){}", o.actuator, o.model,
                    names, o.actuator.empty() ? "; name one with --actuator" : ""));
  }
  std::vector<SweepPoint> points(o.speeds.size());
  std::atomic<size_t> next{0}, done{0};
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const size_t workers = std::min<size_t>(o.threads > 0 ? o.threads : cores, o.speeds.size());
  {
    std::vector<std::jthread> pool;
    for (size_t w = 0; w < workers; ++w) {
      pool.emplace_back([&] {
        for (size_t i = next++; i < o.speeds.size(); i = next++) {
          points[i] = RunOne(sm.model.get(), *target, o.speeds[i], o);
          ++done;
        }
      });
    }
    while (o.progress && done < o.speeds.size()) {
      fmt::print(progress, "\r  sweep: {}/{} speeds ({} threads)", done.load(), o.speeds.size(),
                 workers);
      progress.flush();
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
    }
  }
  if (o.progress)
    fmt::print(progress, "\r  sweep: {0}/{0} speeds ({1} threads)\n", o.speeds.size(), workers);
  return points;
}

void WriteSweepCsv(const std::string& path, const std::vector<SweepPoint>& points) {
  CsvWriter csv(path, {"speed[r/min]", "speed[rad/s]", "velocity_error_rms[r/min]",
                       "velocity_error_peak_to_peak[r/min]", "dominant_frequency[Hz]",
                       "lost_steps[full steps]"});
  for (const SweepPoint& p : points) {
    const double row[] = {RadPerSecToRpm(p.speed),     p.speed,
                          RadPerSecToRpm(p.rms_error), RadPerSecToRpm(p.peak_to_peak_error),
                          p.dominant_frequency,        p.lost_steps};
    csv.Row(row);
  }
  csv.Commit();
}

}  // namespace mjstepper::tools
