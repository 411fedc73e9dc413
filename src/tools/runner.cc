#include "runner.h"

#include <fmt/format.h>
#include <fmt/ostream.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <optional>
#include <ostream>
#include <stdexcept>
#include <system_error>

#include "cancel.h"
#include "core/command_profile.h"
#include "core/klipper_steps.h"
#include "core/sensors/adxl345.h"
#include "core/signals.h"
#include "core/units.h"
#include "csv_writer.h"
#include "options.h"
#include "render_session.h"
#include "resonance.h"
#include "stepper_model.h"

namespace mjstepper::tools {
namespace {

// Runs of more steps than this are estimated before they start (SayEstimate); a shorter one
// takes seconds at the slowest model here.
constexpr long kEstimatedSteps = 100000;

// Whether gravity loads a stepper at the state's pose: a generalised gravity force (qfrc_bias at
// rest) along any stepper's moment row.
bool GravityLoadsAStepper(const mjModel* m, const mjData* d, const StepperModel& sm) {
  if (mju_norm3(m->opt.gravity) == 0) return false;
  const DataPtr rest(mj_copyData(nullptr, m, d));
  mju_zero(rest->qvel, m->nv);
  mj_forward(m, rest.get());
  for (const StepperActuator& s : sm.steppers) {
    const std::vector<double> row = MomentRow(m, rest.get(), s.actuator);
    double load = 0;  // N·m (or N) at the rotor, through the moment row
    for (int i = 0; i < m->nv; ++i) load += row[i] * rest->qfrc_bias[i];
    if (std::abs(load) > 1e-12) return true;
  }
  return false;
}

// StartMode::kSettled: `duration` s with each stepper holding where it starts (a speed of 0, or its
// rotor's start angle or count: a target of the profile is not taken yet) while the model's gravity
// rises from 0 along a half cosine over kSettleRamp and is then held; gravity is the model's own
// again at the end.
void Settle(mjModel* m, mjData* d, const std::vector<StepperActuator>& steppers,
            const std::vector<double>& theta_start, double duration) {
  const std::array<double, 3> gravity = {m->opt.gravity[0], m->opt.gravity[1], m->opt.gravity[2]};
  const double t0 = d->time;
  const long steps = std::lround(duration / m->opt.timestep);
  for (long k = 0; k < steps; ++k) {
    const double ramp = std::min((d->time - t0) / kSettleRamp, 1.0);
    const double scale = 0.5 * (1 - std::cos(std::numbers::pi * ramp));
    for (int i = 0; i < 3; ++i) m->opt.gravity[i] = scale * gravity[i];
    for (size_t i = 0; i < steppers.size(); ++i) {
      const StepperActuator& s = steppers[i];
      const double step = StepAngle(s.config);  // rad per microstep (input = steps)
      d->ctrl[s.ctrladr] = s.config.input == InputMode::kVelocity ? 0.0
                           : s.config.input == InputMode::kSteps
                               ? (step > 0 ? std::round(theta_start[i] / step) : 0.0)
                               : theta_start[i];
    }
    const double t = d->time;
    ThrowIfCancelled();  // (cancel.h)
    mj_step(m, d);
    if (const std::string unstable = InstabilityMessage(d, t); !unstable.empty()) {
      for (int i = 0; i < 3; ++i) m->opt.gravity[i] = gravity[i];
      throw std::runtime_error(fmt::format("while settling under gravity: {}", unstable));
    }
  }
  for (int i = 0; i < 3; ++i) m->opt.gravity[i] = gravity[i];
}

// A folder of this run's own, removed with everything in it when the run ends.
class RunFolder {
 public:
  RunFolder() = default;
  RunFolder(const RunFolder&) = delete;
  RunFolder& operator=(const RunFolder&) = delete;
  ~RunFolder() {
    std::error_code ignored;
    if (!path_.empty()) std::filesystem::remove_all(path_, ignored);
  }
  // The folder, made on first use under the system's temporary folder.
  const std::filesystem::path& path() {
    if (path_.empty()) {
      const auto base = std::filesystem::temp_directory_path();
      for (int k = 0; k < 1000 && path_.empty(); ++k) {
        const auto candidate = base / fmt::format("mjstepper-run-{}-{}", ::getpid(), k);
        if (std::filesystem::create_directory(candidate)) path_ = candidate;
      }
      if (path_.empty()) throw std::runtime_error("cannot make a temporary folder for the run");
    }
    return path_;
  }

 private:
  std::filesystem::path path_;
};

// STEP/DIR step lists reach their drives at their own times: each stepper with input = steps
// whose --ctrl is a step list (steps(FILE), shaped or not) gets the list's pulses as its
// `step_times` (a file in `folder`), rather than one count per step whose pulses the drive spreads
// over the step. Not for an actuator that shares its <instance> with another (its config is
// theirs too), nor where the user set step_times. The overrides to add; the step lists parsed,
// by actuator name, into `parsed` (each read once: Run drives ctrl from them too).
std::vector<ConfigOverride> PulseOverrides(const RunOptions& options, const StepperModel& sm,
                                           RunFolder* folder,
                                           std::map<std::string, CommandProfile>* parsed) {
  std::vector<ConfigOverride> out;
  const mjModel* m = sm.model.get();
  for (const StepperActuator& s : sm.steppers) {
    const auto it = options.ctrl.find(s.name);
    if (s.config.input != InputMode::kSteps || it == options.ctrl.end()) continue;
    const bool set = std::any_of(
        options.overrides.begin(), options.overrides.end(),
        [&](const ConfigOverride& o) { return o.actuator == s.name && o.key == "step_times"; });
    const int instance = m->actuator_plugin[s.actuator];
    int sharing = 0;
    for (int a = 0; a < m->nu; ++a) sharing += m->actuator_plugin[a] == instance ? 1 : 0;
    if (set || s.config.step_times || sharing > 1) continue;
    std::optional<CommandProfile> profile;
    try {
      profile = CommandProfile::Parse(it->second, RadPerMetre(m, s));
    } catch (const std::invalid_argument&) {
      continue;  // Run reports it with the actuator's context
    }
    const std::optional<StepTimes> pulses = profile->PulseTimes();
    if (!pulses) continue;
    parsed->emplace(s.name, *profile);
    const auto path = folder->path() / fmt::format("{}.steps", out.size());
    std::ofstream file(path);
    pulses->Write(file);
    file.close();
    if (!file) throw std::runtime_error(fmt::format("cannot write {}", path.string()));
    out.push_back({.actuator = s.name, .key = "step_times", .value = path.string()});
  }
  return out;
}

// --klipper: the map's step lists (core/klipper_steps.h), each written to `folder` and given to
// its actuator as the --ctrl steps(FILE) it stands for.
void AddKlipperSteps(const StepperModel& sm, RunFolder* folder, RunOptions* options) {
  for (const auto& [actuator, list] : ReadKlipperSteps(options->klipper)) {
    const bool stepper = std::any_of(sm.steppers.begin(), sm.steppers.end(),
                                     [&](const StepperActuator& s) { return s.name == actuator; });
    if (!stepper) {
      throw std::invalid_argument(fmt::format("--klipper {}: {} has no stepper actuator '{}'",
                                              options->klipper, options->model, actuator));
    }
    if (options->ctrl.count(actuator) != 0) {
      throw std::invalid_argument(
          fmt::format("--klipper {} and --ctrl {}=… both drive '{}': give it one", options->klipper,
                      actuator, actuator));
    }
    const auto path = folder->path() / fmt::format("klipper_{}.steps", options->ctrl.size());
    std::ofstream file(path);
    list.Write(file);
    file.close();
    if (!file) throw std::runtime_error(fmt::format("cannot write {}", path.string()));
    options->ctrl[actuator] = fmt::format("steps({})", path.string());
  }
}

}  // namespace

RunResult Run(const RunOptions& given, std::ostream& progress) {
  const ToolJudgesTimestep judged;  // CheckTimestep below prints the whole verdict
  RequireInRange("--duration", Range("duration"), given.duration);
  RequireInRange("--log-every", Range("log-every"), given.log_every);
  StepperModel sm = LoadStepperModel(given.model, given.overrides);
  RunFolder
      folder;  // (the plugin reads the lists whenever MuJoCo makes an mjData: kept to the end)
  RunOptions options = given;
  if (!options.klipper.empty()) AddKlipperSteps(sm, &folder, &options);
  std::map<std::string, CommandProfile> parsed;  // step lists, read once
  if (const std::vector<ConfigOverride> pulses = PulseOverrides(options, sm, &folder, &parsed);
      !pulses.empty()) {
    std::vector<ConfigOverride> overrides = options.overrides;
    overrides.insert(overrides.end(), pulses.begin(), pulses.end());
    sm = LoadStepperModel(options.model, overrides);
  }
  for (const auto& [name, torque] : options.loads) SetLoadTorque(sm.model.get(), name, torque);
  for (const auto& [name, mass] : options.masses) SetBodyMass(sm.model.get(), name, mass);
  const mjModel* m = sm.model.get();
  int key = -1;
  if (!options.keyframe.empty()) {
    key = mj_name2id(m, mjOBJ_KEY, options.keyframe.c_str());
    if (key < 0) {
      std::string names;
      for (int k = 0; k < m->nkey; ++k) {
        const char* name = mj_id2name(m, mjOBJ_KEY, k);
        names += fmt::format("{}'{}'", names.empty() ? "" : ", ", name ? name : "");
      }
      throw std::invalid_argument(fmt::format("--keyframe {}: no keyframe of that name in {} ({})",
                                              options.keyframe, options.model,
                                              names.empty() ? "it has none" : names));
    }
  }
  // The one timestep rule, on the modes where the run starts (qpos0 or the keyframe): a stepper
  // mode too fast for the step refuses the run (every failing mode named, and the largest step
  // that passes them all); a mode no stepper takes part in only warns (the model's own springs).
  if (options.judge_timestep) {
    ApplyTimestepRule(sm, key, options.model, options.allow_coarse, progress);
  }
  if (const std::string note = SubstepNote(sm); !note.empty())
    fmt::print(progress, "note: {}: {}\n", options.model, note);
  DataPtr data(mj_makeData(m));
  mjData* d = data.get();
  if (key >= 0) {
    // qpos, qvel, act, ctrl and time from the keyframe; the drives then start at rest on their
    // rotors there (plugin state is not in keyframes: SPEC §6).
    mj_resetDataKeyframe(m, d, key);
    if (!std::isfinite(d->time) || std::abs(d->time) > 1e9) {  // s; 1e9: three decades of time
      throw std::invalid_argument(fmt::format(
          "--keyframe {}: its time is {:g} s; a run starts at a finite time within ±1e9 s",
          options.keyframe, d->time));
    }
  }
  mj_forward(m, d);

  // One profile per stepper: the user's, or hold still (speed 0 / the start angle).
  std::vector<CommandProfile> profiles;
  std::vector<double> theta_start;
  for (const StepperActuator& s : sm.steppers) {
    const auto it = options.ctrl.find(s.name);
    if (it == options.ctrl.end()) {
      profiles.push_back(CommandProfile::Parse("constant(0rad/s)"));
    } else if (const auto listed = parsed.find(s.name); listed != parsed.end()) {
      profiles.push_back(listed->second);
    } else {
      try {  // linear units (mm, m/s, …) through the gear of a slide or a tendon
        profiles.push_back(CommandProfile::Parse(it->second, RadPerMetre(m, s)));
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(fmt::format("--ctrl {}={}: actuator '{}' drives {}: {}", s.name,
                                                it->second, s.name, TransmissionTarget(m, s),
                                                e.what()));
      }
    }
    // A velocity-input drive integrates its ctrl: an angle target would be reduced to its slope
    // (constant(0.5rad) to standing still), silently.
    if (s.config.input == InputMode::kVelocity && profiles.back().absolute_angle()) {
      throw std::invalid_argument(fmt::format(
          "--ctrl {}={}: an angle profile needs a stepper with input = position, and '{}' takes "
          "a speed (input = velocity); give a speed profile such as constant(100rpm), or set "
          "{}.input=position",
          s.name, profiles.back().text(), s.name, s.name));
    }
    if (profiles.back().step_list() && s.config.input != InputMode::kSteps) {
      throw std::invalid_argument(fmt::format(
          "--ctrl {}={}: a step list is STEP/DIR pulses; set {}.input=steps (with a chopper "
          "drive or a driver chip)",
          s.name, profiles.back().text(), s.name));
    }
    theta_start.push_back(d->actuator_length[s.outadr]);
  }
  for (const auto& [name, text] : options.ctrl) {
    bool known = false;
    for (const StepperActuator& s : sm.steppers) known |= s.name == name;
    if (!known) {
      std::string names;
      for (const StepperActuator& s : sm.steppers) names += (names.empty() ? "" : ", ") + s.name;
      throw std::invalid_argument(fmt::format(
          "--ctrl {}={}: no stepper actuator named '{}' (steppers: {})", name, text, name, names));
    }
  }

  std::optional<CsvWriter> csv;
  std::vector<std::optional<Carriage>> carriages;  // per stepper: a linear axis's, for the log
  for (const StepperActuator& s : sm.steppers) carriages.push_back(CarriageOf(m, s));
  if (!options.log.empty()) {
    std::vector<std::string> header = {"time[s]"};
    for (size_t i = 0; i < sm.steppers.size(); ++i) {
      const StepperActuator& s = sm.steppers[i];
      header.push_back(s.name + ":theta[rad]");
      header.push_back(s.name + ":velocity_error[rad/s]");  // (omega is a signal)
      if (carriages[i]) {  // in the units the user thinks in (README, "Linear axes")
        for (const char* column :
             {":carriage_position[mm]", ":carriage_speed[mm/s]", ":carriage_force[N]"}) {
          header.push_back(s.name + column);
        }
      }
      for (const SignalInfo& info : SignalTable()) {
        header.push_back(fmt::format("{}:{}[{}]", s.name, info.name, info.unit));
      }
    }
    csv.emplace(options.log, header);
  }

  // The toolhead's accelerometer, as the ADXL345 reports it (issue 18).
  std::optional<Adxl345> adxl;
  std::vector<AccelSample> accel_samples;
  const int accel_adr =
      options.accel_log.empty() ? -1 : AccelerometerAddress(m, options.accelerometer);
  if (accel_adr >= 0) adxl.emplace(Adxl345Options{}, d->time);

  std::optional<RenderSession> render;
  if (options.render.enabled()) render.emplace(m, sm.steppers, options.render);
  std::vector<StepperSample> samples(sm.steppers.size());

  const double h = m->opt.timestep;
  // At least one step (a run of none would report nothing measured), and a number a long holds.
  const double step_count = std::round(options.duration / h);
  RequireInRange("--duration", Range("steps"), step_count,
                 fmt::format("{:g} (at the model's timestep {:g} s, {:g} steps)", options.duration,
                             h, step_count));
  const long steps = static_cast<long>(step_count);
  // Estimated before it runs (stepper_model.h; a short run never is long: not probed).
  if (steps > kEstimatedSteps) {
    SayEstimate(progress, options.progress, fmt::format("run: {} steps", steps),
                static_cast<double>(steps) * WallTimePerStep(m, d));
  }
  RunResult result;
  result.steppers.resize(sm.steppers.size());
  if (options.keep_traces) result.traces.resize(sm.steppers.size());
  std::vector<double> sum_sq(sm.steppers.size(), 0.0);
  std::vector<double> row;
  const auto start = std::chrono::steady_clock::now();
  auto last_report = start;
  // A settled start (StartMode::kSettled): the start commands held while gravity comes in.
  const double settle =
      options.start == StartMode::kSettled && GravityLoadsAStepper(m, d, sm) ? kSettleTime : 0.0;
  result.settle_time = settle;
  if (settle > 0) {
    if (options.progress) {
      fmt::print(progress, "  settling: gravity ramped in over {:g} s, held to {:g} s\n",
                 kSettleRamp, settle);
    }
    Settle(sm.model.get(), d, sm.steppers, theta_start, settle);
  }
  // A keyframe may start the clock anywhere; profiles start here, and the log's time too (less
  // the settling).
  const double t_begin = d->time;
  for (long k = 0; k < steps; ++k) {
    const double t = d->time;
    for (size_t i = 0; i < sm.steppers.size(); ++i) {
      const StepperActuator& s = sm.steppers[i];
      d->ctrl[s.ctrladr] = profiles[i].ControlForStep(t - t_begin, h, s.config.input,
                                                      theta_start[i], StepAngle(s.config));
    }
    static const int kLoadAngle = SignalIndex("load_angle");
    static const int kLostSteps = SignalIndex("lost_steps");
    static const int kCurrentA = SignalIndex("current_a");
    static const int kCurrentB = SignalIndex("current_b");
    static const int kStallGuard = SignalIndex("stallguard");
    static const int kStall = SignalIndex("stall");
    ThrowIfCancelled();  // (cancel.h)
    mj_step(m, d);
    // MuJoCo resets the whole simulation when qpos, qvel or qacc turn bad, and counts it: what
    // followed would be a run from qpos0 reported as this one.
    if (const std::string unstable = InstabilityMessage(d, t); !unstable.empty()) {
      if (csv) csv->Commit();  // the rows up to the step that went bad, for diagnosis
      throw std::runtime_error(
          csv ? fmt::format("{} (the log {} ends there)", unstable, options.log) : unstable);
    }
    // After mj_step, actuator_length/velocity and sensordata describe the step's start, time t.
    row.assign(1, t - settle);
    for (size_t i = 0; i < sm.steppers.size(); ++i) {
      const StepperActuator& s = sm.steppers[i];
      const double* signals = d->sensordata + s.sensor_adr;
      static const int kOmega = SignalIndex("omega");
      const double omega = signals[kOmega];  // rad/s: the rotor's own when sub-stepped
      // With the drive's own motion profile, ctrl is a target and the command is the drive's.
      static const int kOmegaCmd = SignalIndex("omega_cmd");
      const double omega_cmd = s.config.profile.kind == ProfileKind::kNone
                                   ? profiles[i].Speed(t - t_begin, StepAngle(s.config))
                                   : signals[kOmegaCmd];
      const double error = omega - omega_cmd;
      StepperSummary& sum = result.steppers[i];
      sum_sq[i] += error * error;
      sum.max_velocity_error = std::max(sum.max_velocity_error, std::abs(error));
      sum.max_load_angle = std::max(sum.max_load_angle, std::abs(signals[kLoadAngle]));
      sum.lost_steps = signals[kLostSteps] + 0.0;  // + 0.0: no "-0" in the summary
      sum.final_speed = omega;
      if (const std::optional<Carriage>& c = carriages[i]) {
        sum.carriage_speed = c->Speed(d, s);
        sum.carriage_position = c->Position(d, s);
      }
      samples[i] = {.omega_cmd = omega_cmd,
                    .velocity_error = error,
                    .current_a = signals[kCurrentA],
                    .current_b = signals[kCurrentB],
                    .load_angle = signals[kLoadAngle],
                    .lost_steps = signals[kLostSteps],
                    .stallguard = signals[kStallGuard],
                    .stall = signals[kStall] != 0};
      if (options.keep_traces) {
        StepperTrace& trace = result.traces[i];
        trace.time.push_back(t - settle);
        trace.omega_cmd.push_back(omega_cmd);
        trace.velocity_error.push_back(error);
        trace.current_a.push_back(signals[kCurrentA]);
        trace.load_angle.push_back(signals[kLoadAngle]);
        static const int kTorque = SignalIndex("torque_total");
        static const int kCopper = SignalIndex("energy_copper");
        static const int kResistance = SignalIndex("resistance");
        static const int kWinding = SignalIndex("winding_temperature");
        static const int kHousing = SignalIndex("housing_temperature");
        trace.torque.push_back(signals[kTorque]);
        trace.energy_copper.push_back(signals[kCopper]);
        trace.resistance.push_back(signals[kResistance]);
        trace.winding_temperature.push_back(signals[kWinding]);
        trace.housing_temperature.push_back(signals[kHousing]);
      }
      if (csv) {
        row.insert(row.end(), {d->actuator_length[s.outadr], error});
        if (const std::optional<Carriage>& c = carriages[i]) {
          static const int kTorqueTotal = SignalIndex("torque_total");
          row.insert(row.end(), {1e3 * c->Position(d, s), 1e3 * c->Speed(d, s),
                                 c->Force(signals[kTorqueTotal])});
        }
        row.insert(row.end(), signals, signals + kNumSignals);
      }
    }
    if (csv && k % options.log_every == 0) csv->Row(row);
    if (render) render->Step(t - settle, samples, d, settle);
    if (adxl) {  // the sensor after mj_step describes the step's start: held over [t, t + h)
      const mjtNum* a = d->sensordata + accel_adr;
      adxl->Add(t, t + h, {a[0], a[1], a[2]}, &accel_samples);
    }
    const auto now = std::chrono::steady_clock::now();
    if (options.progress && now - last_report > std::chrono::seconds(2)) {
      last_report = now;
      fmt::print(progress, "\r  {:5.1f} % ({:.3f} / {:.3f} s simulated)", 100.0 * (k + 1) / steps,
                 d->time, options.duration);
      progress.flush();
    }
  }
  if (options.progress && last_report != start) fmt::print(progress, "\n");
  if (csv) csv->Commit();
  if (adxl) WriteKlipperAccelLog(options.accel_log, accel_samples);
  if (render) result.frames = render->Finish();
  result.steps = steps;
  result.sim_time = d->time;
  result.wall_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (size_t i = 0; i < sm.steppers.size(); ++i) {
    result.steppers[i].name = sm.steppers[i].name;
    result.steppers[i].profile = profiles[i].text();
    result.steppers[i].rms_velocity_error = std::sqrt(sum_sq[i] / std::max(1L, steps));
  }
  return result;
}

void PrintSummary(const RunResult& r, const std::string& log, std::ostream& out) {
  fmt::print(out, "{} steps, {:.3f} s simulated in {:.3f} s wall ({:.0f} ns/step)\n", r.steps,
             r.sim_time, r.wall_time, 1e9 * r.wall_time / std::max(1L, r.steps));
  for (const StepperSummary& s : r.steppers) {
    fmt::print(out,
               "  {}: {}\n"
               "    final speed {:.2f} r/min; velocity error RMS {:.2f} r/min, max {:.2f} r/min\n"
               "    max |load angle| {:.3f} rad (electrical); lost steps {:+.0f}\n",
               s.name, s.profile, RadPerSecToRpm(s.final_speed),
               RadPerSecToRpm(s.rms_velocity_error), RadPerSecToRpm(s.max_velocity_error),
               s.max_load_angle, s.lost_steps);
    if (std::isfinite(s.carriage_speed)) {
      fmt::print(out, "    carriage: final speed {:.2f} mm/s at {:.3f} mm\n",
                 1e3 * s.carriage_speed, 1e3 * s.carriage_position);
    }
  }
  if (!log.empty()) fmt::print(out, "  log: {}\n", log);
  if (r.frames > 0) fmt::print(out, "  rendered {} frames\n", r.frames);
}

}  // namespace mjstepper::tools
