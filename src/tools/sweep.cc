#include "sweep.h"

#include <fmt/format.h>
#include <fmt/ostream.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <functional>
#include <iterator>
#include <mutex>
#include <numbers>
#include <ostream>
#include <span>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "cancel.h"
#include "config.h"
#include "core/analysis.h"
#include "core/command_profile.h"
#include "core/signals.h"
#include "core/units.h"
#include "csv_writer.h"
#include "options.h"
#include "stepper_model.h"

namespace mjstepper::tools {
namespace {

// A run at constant speed on its own mjData: the stepper's command ramps from rest at
// `acceleration` to `speed`, then holds it; Step() sets ctrl and steps.
struct SpeedRun {
  SpeedRun(const mjModel* model, const StepperActuator& stepper, double speed, double acceleration)
      : m(model),
        s(stepper),
        data(mj_makeData(model)),
        d(data.get()),
        ramp(std::max(std::abs(speed) / acceleration, 1e-6)),
        profile(CommandProfile::Parse(
            fmt::format("ramp(0rad/s, {:.17g}rad/s, {:.17g}s)", speed, ramp))) {
    mj_forward(m, d);
    theta_start = d->actuator_length[s.outadr];
  }
  void Step() {
    d->ctrl[s.ctrladr] = profile.ControlForStep(d->time, m->opt.timestep, s.config.input,
                                                theta_start, StepAngle(s.config));
    const double t = d->time;
    ThrowIfCancelled();  // (cancel.h)
    mj_step(m, d);
    if (const std::string unstable = InstabilityMessage(d, t); !unstable.empty()) {
      throw std::runtime_error(
          fmt::format("the run at {:.6g} rad/s: {}", profile.Speed(t), unstable));
    }
  }

  const mjModel* m;
  const StepperActuator& s;
  DataPtr data;
  mjData* d;
  double ramp;  // s, the ramp's duration
  CommandProfile profile;
  double theta_start = 0;  // rad
};

// One constant-speed run on its own mjData.
SweepPoint RunOne(const mjModel* m, const StepperActuator& s, double speed, const SweepOptions& o) {
  SpeedRun run(m, s, speed, o.acceleration);
  const double h = m->opt.timestep;
  const long start = std::lround((run.ramp + o.settle) / h);
  const long steps = start + std::lround(o.measure / h);
  std::vector<double> error;
  error.reserve(steps - start);
  for (long k = 0; k < steps; ++k) {
    const double t = run.d->time;
    run.Step();
    // The rotor's speed at the step's start (the `omega` signal: its own when sub-stepped).
    static const int kOmega = SignalIndex("omega");
    if (k >= start)
      error.push_back(run.d->sensordata[s.sensor_adr + kOmega] - run.profile.Speed(t));
  }
  SweepPoint p;
  p.speed = speed;
  p.rms_error = Rms(error);
  p.peak_to_peak_error = PeakToPeak(error);
  p.dominant_frequency = DominantFrequency(error, 1.0 / h, 5.0, 1000.0, 0.5);
  p.lost_steps = run.d->sensordata[s.sensor_adr + SignalIndex("lost_steps")];
  return p;
}

// Whether the drive has lost its rotor: a counted slip (open-loop drives), or a tracking error of
// more than the slip threshold 5π/4 electrical (closed-loop drives, which count none).
bool Slipped(const mjData* d, const StepperActuator& s) {
  static const int kLost = SignalIndex("lost_steps"), kAngle = SignalIndex("load_angle");
  const double* signals = d->sensordata + s.sensor_adr;
  const double cycles = signals[kLost] / 4;
  return cycles != 0 || std::abs(signals[kAngle] - kTwoPi * cycles) > 1.25 * std::numbers::pi;
}

// One pull-out run: to speed, settle, then a load torque rising at o.rate against the motion
// until the first slip. The pull-out torque is the load when the slip is counted (5π/4 past the
// cell's centre), at most the largest 10 ms mean (kPullOutWindow) of the motor's own torque along
// the load since the load began: a rising load overshoots the fold by the time the rotor's inertia
// takes to leave it (at 0.5 N·m/s that read 2-5 % above the holding torque, issue 29), while the
// motor's torque never exceeds Km·|i| (S-4), so at standstill the curve never reads above the
// holding torque. (At speed the mean motor torque also carries the bench's damping B·ω, and the
// load at the slip is then the smaller.)
PullOutPoint RunPullOut(const mjModel* m, const StepperActuator& s, double speed,
                        const PullOutOptions& o) {
  SpeedRun run(m, s, speed, o.acceleration);
  mjData* d = run.d;
  const double load_start = run.ramp + o.settle;  // s
  const double against = speed < 0 ? 1.0 : -1.0;  // the load opposes the motion
  static const int kTorque = SignalIndex("torque_total");
  // The motor's torque along the load (N·m) over the last kPullOutWindow: a ring of samples.
  const size_t window =
      std::max<size_t>(1, static_cast<size_t>(std::lround(kPullOutWindow / m->opt.timestep)));
  std::vector<double> ring(window, 0.0);
  size_t filled = 0;
  double ring_sum = 0;
  double most_torque = 0;  // N·m, the largest mean motor torque along the load since it began
  PullOutPoint p{.speed = speed};
  while (true) {
    const double t = d->time;
    const double load = t < load_start ? 0.0 : o.rate * (t - load_start);  // N·m, rotor side
    if (load > o.max_torque) {
      p.torque = o.max_torque;
      p.held_max = true;
      break;
    }
    // τ·r on the dofs, r the moment row at this pose (gear at a joint's dof: gear·τ).
    const std::vector<double> row = MomentRow(m, d, s.actuator);
    for (int i = 0; i < m->nv; ++i) {
      if (row[i] != 0) d->qfrc_applied[i] = against * row[i] * load;
    }
    run.Step();
    mj_forward(m, d);  // the signals of the new state
    const double motor = -against * d->sensordata[s.sensor_adr + kTorque];  // N·m, along the load
    ring_sum += motor - ring[filled % window];
    ring[filled % window] = motor;
    ++filled;
    if (t >= load_start) {
      most_torque = std::max(most_torque, ring_sum / static_cast<double>(std::min(filled, window)));
    }
    if (Slipped(d, s)) {
      p.torque = t < load_start ? 0.0 : std::min(load, most_torque);
      p.slipped_unloaded = t < load_start;
      break;
    }
  }
  return p;
}

// The stepper named `actuator`, or the model's only one.
const StepperActuator& FindTarget(const StepperModel& sm, const std::string& actuator,
                                  const std::string& model) {
  const StepperActuator* target = nullptr;
  for (const StepperActuator& s : sm.steppers) {
    if (actuator.empty() ? sm.steppers.size() == 1 : s.name == actuator) target = &s;
  }
  if (target == nullptr) {
    std::string names;
    for (const StepperActuator& s : sm.steppers) names += (names.empty() ? "" : ", ") + s.name;
    throw std::invalid_argument(fmt::format("--actuator '{}': not a stepper of {} (steppers: {}){}",
                                            actuator, model, names,
                                            actuator.empty() ? "; name one with --actuator" : ""));
  }
  return *target;
}

// run(i) for i in [0, n) on `threads` workers (0: one per core), each run on its own mjData, with
// a progress line naming `what`.
void ParallelFor(size_t n, int threads, bool show_progress, const char* what,
                 std::ostream& progress, const std::function<void(size_t)>& run) {
  std::atomic<size_t> next{0}, done{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;  // the first run's error, rethrown here once every worker stopped
  std::mutex error_mutex;
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const size_t workers = std::min<size_t>(threads > 0 ? threads : cores, n);
  {
    std::vector<std::jthread> pool;
    for (size_t w = 0; w < workers; ++w) {
      pool.emplace_back([&] {
        for (size_t i = next++; i < n && !failed; i = next++) {
          try {
            run(i);
          } catch (...) {
            const std::lock_guard lock(error_mutex);
            if (!error) error = std::current_exception();
            failed = true;
          }
          ++done;
        }
      });
    }
    while (show_progress && done < n && !failed) {
      fmt::print(progress, "\r  {}: {}/{} speeds ({} threads)", what, done.load(), n, workers);
      progress.flush();
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
    }
  }
  if (error) {
    if (show_progress) fmt::print(progress, "\n");
    std::rethrow_exception(error);
  }
  if (show_progress) {
    fmt::print(progress, "\r  {0}: {1}/{1} speeds ({2} threads)\n", what, n, workers);
  }
}

// The rotor's speeds (rad/s) for a list given at the rotor or, `at_carriage`, in m/s at the
// stepper's carriage (README, "Linear axes"), each within Range("speed") at the rotor.
std::vector<double> RotorSpeeds(const mjModel* m, const StepperActuator& s,
                                const std::vector<double>& speeds, bool at_carriage) {
  if (!at_carriage) return speeds;
  const std::optional<double> rad_per_metre = RadPerMetre(m, s);
  if (!rad_per_metre) {
    throw std::invalid_argument(fmt::format(
        "--speeds in mm/s or m/s: stepper '{}' drives {}, which has no carriage; declare its "
        "pulley (pulley_teeth, belt_pitch) or lead screw (lead) in its <config>, or give the "
        "speeds at the rotor (rpm, r/min, rad/s)",
        s.name, TransmissionTarget(m, s)));
  }
  std::vector<double> rotor(speeds.size());
  for (size_t i = 0; i < speeds.size(); ++i) {
    rotor[i] = speeds[i] * *rad_per_metre;
    RequireInRange("--speeds", Range("speed"), rotor[i],
                   fmt::format("{:g} mm/s is {:g} rad/s at the rotor", 1e3 * speeds[i], rotor[i]));
  }
  return rotor;
}

// A point's carriage columns on a linear axis (its commanded speed and, for a pull-out, the
// force at the carriage); left NaN on a rotary one.
template <class Point>
void AtCarriage(const mjModel* m, const StepperActuator& s, Point* p) {
  const std::optional<double> rad_per_metre = RadPerMetre(m, s);
  if (!rad_per_metre) return;
  p->carriage_speed = p->speed / *rad_per_metre;
  if constexpr (requires { p->force; }) p->force = p->torque * std::abs(*rad_per_metre);
}

// The simulated seconds of one speed's run (SpeedRun: the ramp, then the settling and the
// measured window, or the load's rise to max_torque).
double RunSeconds(double speed, const SweepOptions& o) {
  return std::abs(speed) / o.acceleration + o.settle + o.measure;
}
double RunSeconds(double speed, const PullOutOptions& o) {
  return std::abs(speed) / o.acceleration + o.settle + o.max_torque / o.rate;
}

// Says the wall time of the runs over `speeds` on the workers ParallelFor takes, estimated
// before they start (stepper_model.h's SayEstimate: with the progress, or when long).
template <class Options>
void Estimate(const mjModel* m, const std::vector<double>& speeds, const Options& o,
              const std::string& what, std::ostream& progress, size_t repeats = 1) {
  double seconds = 0;  // simulated
  for (double speed : speeds) seconds += RunSeconds(speed, o);
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const double workers = static_cast<double>(
      std::min<size_t>(o.threads > 0 ? o.threads : cores, std::max<size_t>(1, speeds.size())));
  SayEstimate(progress, o.progress,
              fmt::format("{}: {} runs, {:.0f} s simulated", what, speeds.size() * repeats,
                          seconds * repeats),
              seconds * repeats / m->opt.timestep * WallTimePerStep(m) / workers);
}

// run(model, stepper, speed, options) for each of the options' speeds, on all cores.
template <class Point, class Options, class Run, class Check>
std::vector<Point> OverSpeeds(const Options& o, const char* what, std::ostream& progress, Run run,
                              Check check) {
  const ToolJudgesTimestep judged;  // judged below, each warning once
  StepperModel sm;
  bool judge = true;
  if constexpr (requires { o.model_text; }) {
    sm = LoadStepperModel(o.model, o.overrides, o.model_text);
    judge = o.judge_timestep;
  } else {
    sm = LoadStepperModel(o.model, o.overrides);
  }
  if (judge) ApplyTimestepRule(sm, -1, o.model, o.allow_coarse, progress);
  check(sm.model.get());
  const StepperActuator& target = FindTarget(sm, o.actuator, o.model);
  const std::vector<double> speeds =
      RotorSpeeds(sm.model.get(), target, o.speeds, o.speeds_at_carriage);
  Estimate(sm.model.get(), speeds, o, what, progress);
  std::vector<Point> points(speeds.size());
  ParallelFor(speeds.size(), o.threads, o.progress, what, progress, [&](size_t i) {
    points[i] = run(sm.model.get(), target, speeds[i], o);
    AtCarriage(sm.model.get(), target, &points[i]);
  });
  return points;
}

}  // namespace

namespace {

// The speeds of a sweep, pull-out or map, within their bounds (options.h).
void CheckSpeeds(const std::vector<double>& speeds, double runs) {
  RequireInRange("--speeds", Range("speeds"), runs, fmt::format("({:g} runs)", runs));
  for (double speed : speeds) RequireInRange("--speeds", Range("speed"), speed);
}

// A sweep's timing within its bounds, and a measured window of at least kMinMeasuredSteps of the
// model's steps.
void CheckSweepTiming(const SweepOptions& o, const mjModel* m) {
  RequireInRange("--settle", Range("settle"), o.settle);
  RequireInRange("--measure", Range("measure"), o.measure);
  if (!(o.acceleration > 0) || !std::isfinite(o.acceleration)) {
    throw std::invalid_argument(
        fmt::format("sweep: acceleration = {} rad/s²: must be finite and > 0", o.acceleration));
  }
  if (!(o.measure >= kMinMeasuredSteps * m->opt.timestep)) {
    throw std::invalid_argument(
        fmt::format("--measure {:g}: must hold at least {} timesteps of the model ({:g} s)",
                    o.measure, kMinMeasuredSteps, kMinMeasuredSteps * m->opt.timestep));
  }
}

}  // namespace

std::vector<SweepPoint> Sweep(const SweepOptions& o, std::ostream& progress) {
  CheckSpeeds(o.speeds, static_cast<double>(o.speeds.size()));
  return OverSpeeds<SweepPoint>(o, "sweep", progress, RunOne,
                                [&](const mjModel* m) { CheckSweepTiming(o, m); });
}

std::vector<PullOutPoint> PullOut(const PullOutOptions& o, std::ostream& progress) {
  CheckSpeeds(o.speeds, static_cast<double>(o.speeds.size()));
  RequireInRange("--rate", Range("rate"), o.rate);
  RequireInRange("--max-torque", Range("max-torque"), o.max_torque);
  RequireInRange("--settle", Range("settle"), o.settle);
  if (!(o.max_torque / o.rate <= 1000) || !(o.acceleration > 0) || !std::isfinite(o.acceleration)) {
    throw std::invalid_argument(fmt::format(
        "pullout: max torque {:g} N·m / rate {:g} N·m/s must be at most 1000 s, acceleration {:g} "
        "rad/s² finite and > 0",
        o.max_torque, o.rate, o.acceleration));
  }
  return OverSpeeds<PullOutPoint>(o, "pullout", progress, RunPullOut, [](const mjModel*) {});
}

namespace {

// Whether a result is a linear axis's: its points carry the carriage's speed (AtCarriage).
template <class Point>
bool Linear(const std::vector<Point>& points) {
  return !points.empty() && std::isfinite(points.front().carriage_speed);
}

}  // namespace

void WritePullOutCsv(const std::string& path, const std::vector<PullOutPoint>& points) {
  std::vector<std::string> header = {"speed[r/min]", "speed[rad/s]", "pull_out_torque[N·m]",
                                     "slipped_before_load[1/0]", "held_max_torque[1/0]"};
  const bool linear = Linear(points);
  if (linear) header.insert(header.end(), {"carriage_speed[mm/s]", "pull_out_force[N]"});
  CsvWriter csv(path, header, 17);  // every digit, as the sweep's
  for (const PullOutPoint& p : points) {
    const double row[] = {RadPerSecToRpm(p.speed),
                          p.speed,
                          p.torque,
                          p.slipped_unloaded ? 1.0 : 0.0,
                          p.held_max ? 1.0 : 0.0,
                          1e3 * p.carriage_speed,
                          p.force};
    csv.Row(std::span<const double>(row, linear ? 7 : 5));
  }
  csv.Commit();
}

namespace {

// A copy of m with the parameter ("stiffness:JOINT" or "mass:BODY") set to value.
ModelPtr WithParameter(const mjModel* m, const std::string& parameter, double value) {
  ModelPtr copy(mj_copyModel(nullptr, m));
  const size_t colon = parameter.find(':');
  const std::string kind = parameter.substr(0, colon);
  const std::string name = colon == std::string::npos ? "" : parameter.substr(colon + 1);
  if (kind == "stiffness") {
    const int joint = mj_name2id(copy.get(), mjOBJ_JOINT, name.c_str());
    if (joint < 0) {
      throw std::invalid_argument(fmt::format("--vary {}: no joint named '{}'", parameter, name));
    }
    RequireInRange("--vary", Range("stiffness"), value, fmt::format("{}={}", parameter, value));
    copy->jnt_stiffness[joint] = value;
  } else if (kind == "mass") {
    RequireInRange("--vary", Range("mass"), value, fmt::format("{}={}", parameter, value));
    SetBodyMass(copy.get(), name, value);
  } else {
    throw std::invalid_argument(fmt::format(
        "--vary {}: expected stiffness:JOINT (N·m/rad or N/m) or mass:BODY (kg)", parameter));
  }
  return copy;
}

}  // namespace

std::vector<MapPoint> Map(const MapOptions& o, std::ostream& progress) {
  const SweepOptions& s = o.sweep;
  if (o.values.empty()) throw std::invalid_argument("--vary: no value");
  CheckSpeeds(s.speeds, static_cast<double>(s.speeds.size() * o.values.size()));
  const ToolJudgesTimestep judged;  // judged below, each warning once
  const StepperModel sm = LoadStepperModel(s.model, s.overrides);
  // On the model as given: a map's stiffer values can only be judged per value, and its
  // parameter is what the map varies (the resonance it looks for).
  ApplyTimestepRule(sm, -1, s.model, s.allow_coarse, progress);
  CheckSweepTiming(s, sm.model.get());
  const StepperActuator& target = FindTarget(sm, s.actuator, s.model);
  std::vector<ModelPtr> models;
  for (double value : o.values) models.push_back(WithParameter(sm.model.get(), o.parameter, value));
  const std::vector<double> speeds =
      RotorSpeeds(sm.model.get(), target, s.speeds, s.speeds_at_carriage);
  const size_t n = speeds.size();
  Estimate(sm.model.get(), speeds, s, "map", progress, o.values.size());
  std::vector<MapPoint> points(o.values.size() * n);
  ParallelFor(points.size(), s.threads, s.progress, "map", progress, [&](size_t i) {
    points[i] = {.value = o.values[i / n],
                 .point = RunOne(models[i / n].get(), target, speeds[i % n], s)};
    AtCarriage(sm.model.get(), target, &points[i].point);
  });
  return points;
}

namespace {

const char* const kSweepHeader[] = {"speed[r/min]",
                                    "speed[rad/s]",
                                    "velocity_error_rms[r/min]",
                                    "velocity_error_peak_to_peak[r/min]",
                                    "dominant_frequency[Hz]",
                                    "lost_steps[full steps]"};
const char* const kCarriageSpeedHeader = "carriage_speed[mm/s]";  // a linear axis's only

// A sweep point's columns, after `row`'s first `keep` (the carriage's speed on a linear axis).
void SweepRow(const SweepPoint& p, bool linear, size_t keep, std::vector<double>* row) {
  row->resize(keep);
  row->insert(row->end(),
              {RadPerSecToRpm(p.speed), p.speed, RadPerSecToRpm(p.rms_error),
               RadPerSecToRpm(p.peak_to_peak_error), p.dominant_frequency, p.lost_steps});
  if (linear) row->push_back(1e3 * p.carriage_speed);
}

std::vector<std::string> SweepHeader(bool linear) {
  std::vector<std::string> header(std::begin(kSweepHeader), std::end(kSweepHeader));
  if (linear) header.push_back(kCarriageSpeedHeader);
  return header;
}

}  // namespace

void WriteMapCsv(const std::string& path, const std::string& parameter,
                 const std::vector<MapPoint>& points) {
  const bool linear = !points.empty() && std::isfinite(points.front().point.carriage_speed);
  std::vector<std::string> header = SweepHeader(linear);
  header.insert(header.begin(), parameter);
  CsvWriter csv(path, header, 17);  // every digit, as the sweep's
  std::vector<double> row;
  for (const MapPoint& m : points) {
    row.assign(1, m.value);
    SweepRow(m.point, linear, 1, &row);
    csv.Row(row);
  }
  csv.Commit();
}

void WriteSweepCsv(const std::string& path, const std::vector<SweepPoint>& points) {
  // Every digit (a few rows): the Python package's Ray sweep is checked against it to 1e-12.
  const bool linear = Linear(points);
  CsvWriter csv(path, SweepHeader(linear), 17);
  std::vector<double> row;
  for (const SweepPoint& p : points) {
    SweepRow(p, linear, 0, &row);
    csv.Row(row);
  }
  csv.Commit();
}

std::vector<SweepPoint> ReadSweepCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(fmt::format("cannot read {}", path));
  std::string line;
  const std::string header = fmt::format("{}", fmt::join(SweepHeader(false), ","));
  const std::string linear_header = fmt::format("{}", fmt::join(SweepHeader(true), ","));
  if (!std::getline(in, line) || (line != header && line != linear_header)) {
    throw std::runtime_error(
        fmt::format("{}: not a sweep CSV (expected the header {}, on a linear axis with {})", path,
                    header, kCarriageSpeedHeader));
  }
  const size_t count = line == header ? std::size(kSweepHeader) : std::size(kSweepHeader) + 1;
  std::vector<SweepPoint> points;
  std::vector<double> v(count);
  for (int row = 2; std::getline(in, line); ++row) {
    std::istringstream fields(line);
    std::string field;
    for (double& x : v) {
      char* end = nullptr;
      const bool present = static_cast<bool>(std::getline(fields, field, ','));
      if (present) x = std::strtod(field.c_str(), &end);
      if (!present || end == field.c_str() || *end != '\0') {
        throw std::runtime_error(fmt::format("{}:{}: not {} numbers: {}", path, row, count, line));
      }
    }
    if (std::getline(fields, field, ',')) {
      throw std::runtime_error(
          fmt::format("{}:{}: more than {} fields: {}", path, row, count, line));
    }
    points.push_back({.speed = v[1],
                      .rms_error = RpmToRadPerSec(v[2]),
                      .peak_to_peak_error = RpmToRadPerSec(v[3]),
                      .dominant_frequency = v[4],
                      .lost_steps = v[5],
                      .carriage_speed = count > 6 ? 1e-3 * v[6] : NAN});
  }
  return points;
}

}  // namespace mjstepper::tools
