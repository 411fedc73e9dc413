#include "stepper_model.h"

#include <fmt/format.h>
#include <fmt/ostream.h>
#include <fmt/ranges.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <variant>
#include <vector>

#include "carriage.h"
#include "config.h"
#include "core/averaged_bridge.h"
#include "core/substep.h"
#include "core/units.h"
#include "installation.h"
#include "stepper.h"

namespace mjstepper::tools {
namespace {

int StepperPluginSlot() {
  int slot = -1;
  mjp_getPlugin(plugin::kPluginName, &slot);
  return slot;
}

bool IsStepper(const mjModel* m, int actuator) {
  const int instance = m->actuator_plugin[actuator];
  return instance >= 0 && m->plugin[instance] == StepperPluginSlot();
}

// MuJoCo's compile error, each line once: the compiler may initialise the plugin more than once
// and collects the warnings of every attempt, the last one cut short by its buffer (a line that
// begins an earlier one is that one again).
std::string DistinctLines(const std::string& text) {
  std::vector<std::string> kept;
  std::stringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    const bool repeated = std::any_of(kept.begin(), kept.end(), [&](const std::string& earlier) {
      return earlier.rfind(line, 0) == 0;
    });
    if (!repeated) kept.push_back(line);
  }
  return fmt::format("{}", fmt::join(kept, "\n"));
}

ModelPtr Compile(mjSpec* spec, const mjVFS* vfs) {
  ModelPtr model(mj_compile(spec, vfs));
  if (!model) {
    throw std::runtime_error(fmt::format("compile error: {}", DistinctLines(mjs_getError(spec))));
  }
  return model;
}

// MuJoCo's warnings (the plugin's among them) on stderr, each distinct one once per run, instead of
// MuJoCo's default: stdout and a MUJOCO_LOG.TXT in the working directory. Sweeps create one mjData
// per run and thread, each of which would repeat the plugin's load-time warning.
std::mutex warn_mutex;
int tool_judges_timestep = 0;  // ToolJudgesTimestep scopes alive (under warn_mutex)

void WarnOnce(const char* message) {
  static std::set<std::string> seen;
  const std::lock_guard<std::mutex> lock(warn_mutex);
  constexpr std::string_view kTimestep = "mjstepper: timestep ";  // the plugin's load warning
  if (tool_judges_timestep > 0 && std::string_view(message).starts_with(kTimestep)) return;
  if (seen.insert(message).second) std::fprintf(stderr, "warning: %s\n", message);
}

// $MJSTEPPER_PLUGIN, else the installation's library.
std::string PluginPath() {
  const char* env = std::getenv("MJSTEPPER_PLUGIN");
  return env != nullptr && env[0] != '\0' ? env : GetInstallation().plugin_library;
}

}  // namespace

ModelPtr CompileSpec(mjSpec* spec, const mjVFS* vfs) { return Compile(spec, vfs); }

ToolJudgesTimestep::ToolJudgesTimestep() {
  const std::lock_guard<std::mutex> lock(warn_mutex);
  ++tool_judges_timestep;
}
ToolJudgesTimestep::~ToolJudgesTimestep() {
  const std::lock_guard<std::mutex> lock(warn_mutex);
  --tool_judges_timestep;
}

void LoadPluginLibrary() {
  static const bool loaded = [] {
    mju_user_warning = WarnOnce;
    // Loaded once per process: the Python package has loaded it already at import.
    if (StepperPluginSlot() < 0) mj_loadPluginLibrary(PluginPath().c_str());
    return true;
  }();
  (void)loaded;
  if (StepperPluginSlot() < 0) {
    throw std::runtime_error(fmt::format("plugin {} not registered after loading {}",
                                         plugin::kPluginName, PluginPath()));
  }
}

StepperModel LoadStepperModel(const std::string& path, const std::vector<ConfigOverride>& overrides,
                              const std::string& text) {
  LoadPluginLibrary();
  // With overrides, the edited text is read from a VFS under the file's own name, so that relative
  // asset paths still resolve against the model's folder.
  struct Vfs {
    Vfs() { mj_defaultVFS(&vfs); }
    ~Vfs() { mj_deleteVFS(&vfs); }
    mjVFS vfs;
  } files;
  const mjVFS* vfs = nullptr;
  if (!text.empty() && !overrides.empty()) {
    throw std::logic_error("LoadStepperModel: a model's text takes no overrides");
  }
  if (!overrides.empty() || !text.empty()) {
    const std::string edited = text.empty() ? ApplyOverrides(path, overrides) : text;
    mj_addBufferVFS(&files.vfs, path.c_str(), edited.data(), static_cast<int>(edited.size()));
    vfs = &files.vfs;
  }
  char error[1024] = "";
  std::unique_ptr<mjSpec, SpecDeleter> spec(mj_parseXML(path.c_str(), vfs, error, sizeof(error)));
  if (!spec) throw std::runtime_error(fmt::format("{}: {}", path, error));
  ModelPtr model = Compile(spec.get(), vfs);

  // Which stepper actuators already have a probe sensor?
  std::vector<int> probe_of(model->nactuator, -1);
  for (int s = 0; s < model->nsensor; ++s) {
    const int instance = model->sensor_plugin[s];
    if (instance >= 0 && model->plugin[instance] == StepperPluginSlot() &&
        model->sensor_objtype[s] == mjOBJ_ACTUATOR) {
      probe_of[model->sensor_objid[s]] = s;
    }
  }
  bool added = false;
  for (int a = 0; a < model->nactuator; ++a) {
    if (!IsStepper(model.get(), a) || probe_of[a] >= 0) continue;
    const char* name = mj_id2name(model.get(), mjOBJ_ACTUATOR, a);
    if (name == nullptr) {
      throw std::runtime_error(fmt::format(
          "{}: stepper actuator id {} has no name; name it so that it can be logged", path, a));
    }
    mjsSensor* sensor = mjs_addSensor(spec.get());
    sensor->type = mjSENS_PLUGIN;
    sensor->objtype = mjOBJ_ACTUATOR;
    mjs_setString(sensor->objname, name);
    mjs_setName(sensor->element, fmt::format("mjstepper:{}", name).c_str());
    mjs_setString(sensor->plugin.plugin_name, plugin::kPluginName);
    sensor->plugin.active = true;
    // Its own (implicit) instance, as the XML reader makes for <plugin plugin="..."> with no
    // instance attribute: a probe with no config.
    mjsPlugin* probe = mjs_addPlugin(spec.get());
    mjs_setString(probe->plugin_name, plugin::kPluginName);
    probe->active = true;
    sensor->plugin.element = probe->element;
    added = true;
  }
  if (added) model = Compile(spec.get(), vfs);

  StepperModel out;
  for (int s = 0; s < model->nsensor; ++s) {
    const int instance = model->sensor_plugin[s];
    if (instance < 0 || model->plugin[instance] != StepperPluginSlot()) continue;
    const int a = model->sensor_objid[s];
    const int drive_instance = model->actuator_plugin[a];
    auto read = [&](const char* key) {
      return mj_getPluginConfig(model.get(), drive_instance, key);
    };
    auto parsed = plugin::ParseStepperConfig(read);
    if (auto* e = std::get_if<std::string>(&parsed)) throw std::runtime_error(*e);
    const plugin::StepperConfig& config = std::get<plugin::StepperConfig>(parsed);
    const char* name = mj_id2name(model.get(), mjOBJ_ACTUATOR, a);
    out.steppers.push_back({.actuator = a,
                            .name = name != nullptr ? name : fmt::format("actuator{}", a),
                            .sensor_adr = model->sensor_adr[s],
                            .config = config.drive,
                            .coupling = config.coupling,
                            .ctrladr = model->actuator_ctrladr[a],
                            .outadr = model->actuator_outadr[a]});
  }
  out.model = std::move(model);
  return out;
}

std::string InstabilityMessage(const mjData* d, double t) {
  for (const auto& [w, what] :
       {std::pair{mjWARN_BADQPOS, "qpos"}, std::pair{mjWARN_BADQVEL, "qvel"},
        std::pair{mjWARN_BADQACC, "qacc"}}) {
    if (d->warning[w].number > 0) {
      return fmt::format(
          "the simulation went unstable at t = {:.6g} s: MuJoCo found a bad {} in dof {} and "
          "reset it; try a smaller timestep, or check the model's stiffness, masses and ctrl",
          t, what, d->warning[w].lastinfo);
    }
  }
  return "";
}

void SetLoadTorque(mjModel* m, const std::string& name, double torque) {
  const std::string what = fmt::format("--load {}={}", name, torque);
  const int id = mj_name2id(m, mjOBJ_ACTUATOR, name.c_str());
  if (id < 0) throw std::invalid_argument(fmt::format("{}: no actuator named '{}'", what, name));
  if (!std::isfinite(torque)) {
    throw std::invalid_argument(fmt::format("{}: the torque must be finite (N·m)", what));
  }
  const mjtNum* gain = m->actuator_gainprm + id * mjNGAIN;
  mjtNum* bias = m->actuator_biasprm + id * mjNBIAS;
  if (m->actuator_plugin[id] >= 0 || m->actuator_gaintype[id] != mjGAIN_FIXED || gain[0] != 0 ||
      m->actuator_biastype[id] != mjBIAS_AFFINE || bias[1] != 0 || bias[2] != 0) {
    throw std::invalid_argument(
        fmt::format("{}: actuator '{}' is not a constant load; write it as <general gainprm=\"0\" "
                    "biastype=\"affine\" biasprm=\"-TORQUE 0 0\"/> on the joint (plugin/README.md)",
                    what, name));
  }
  bias[0] = -torque;
}

void SetBodyMass(mjModel* m, const std::string& name, double mass) {
  const std::string what = fmt::format("--mass {}={}", name, mass);
  const int body = mj_name2id(m, mjOBJ_BODY, name.c_str());
  if (body <= 0) throw std::invalid_argument(fmt::format("{}: no body named '{}'", what, name));
  if (!(mass > 0) || !std::isfinite(mass)) {
    throw std::invalid_argument(fmt::format("{}: the mass must be finite and > 0 (kg)", what));
  }
  const double scale = m->body_mass[body] > 0 ? mass / m->body_mass[body] : 0;
  if (!(scale > 0)) {
    throw std::invalid_argument(
        fmt::format("{}: body '{}' has no mass of its own to scale", what, name));
  }
  m->body_mass[body] = mass;
  for (int k = 0; k < 3; ++k) m->body_inertia[3 * body + k] *= scale;
  DataPtr d(mj_makeData(m));
  mj_setConst(m, d.get());
}

std::optional<double> RadPerMetre(const mjModel* m, const StepperActuator& s) {
  const int target = m->actuator_trnid[2 * s.actuator];
  if (m->actuator_trntype[s.actuator] == mjTRN_TENDON ||
      (m->actuator_trntype[s.actuator] == mjTRN_JOINT && m->jnt_type[target] == mjJNT_SLIDE)) {
    return Gear(m, s);
  }
  const double radius = s.config.transmission.MetresPerRadian();  // m per rad of the hinge
  if (radius > 0) return Gear(m, s) / radius;
  return std::nullopt;
}

double WallTimePerStep(const mjModel* m, const mjData* pose) {
  constexpr int kProbeSteps = 50;
  DataPtr d(mj_makeData(m));
  if (pose != nullptr) mju_copy(d->qpos, pose->qpos, m->nq);
  mj_forward(m, d.get());
  const auto begin = std::chrono::steady_clock::now();
  for (int k = 0; k < kProbeSteps; ++k) mj_step(m, d.get());
  const std::chrono::duration<double> spent = std::chrono::steady_clock::now() - begin;
  return spent.count() / kProbeSteps;
}

void SayEstimate(std::ostream& out, bool progress, const std::string& what, double seconds) {
  if (!progress && !(seconds > kLongJob)) return;
  fmt::print(out, "{}: about {} s of wall time{}\n", what,
             seconds < 10 ? fmt::format("{:.1f}", seconds) : fmt::format("{:.0f}", seconds),
             progress ? "" : " (Ctrl-C stops it)");
}

std::optional<Carriage> CarriageOf(const mjModel* m, const StepperActuator& s) {
  const std::optional<double> rad_per_metre = RadPerMetre(m, s);
  if (!rad_per_metre) return std::nullopt;
  Carriage c{.rad_per_metre = *rad_per_metre, .gear = Gear(m, s)};
  if (s.config.transmission.MetresPerRadian() == 0) return c;  // a slide or a tendon
  const plugin::Belt belt = plugin::BeltOf(m, m->actuator_trnid[2 * s.actuator]);
  c.belt = belt.tendon;
  c.belt_coef = belt.coef;
  return c;
}

double Carriage::Position(const mjData* d, const StepperActuator& s) const {
  const double rotor = d->actuator_length[s.outadr];  // rad
  return belt < 0 ? rotor / rad_per_metre : d->ten_length[belt] - belt_coef * rotor / gear;
}

double Carriage::Speed(const mjData* d, const StepperActuator& s) const {
  const double rotor = d->actuator_velocity[s.outadr];  // rad/s
  return belt < 0 ? rotor / rad_per_metre : d->ten_velocity[belt] - belt_coef * rotor / gear;
}

std::string TransmissionTarget(const mjModel* m, const StepperActuator& s) {
  const int target = m->actuator_trnid[2 * s.actuator];
  if (m->actuator_trntype[s.actuator] == mjTRN_TENDON) {
    const char* name = mj_id2name(m, mjOBJ_TENDON, target);
    return fmt::format("tendon '{}'", name != nullptr ? name : fmt::format("{}", target));
  }
  const char* name = mj_id2name(m, mjOBJ_JOINT, target);
  return fmt::format("{} joint '{}'", m->jnt_type[target] == mjJNT_SLIDE ? "slide" : "hinge",
                     name != nullptr ? name : fmt::format("{}", target));
}

StepperResolution Resolution(const mjModel* m, const StepperActuator& s) {
  StepperResolution r;
  const Drive drive(s.config);
  r.stiffness = drive.HoldingStiffness();
  r.detent_stiffness = drive.DetentStiffness();
  r.inertia = ReflectedInertia(m, s.actuator);
  r.omega_n = std::sqrt(r.stiffness / r.inertia);
  return r;
}

std::vector<plugin::ModalStepper> ModalSteppers(const StepperModel& sm) {
  std::vector<plugin::ModalStepper> out;
  for (const StepperActuator& s : sm.steppers) {
    const Drive drive(s.config);
    out.push_back({.actuator = s.actuator,
                   .name = s.name,
                   .stiffness = drive.HoldingStiffness(),
                   .detent_stiffness = drive.DetentStiffness(),
                   .max_omega_h = MaxOmegaTimesStep(s.coupling),
                   .substepped = s.coupling == Coupling::kSubstepped,
                   .step_input = s.config.input == InputMode::kSteps});
  }
  return out;
}

TimestepVerdict CheckTimestep(const StepperModel& sm, int key) {
  return plugin::JudgeModelTimestep(sm.model.get(), ModalSteppers(sm), key);
}

void ApplyTimestepRule(const StepperModel& sm, int key, const std::string& subject,
                       bool allow_coarse, std::ostream& out) {
  if (const std::string warning = IntegratorWarning(sm.model.get()); !warning.empty())
    fmt::print(out, "warning: {}: {}\n", subject, warning);
  const TimestepVerdict verdict = CheckTimestep(sm, key);
  // A step the modes pass but a move's ringing does not: recommended, never refused.
  if (const std::string note = verdict.RingingNote(subject);
      verdict.failed.empty() && !note.empty())
    fmt::print(out, "note: {}\n", note);
  if (verdict.failed.empty()) return;
  const std::string message = verdict.Message(subject);
  if (verdict.refuse() && !allow_coarse) {
    throw std::invalid_argument(message + ", or pass --allow-coarse");
  }
  fmt::print(out, "warning: {}\n", message);
}

double SwitchingCycle(const DriveConfig& c) {
  if (c.fidelity != Fidelity::kSwitching) return 0;
  return std::visit(
      [&](const auto& unit) {
        if constexpr (SwitchingUnit<std::decay_t<decltype(unit)>>) {
          return FastestCycle(unit, c.bus_voltage, c.motor.inductance, unit.table.peak_current);
        } else {
          return 0.0;
        }
      },
      c.controller);
}

std::string IntegratorWarning(const mjModel* m) {
  if (m->opt.integrator != mjINT_RK4) return "";
  // Measured 2026-11-29 (plugin/README.md, "Integrators"): models/tsui_rigid.xml's sweep at
  // 20-200 r/min, RMS velocity ripple against the same sweep with implicitfast at 1e-5 s.
  return fmt::format(
      "integrator RK4 at timestep {:g} s: with RK4 the Tsui sweep's velocity ripple is up to 3.6 % "
      "off a 10 µs reference at 5e-5 s (0.7 % at 1e-5 s), where Euler and implicitfast stay "
      "within 0.07 %; use integrator=\"implicitfast\" (plugin/README.md, \"Integrators\")",
      m->opt.timestep);
}

std::string SubstepNote(const StepperModel& sm) {
  const double h = sm.model->opt.timestep;  // s
  const bool substepped =
      std::any_of(sm.steppers.begin(), sm.steppers.end(),
                  [](const StepperActuator& s) { return s.coupling == Coupling::kSubstepped; });
  if (!(substepped && h > kSubsteppedMeasuredStep)) return "";
  return fmt::format(
      "timestep {:g} s is above {:g} s, the largest at which the sub-stepped coupling's fidelity "
      "is measured against a 10 µs reference (docs/coupling.md, \"The sub-stepped rotor\")",
      h, kSubsteppedMeasuredStep);
}

std::vector<int> ExcitationOrders(const DriveConfig& c) {
  std::vector<int> orders;
  for (const DetentHarmonic& h : c.motor.detent) {
    if (std::find(orders.begin(), orders.end(), h.order) == orders.end()) orders.push_back(h.order);
  }
  if (orders.empty()) orders = {1, 2, 4};
  std::sort(orders.begin(), orders.end());
  return orders;
}

std::vector<ResonantSpeed> ResonantSpeeds(const std::vector<plugin::Mode>& modes, size_t index,
                                          const DriveConfig& c) {
  std::vector<ResonantSpeed> out;
  for (size_t k = 0; k < modes.size(); ++k) {
    const double share = modes[k].participation.at(index);
    if (share < plugin::kMinParticipation) continue;
    const double f = modes[k].omega / kTwoPi;  // Hz
    for (int h : ExcitationOrders(c)) {
      out.push_back({.mode = static_cast<int>(k),
                     .frequency = f,
                     .participation = share,
                     .order = h,
                     .speed = 60.0 * f / (h * c.motor.rotor_teeth)});  // SPEC §2-3
    }
  }
  return out;
}

std::vector<double> MomentRow(const mjModel* m, const mjData* d, int actuator) {
  std::vector<double> row(m->nv, 0.0);
  const int out = m->actuator_outadr[actuator];  // moment rows are per output
  for (int k = d->moment_rowadr[out]; k < d->moment_rowadr[out] + d->moment_rownnz[out]; ++k) {
    row[d->moment_colind[k]] += d->actuator_moment[k];
  }
  return row;
}

double ReflectedInertia(const mjModel* m, int actuator, const mjData* pose) {
  DataPtr d(mj_makeData(m));
  if (pose != nullptr) mju_copy(d->qpos, pose->qpos, m->nq);
  mj_forward(m, d.get());
  std::vector<mjtNum> dense(m->nv * m->nv);
  mj_fullM(m, d.get(), dense.data());
  const std::vector<double> row = MomentRow(m, d.get(), actuator);
  std::vector<int> moved;  // the dofs the actuator moves; the others are held
  for (int i = 0; i < m->nv; ++i) {
    if (row[i] != 0) moved.push_back(i);
  }
  if (moved.empty()) return 0;
  if (moved.size() == 1) {  // a joint (r = gear), or a tendon over one joint
    const int dof = moved[0];
    return dense[dof * m->nv + dof] / (row[dof] * row[dof]);
  }
  const int n = static_cast<int>(moved.size());
  Eigen::MatrixXd mass(n, n);
  Eigen::VectorXd r(n);
  for (int i = 0; i < n; ++i) {
    r(i) = row[moved[i]];
    for (int j = 0; j < n; ++j) mass(i, j) = dense[moved[i] * m->nv + moved[j]];
  }
  // The inertia of the actuator's own coordinate: 1/(r·M⁻¹·rᵀ) (M symmetric positive definite).
  return 1.0 / r.dot(mass.ldlt().solve(r));
}

int AccelerometerAddress(const mjModel* m, const std::string& name) {
  const int id = mj_name2id(m, mjOBJ_SENSOR, name.c_str());
  if (id < 0 || m->sensor_type[id] != mjSENS_ACCELEROMETER) {
    throw std::invalid_argument(fmt::format(
        "--accelerometer {}: the model has no accelerometer sensor of that name (add <sensor>"
        "<accelerometer name=\"{}\" site=\"...\"/></sensor> on the toolhead, its site's axes the "
        "printer's X, Y, Z)",
        name, name));
  }
  return m->sensor_adr[id];
}

}  // namespace mjstepper::tools
