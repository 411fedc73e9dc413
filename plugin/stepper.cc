#include "stepper.h"

#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <tuple>
#include <variant>

#include "carriage.h"
#include "config.h"
#include "core/signals.h"
#include "core/substep.h"
#include "modes.h"

namespace mjstepper::plugin {
namespace {

static_assert(sizeof(mjtNum) == sizeof(double), "DriveState is stored as mjtNum");

// The instance's parsed config, or null if it is bad (init then fails with the message).
std::optional<StepperConfig> InstanceConfig(const mjModel* m, int instance) {
  const auto parsed = ParseStepperConfig(
      [m, instance](const char* name) { return mj_getPluginConfig(m, instance, name); });
  if (const StepperConfig* c = std::get_if<StepperConfig>(&parsed)) return *c;
  return std::nullopt;
}

std::string NameOf(const mjModel* m, int adr) { return adr >= 0 ? m->names + adr : ""; }

// Who an error is about: "instance 'x'", "actuator 'shaft' (id 0)" or "sensor 'probe' (id 2)".
std::string Subject(const mjModel* m, int instance) {
  const std::string name = NameOf(m, m->name_pluginadr[instance]);
  if (!name.empty()) return fmt::format("instance '{}'", name);
  for (int a = 0; a < m->nactuator; ++a) {
    if (m->actuator_plugin[a] == instance) {
      return fmt::format("actuator '{}' (id {})", NameOf(m, m->name_actuatoradr[a]), a);
    }
  }
  for (int s = 0; s < m->nsensor; ++s) {
    if (m->sensor_plugin[s] == instance) {
      return fmt::format("sensor '{}' (id {})", NameOf(m, m->name_sensoradr[s]), s);
    }
  }
  return fmt::format("instance {}", instance);
}

std::vector<int> BoundActuators(const mjModel* m, int instance) {
  std::vector<int> ids;
  for (int a = 0; a < m->nactuator; ++a) {
    if (m->actuator_plugin[a] == instance) ids.push_back(a);
  }
  return ids;
}

bool IsStepperInstance(const mjModel* m, int instance) {
  // The plugin's slot in MuJoCo's table, looked up once: registration happens once per process,
  // and a slot never changes (this runs every step, from the consistent coupling).
  static const int slot = [] {
    int found = -1;
    return mjp_getPlugin(kPluginName, &found) != nullptr ? found : -1;
  }();
  return instance >= 0 && slot >= 0 && m->plugin[instance] == slot;
}

static_assert(kMaxCommand == mjMAXVAL, "core's bound on a ctrl is MuJoCo's mju_isBad bound");

// The IEC 60085 letter of an insulation limit (°C), as the `insulation_class` attribute names it.
const char* InsulationClassName(double limit) {
  return limit == 105 ? "A" : limit == 120 ? "E" : limit == 155 ? "F" : limit == 180 ? "H" : "B";
}

// The name MJCF gives a transmission type, for the refusal of one the stepper does not drive.
const char* TransmissionName(int trntype) {
  switch (trntype) {
    case mjTRN_JOINT:
      return "joint";
    case mjTRN_JOINTINPARENT:
      return "jointinparent";
    case mjTRN_SLIDERCRANK:
      return "slidercrank";
    case mjTRN_TENDON:
      return "tendon";
    case mjTRN_SITE:
      return "site";
    case mjTRN_BODY:
      return "body";
    default:
      return "unknown";
  }
}

// The hinge a gauge is drawn on: the joint of a joint transmission (a slide too, as before), the
// first hinge of a fixed tendon (a pulley written into the belt), else none (-1).
// The gauge's size, as fractions of the model's extent (GaugeRadius).
constexpr double kGaugeMinOfExtent = 0.025, kGaugeMaxOfExtent = 0.5;

int GaugeJoint(const mjModel* m, int trntype, int target) {
  if (trntype == mjTRN_JOINT) return target;
  const int adr = m->tendon_adr[target];
  for (int w = adr; w < adr + m->tendon_num[target]; ++w) {
    if (m->wrap_type[w] != mjWRAP_JOINT) return -1;  // a spatial tendon
    if (m->jnt_type[m->wrap_objid[w]] == mjJNT_HINGE) return m->wrap_objid[w];
  }
  return -1;
}

// The gauge's scale (m): its joint's body's bounding radius, kept within 2.5-50 % of the model's
// extent (MuJoCo's stat.extent), so that the gauge reads at the scene's scale (issue 32, item 4: a
// few pixels on a 6 mm pulley, huge on a slide's carriage); a slide's, whose dial lies on the
// carriage's face, kSlideGaugeOfBody of it, at most 50 %: the command arrow (2 radii) stays
// within the carriage; 2 cm with no joint or extent.
constexpr double kSlideGaugeOfBody = 0.3;
double GaugeRadius(const mjModel* m, int joint) {
  if (joint < 0) return 0.02;
  const int body = m->jnt_bodyid[joint];
  double radius = 0;
  for (int g = m->body_geomadr[body]; g >= 0 && g < m->body_geomadr[body] + m->body_geomnum[body];
       ++g) {
    radius = std::max(radius, m->geom_rbound[g]);
  }
  const double extent = m->stat.extent;  // m
  if (m->jnt_type[joint] == mjJNT_SLIDE && radius > 0) {
    return extent > 0 ? std::min(kSlideGaugeOfBody * radius, kGaugeMaxOfExtent * extent)
                      : kSlideGaugeOfBody * radius;
  }
  if (!(extent > 0)) return radius > 0 ? radius : 0.02;
  return std::clamp(radius > 0 ? radius : 0.02, kGaugeMinOfExtent * extent,
                    kGaugeMaxOfExtent * extent);
}

// Output `row`'s rate (rad/s or m/s): its moment row (per output, gear included) times qvel, as
// MuJoCo's actuator_velocity is made.
double MomentRate(const mjData* d, int row) {
  double rate = 0;
  for (int k = d->moment_rowadr[row]; k < d->moment_rowadr[row] + d->moment_rownnz[row]; ++k) {
    rate += d->actuator_moment[k] * d->qvel[d->moment_colind[k]];
  }
  return rate;
}

}  // namespace

double Stepper::RotorAngleAtEnd(const mjModel* m, const mjData* d, const Actuator& a) {
  if (a.tendon < 0) return a.gear * d->qpos[a.qposadr];
  const int adr = m->tendon_adr[a.tendon];
  if (m->wrap_type[adr] == mjWRAP_JOINT) {
    // A fixed tendon: L = Σ coef·q, summed as MuJoCo's mj_tendon does, so that θ here is the next
    // step's actuator_length to the bit.
    double length = 0;  // m or rad, the tendon's unit
    for (int w = adr; w < adr + m->tendon_num[a.tendon]; ++w) {
      length += m->wrap_prm[w] * d->qpos[m->jnt_qposadr[m->wrap_objid[w]]];
    }
    return length * a.gear;
  }
  // A spatial tendon: its length is a function of the whole pose, which MuJoCo computes only in
  // the next step's kinematics. To first order in the step, θ1 = θ0 + h·(gear·∂L/∂q)·v1: the start
  // value and moment row (still the step's start ones here) and the integrated velocity v1.
  return d->actuator_length[a.outadr] + m->opt.timestep * MomentRate(d, a.outadr);
}

std::string VersionMismatch(int built_for, int running) {
  if (built_for == running) return "";
  auto dotted = [](int v) {
    return fmt::format("{}.{}.{}", v / 1000000, v / 1000 % 1000, v % 1000);
  };
  return fmt::format(
      "mjstepper: built for MuJoCo {} ({}) but running with libmujoco {} ({}); rebuild mjstepper "
      "against the libmujoco it runs with (requirements.txt pins the version)",
      dotted(built_for), built_for, dotted(running), running);
}

namespace {
std::atomic<int> live_steppers{0};
}  // namespace

Stepper::Stepper() { ++live_steppers; }
Stepper::~Stepper() { --live_steppers; }
int Stepper::LiveCount() { return live_steppers; }

int Stepper::Init(const mjModel* m, mjData* d, int instance) {
  // The modes' own mjData (ComputeModes) initialises every instance again: no advice from those.
  static thread_local bool judging = false;
  try {  // no exception crosses into MuJoCo
    int first = 0;
    while (!IsStepperInstance(m, first)) ++first;
    std::unique_ptr<Stepper> stepper = Create(m, instance, /*advice=*/!judging);
    bool ok = stepper != nullptr;
    if (instance == first) {
      // Every later instance's errors too, after this one's: in model order, all of them.
      std::vector<ModalStepper> steppers;
      if (stepper) stepper->AddModalSteppers(m, &steppers);
      for (int later = instance + 1; later < m->nplugin; ++later) {
        if (!IsStepperInstance(m, later)) continue;
        const std::unique_ptr<Stepper> other = Create(m, later, /*advice=*/false);
        if (other) {
          other->AddModalSteppers(m, &steppers);
        } else {
          ok = false;
        }
      }
      // The one timestep rule (core/timestep_rule.h) on the model's modes, as info and run judge
      // it: warned once per load, with every failing mode and the suggestion.
      if (ok && !judging) {
        judging = true;
        try {
          const TimestepVerdict verdict = JudgeModelTimestep(m, steppers);
          judging = false;
          if (!verdict.failed.empty()) mju_warning("%s", verdict.Summary("mjstepper").c_str());
        } catch (...) {
          judging = false;
          throw;
        }
      }
    }
    if (!ok) return -1;  // (this instance's Stepper, if made, is freed here)
    d->plugin_data[instance] = reinterpret_cast<uintptr_t>(stepper.release());
    return 0;
  } catch (const std::exception& e) {
    mju_warning("mjstepper: %s", e.what());
    return -1;
  }
}

void Stepper::AddModalSteppers(const mjModel* m, std::vector<ModalStepper>* out) const {
  if (!drive_) return;
  for (const Actuator& a : actuators_) {
    out->push_back({.actuator = a.id,
                    .name = NameOf(m, m->name_actuatoradr[a.id]),
                    .stiffness = drive_->HoldingStiffness(),
                    .detent_stiffness = drive_->DetentStiffness(),
                    .max_omega_h = MaxOmegaTimesStep(coupling_),
                    .substepped = coupling_ == Coupling::kSubstepped,
                    .step_input = drive_->config().input == InputMode::kSteps});
  }
}

std::unique_ptr<Stepper> Stepper::Create(const mjModel* m, int instance, bool advice) {
  if (const std::string mismatch = VersionMismatch(mjVERSION_HEADER, mj_version());
      !mismatch.empty()) {
    mju_warning("%s", mismatch.c_str());
    return nullptr;
  }
  const std::string subject = Subject(m, instance);
  auto fail = [&](const std::string& what) {
    mju_warning("%s", fmt::format("mjstepper: {}: {}", subject, what).c_str());
    return nullptr;
  };
  // About one of the instance's actuators: named once, whether the instance is the actuator's own
  // (its subject already names it) or shared.
  auto fail_for = [&](const std::string& actuator, const std::string& what) {
    return fail(subject == actuator ? what : actuator + ": " + what);
  };
  auto read = [m, instance](const char* name) { return mj_getPluginConfig(m, instance, name); };

  std::unique_ptr<Stepper> stepper(new Stepper());
  const std::vector<int> bound = BoundActuators(m, instance);
  if (bound.empty()) {
    // A signal probe: a sensor on an actuator driven by a stepper instance.
    for (const char* name : AttributeNames()) {
      const char* value = read(name);
      if (value != nullptr && value[0] != '\0') {
        return fail(
            fmt::format("{} = \"{}\": a signal sensor takes no config; configure the "
                        "actuator's drive instead",
                        name, value));
      }
    }
    for (int s = 0; s < m->nsensor; ++s) {
      if (m->sensor_plugin[s] != instance) continue;
      const int a = m->sensor_objid[s];
      if (m->sensor_objtype[s] != mjOBJ_ACTUATOR || a < 0 ||
          !IsStepperInstance(m, m->actuator_plugin[a])) {
        return fail(
            "a mjstepper.stepper sensor needs objtype=\"actuator\" and objname naming an "
            "actuator driven by mjstepper.stepper");
      }
    }
    return stepper;
  }

  const std::variant<StepperConfig, std::string> parsed = ParseStepperConfig(read);
  if (const std::string* error = std::get_if<std::string>(&parsed)) return fail(*error);
  // Every step runs each interrupt in it (and MuJoCo's compiler steps once while loading): bound
  // their number, so that no config makes a load or a step take unbounded time.
  const double isr_period = std::get<StepperConfig>(parsed).drive.isr_period;  // s
  if (!(m->opt.timestep > 0 && std::isfinite(m->opt.timestep))) {
    return fail(
        fmt::format("timestep = {:g} s (the model's <option timestep>): must be finite and "
                    "> 0",
                    m->opt.timestep));
  }
  if (!InterruptsFit(m->opt.timestep, isr_period)) {
    const char* raw = read("isr_period");
    return fail(fmt::format(
        "isr_period = \"{}\": at most {} interrupts per timestep ({:g} s) are run; use "
        "isr_period >= {:g} (s)",
        raw != nullptr && raw[0] != '\0' ? std::string(raw) : fmt::format("{:g}", isr_period),
        kMaxInterruptsPerStep, m->opt.timestep, LeastIsrPeriod(m->opt.timestep)));
  }
  stepper->drive_.emplace(std::get<StepperConfig>(parsed).drive);
  stepper->state_size_ = stepper->drive_->layout().total();
  stepper->gauge_ = std::get<StepperConfig>(parsed).gauge;
  stepper->coupling_ = std::get<StepperConfig>(parsed).coupling;

  stepper->insulation_warned_ = std::make_unique<std::atomic<bool>[]>(bound.size());
  for (int s = 0; s < m->nsensor; ++s) {
    if (m->sensor_plugin[s] == instance) {
      return fail(
          "sensors read a drive through objtype=\"actuator\" objname=\"...\" and no "
          "instance; see plugin/README.md");
    }
  }
  for (int a : bound) {
    const std::string actuator =
        fmt::format("actuator '{}' (id {})", NameOf(m, m->name_actuatoradr[a]), a);
    // θ = gear·q on a hinge or slide joint, θ = gear·L on a tendon (fixed or spatial): both are
    // MuJoCo's actuator_length, and gear·τ (through the moment row) MuJoCo's force on the dofs.
    const int target = m->actuator_trnid[2 * a];
    const int trntype = m->actuator_trntype[a];
    if (trntype == mjTRN_JOINT) {
      if (target < 0 ||
          (m->jnt_type[target] != mjJNT_HINGE && m->jnt_type[target] != mjJNT_SLIDE)) {
        return fail_for(actuator,
                        "the stepper needs a joint transmission on a hinge or slide joint, or a "
                        "tendon transmission");
      }
    } else if (trntype != mjTRN_TENDON || target < 0) {
      return fail_for(actuator,
                      fmt::format("trntype = {}: the stepper needs a joint transmission on a hinge "
                                  "or slide joint (joint=\"...\"), or a tendon transmission "
                                  "(tendon=\"...\")",
                                  TransmissionName(trntype)));
    }
    if (m->actuator_ctrlnum[a] != 1 || m->actuator_outnum[a] != 1) {
      return fail_for(actuator, "the stepper takes one control and drives one output");
    }
    // |gear| in [kMinGear, kMaxGear]: a rotor angle gear·q that neither underflows (1e-300 made
    // it 0) nor turns the drive's kMaxCommand into a joint angle MuJoCo's own bound refuses.
    const double gear = m->actuator_gear[6 * m->actuator_outadr[a]];
    if (!(std::abs(gear) >= kMinGear && std::abs(gear) <= kMaxGear)) {
      return fail_for(actuator, fmt::format("gear = {:g}: |gear| must be between {:g} and {:g} "
                                            "(the rotor turns gear times the joint)",
                                            gear, kMinGear, kMaxGear));
    }
    if (const std::string why = CarriageMismatch(m, a, stepper->drive_->config().transmission);
        !why.empty()) {
      return fail_for(actuator, why);
    }
    // With a dyntype (filter, integrator, ...) MuJoCo integrates the actuator's activation from
    // ctrl, and its own actuators feed that activation, not ctrl, to their gain: so does the
    // drive, reading the last activation element (MuJoCo's act_last, where it writes act_dot).
    const int actadr = m->actuator_dyntype[a] != mjDYN_NONE && m->actuator_actnum[a] > 0
                           ? m->actuator_actadr[a] + m->actuator_actnum[a] - 1
                           : -1;
    stepper->actuators_.push_back({.id = a,
                                   .ctrladr = m->actuator_ctrladr[a],
                                   .actadr = actadr,
                                   .outadr = m->actuator_outadr[a],
                                   .qposadr = trntype == mjTRN_JOINT ? m->jnt_qposadr[target] : -1,
                                   .tendon = trntype == mjTRN_TENDON ? target : -1,
                                   .gauge_joint = GaugeJoint(m, trntype, target),
                                   .gauge_radius = GaugeRadius(m, GaugeJoint(m, trntype, target)),
                                   .gear = gear});
    // The rotor's inertia is MuJoCo's business (armature); the preset knows its value.
    const double rotor_inertia = stepper->drive_->config().motor.rotor_inertia;  // kg·m²
    if (m->actuator_armature[a] < rotor_inertia * (1 - 1e-9)) {
      return fail_for(
          actuator,
          fmt::format(
              "the motor's rotor inertia J = {:g} kg·m² is not in the model (armature = {:g}); "
              "add armature=\"{:g}\" to the actuator (MuJoCo reflects it through gear²), or set "
              "rotor_inertia=\"0\" if the model carries the rotor itself",
              rotor_inertia, m->actuator_armature[a], rotor_inertia));
    }
    // MuJoCo 4.0 adds a tendon's armature to the mass matrix within each kinematic tree only (the
    // cross-tree terms of J·gear²·(∂L/∂q)ᵀ(∂L/∂q) are dropped; tests/plugin/tendon_test.cc): on a
    // tendon across trees the rotor does not couple them as a rigid cable would.
    if (advice && trntype == mjTRN_TENDON && m->tendon_treenum[target] > 1 &&
        m->actuator_armature[a] > 0) {
      mju_warning(
          "%s",
          fmt::format("mjstepper: {}: tendon '{}' spans {} kinematic trees, and MuJoCo adds the "
                      "rotor's armature (J·gear²) within each tree only: the rotor's inertia "
                      "does not couple them; for a rigid rotor put the tendon's joints in one "
                      "tree, or the rotor as a body on a hinge in the tendon (rotor_inertia=\"0\")",
                      actuator, NameOf(m, m->name_tendonadr[target]), m->tendon_treenum[target])
              .c_str());
    }
  }
  if (stepper->coupling_ == Coupling::kSubstepped) {
    // The sub-stepped rotor lands MuJoCo's Euler step (damping implicit) on its angles: one
    // derivative evaluation per step, and the command known at the step's start.
    if (m->opt.integrator == mjINT_RK4) {
      return fail(
          "coupling = \"substepped\": the model's integrator is RK4, whose four stages see four "
          "states; use integrator=\"Euler\" or \"implicitfast\", or coupling=\"consistent\"");
    }
    for (const Actuator& a : stepper->actuators_) {
      if (a.actadr >= 0) {
        return fail_for(
            fmt::format("actuator '{}' (id {})", NameOf(m, m->name_actuatoradr[a.id]), a.id),
            "coupling = \"substepped\" takes ctrl as the command at the step's start: "
            "remove the actuator's dyntype, or use coupling=\"consistent\"");
      }
    }
  }
  // The model's steppers with the consistent or substepped coupling (this one's and every other
  // instance's), in actuator order, for C-3 or R-1 each step: which they are depends only on the
  // model, and they are coupled one way.
  for (int j = 0; j < m->nactuator; ++j) {
    const int owner = m->actuator_plugin[j];
    if (owner < 0 || !IsStepperInstance(m, owner)) continue;
    // Its coupling as its own instance parses it (the same parser: trimmed, defaulted); a config
    // that does not parse is refused by its own instance's load.
    const std::optional<StepperConfig> config = InstanceConfig(m, owner);
    if (!config || config->coupling == Coupling::kExplicit) continue;
    if (stepper->coupling_ != Coupling::kExplicit && config->coupling != stepper->coupling_) {
      return fail(fmt::format(
          "coupling = \"{}\" here but \"{}\" on actuator '{}' (id {}): the model's steppers "
          "are solved together, one way; set one coupling on all (\"explicit\" may sit beside "
          "either)",
          stepper->coupling_ == Coupling::kSubstepped ? "substepped" : "consistent",
          config->coupling == Coupling::kSubstepped ? "substepped" : "consistent",
          NameOf(m, m->name_actuatoradr[j]), j));
    }
    const std::vector<int> owned = BoundActuators(m, owner);  // a drive's slots, in id order
    const auto slot = std::find(owned.begin(), owned.end(), j) - owned.begin();
    stepper->coupled_.push_back({.actuator = j,
                                 .instance = owner,
                                 .slot = static_cast<int>(slot),
                                 .output = m->actuator_outadr[j]});
  }
  // The solve's scratch, in the instance that solves (the first of coupled_), sized here so that
  // no step allocates: τ0 and k, R, F, G, a_ext and the handed torques at their largest (n = na).
  const long na = static_cast<long>(stepper->coupled_.size());
  if (na > 0 && stepper->coupled_.front().instance == instance) {
    stepper->scratch_outputs_.resize(na);
    stepper->scratch_.resize(3 * na + na * m->nv + m->nv + na * na + na);
    if (stepper->coupling_ == Coupling::kSubstepped) {
      // The dofs MuJoCo's Euler step damps implicitly (engine_forward.c, mj_EulerSkip): dof
      // damping plus the damping of the actuators with a joint transmission on the dof's joint
      // (times gear²).
      std::vector<double> damping(m->dof_damping, m->dof_damping + m->nv);
      for (int j = 0; j < m->nactuator; ++j) {
        if (m->actuator_trntype[j] != mjTRN_JOINT && m->actuator_trntype[j] != mjTRN_JOINTINPARENT)
          continue;
        const int joint = m->actuator_trnid[2 * j];
        if (m->jnt_type[joint] != mjJNT_HINGE && m->jnt_type[joint] != mjJNT_SLIDE) continue;
        const double gear = m->actuator_gear[6 * m->actuator_outadr[j]];
        damping[m->jnt_dofadr[joint]] += m->actuator_damping[j] * gear * gear;
      }
      for (int v = 0; v < m->nv; ++v) {
        if (damping[v] > 0) {
          stepper->damped_dofs_.push_back(v);
          stepper->dof_damping_.push_back(damping[v]);
        }
      }
      const long s = static_cast<long>(stepper->damped_dofs_.size());
      stepper->substep_states_.resize(na);
      // θ, ω, c0, a_x, commands, statuses, chord, τ; P and B; U, Q, h·D, Eᵀ·M⁻¹·F; M⁻¹·F; the
      // damped dofs' unit columns, then M⁻¹ of them; R-1's 4·n + n².
      stepper->substep_scratch_.resize(8 * na + 2 * na * na + na * s + s * s + 2 * s + m->nv +
                                       2 * s * m->nv + 4 * na + na * na);
    }
  }
  for (int j = 0; j < m->njnt; ++j) {
    if (!m->jnt_actgravcomp[j]) continue;
    const int dofs = m->jnt_type[j] == mjJNT_FREE ? 6 : m->jnt_type[j] == mjJNT_BALL ? 3 : 1;
    for (int v = m->jnt_dofadr[j]; v < m->jnt_dofadr[j] + dofs; ++v) {
      stepper->gravcomp_dofs_.push_back(v);
    }
  }
  return stepper;
}

int Stepper::StateSize(const mjModel* m, int instance) {
  const int actuators = static_cast<int>(BoundActuators(m, instance).size());
  if (actuators == 0) return 0;
  // After the actuators' slots, room for the constraint forces of the step just taken (a flag that
  // they are there, then nv), which the consistent coupling's leader reads at the next step
  // (ConsistentForces); substepped, then each slot's SubstepSlot.
  const std::optional<StepperConfig> c = InstanceConfig(m, instance);
  const int drive = c ? MakeStateLayout(c->drive).total() : 0;
  const int substep =
      c && c->coupling == Coupling::kSubstepped ? actuators * (kSubstepExtras + drive) : 0;
  return actuators * drive + 1 + m->nv + substep;
}

void Stepper::Reset(const mjModel* m, mjtNum* plugin_state, int instance) {
  std::fill_n(plugin_state, m->plugin_statenum[instance], 0.0);
}

double Stepper::Command(const mjModel* m, const mjData* d, const Actuator& a,
                        const DriveState* state) const {
  // Plugins get ctrl raw: clamp it as MuJoCo's mj_fwdActuation does, then test it as MuJoCo does
  // (mju_isBad: NaN or beyond mjMAXVAL = kMaxCommand), which also counts it as mjWARN_BADCTRL for
  // every actuator. MuJoCo then zeroes all controls; a drive instead keeps its command
  // (Drive::CommandFrom), so that one bad sample neither turns its state to NaN nor jerks it.
  if (a.actadr >= 0) {
    // The activation MuJoCo integrated from ctrl (already within actrange if actlimited). Read
    // in advance, after MuJoCo's integration, it is the step's end value: the command over the
    // step is the one MuJoCo's own actuators use with actearly="true" (plugin/README.md).
    return drive_->CommandFrom(d->act[a.actadr], state, d->actuator_length[a.outadr]);
  }
  double ctrl = d->ctrl[a.ctrladr];
  if (m->actuator_ctrllimited[a.ctrladr] && !(m->opt.disableflags & mjDSBL_CLAMPCTRL)) {
    ctrl = std::clamp(ctrl, m->actuator_ctrlrange[2 * a.ctrladr],
                      m->actuator_ctrlrange[2 * a.ctrladr + 1]);  // (NaN stays NaN)
  }
  return drive_->CommandFrom(ctrl, state, d->actuator_length[a.outadr]);
}

DriveState Stepper::CurrentState(const mjModel* m, const mjData* d, int instance, int slot) const {
  DriveState state = drive_->Load(Slot(m, d, instance, slot));
  if (!state.started) {
    const Actuator& a = actuators_[slot];
    state = drive_->Rest(d->time, d->actuator_length[a.outadr], Command(m, d, a, nullptr));
  }
  return state;
}

void Stepper::Compute(const mjModel* m, mjData* d, int instance, int capability) const {
  if (capability == mjPLUGIN_SENSOR) {
    ComputeProbe(m, d, instance);
    return;
  }
  if (!drive_) return;
  // The consistent coupling solves every started coupled stepper of the model at once (C-3), in
  // one instance, the first of coupled_: it writes all their forces, once per step.
  const bool leader = !coupled_.empty() && coupled_.front().instance == instance;
  RestartImplausible(m, d, instance);
  if (leader) {  // the leader reads the other coupled instances' states before their Compute
    int checked = instance;  // an instance repeated in a row once (a second check finds nothing)
    for (const CoupledActuator& c : coupled_) {
      if (c.instance == checked) continue;
      checked = c.instance;
      if (c.instance != instance) FromData(d, c.instance).RestartImplausible(m, d, c.instance);
    }
  }
  for (size_t slot = 0; slot < actuators_.size(); ++slot) {
    const Actuator& a = actuators_[slot];
    // Torque from the currents at the step's start (as MuJoCo's dcmotor without actearly); the
    // core state suffices once the drive has started.
    const double* values = Slot(m, d, instance, slot);
    const bool started = Drive::Started(values);
    // The leader's solve writes it (substepped: from the start).
    if ((started && coupling_ == Coupling::kConsistent) || coupling_ == Coupling::kSubstepped) {
      continue;
    }
    const double torque =
        started ? drive_->StoredTorque(values, d->actuator_length[a.outadr])
                : drive_->Torque(CurrentState(m, d, instance, slot), d->actuator_length[a.outadr]);
    // The gear train's efficiency (transmission.h) on what the rotor hands the load.
    d->actuator_force[a.outadr] =
        torque * drive_->config().transmission.Scale(torque, d->actuator_velocity[a.outadr]);
  }
  if (leader) {
    // The last step's constraint forces as kept in the state (so that a restored state replays
    // bit for bit); before any step (a reset, a new mjData) MuJoCo's own, as mj_forward left them.
    const mjtNum* kept = ConstraintForces(m, d, instance);
    ConsistentForces(m, d, kept[0] != 0 ? kept + 1 : d->qfrc_constraint);
  }
}

double Stepper::OtherActuatorForce(const mjModel* m, const mjData* d, int actuator, int output) {
  // MuJoCo clears actuator_force before the plugins: a stepper not computed yet this step has 0
  // there, so its motor torque at the step's start is read from its own state. Built-in forces
  // are taken as MuJoCo will apply them, within their forcerange.
  const int instance = m->actuator_plugin[actuator];
  double force = d->actuator_force[output];
  if (instance >= 0 && IsStepperInstance(m, instance)) {
    const Stepper& other = FromData(d, instance);
    for (size_t slot = 0; other.drive_ && slot < other.actuators_.size(); ++slot) {
      if (other.actuators_[slot].id != actuator) continue;
      const double* values = other.Slot(m, d, instance, slot);
      if (Drive::Started(values)) {
        force = other.drive_->StoredTorque(values, d->actuator_length[output]);
        force *= other.drive_->config().transmission.Scale(force, d->actuator_velocity[output]);
      }
    }
  }
  if (m->actuator_forcelimited[actuator]) {
    force = mju_clip(force, m->actuator_forcerange[2 * actuator],
                     m->actuator_forcerange[2 * actuator + 1]);
  }
  return force;
}

void Stepper::ConsistentForces(const mjModel* m, mjData* d, const mjtNum* constraint) const {
  // C-3 (core/coupling.h) over every started stepper with the consistent coupling in the model
  // (an arm's steppers see each other through M); it writes every one's force. R: their
  // moment rows; G = R·M⁻¹·Rᵀ from M factorised before actuation; a_ext = R·M⁻¹·F with F what
  // MuJoCo will add up as qfrc_smooth + qfrc_constraint less these steppers: this step's passive
  // (without the damping MuJoCo integrates implicitly: the dofs' and the actuators'), bias
  // (gravity, Coriolis), applied and xfrc forces, every other actuator's force, and the previous
  // step's constraint forces (this step's come after actuation), `constraint`: kept in the
  // leader's plugin state at the end of each step (Advance), not read from d->qfrc_constraint,
  // which no mjSTATE holds, so that mj_setState replays a run bit for bit. A stepper has one output
  // (checked at load); moment rows, actuator_force and actuator_velocity are per output.
  const int na = static_cast<int>(coupled_.size());  // at most this many rows
  const int nv = m->nv;
  // Substepped: every member from its first step (its drive starts at rest then), and F with the
  // damping MuJoCo integrates implicitly, which R-2 accounts for.
  const bool substepped = coupling_ == Coupling::kSubstepped;
  int* outputs = scratch_outputs_.data();  // the started ones' outputs
  mjtNum* torque = scratch_.data();        // τ0 (N·m), then k (N·m/rad)
  mjtNum* stiffness = torque + na;
  int n = 0;
  for (const CoupledActuator& c : coupled_) {
    const Stepper& s = FromData(d, c.instance);
    const double* values = s.Slot(m, d, c.instance, c.slot);
    if (!s.drive_ || s.coupling_ != coupling_ || (!substepped && !Drive::Started(values))) continue;
    const double theta = d->actuator_length[c.output];
    outputs[n] = c.output;
    std::tie(torque[n], stiffness[n]) = s.drive_->StoredTorqueAndStiffness(values, theta);
    // The gear train's efficiency (transmission.h) scales what the rotor hands the load, and so
    // its stiffness as the load sees it (the factor depends on the speed, not the angle).
    const double scale =
        s.drive_->config().transmission.Scale(torque[n], d->actuator_velocity[c.output]);
    torque[n] *= scale;
    stiffness[n] *= scale;
    ++n;
  }
  if (n == 0) return;
  auto row_of = [d](int output) {
    const int begin = d->moment_rowadr[output];
    return std::pair{begin, begin + d->moment_rownnz[output]};
  };
  mjtNum* rows = torque + 2 * na;              // R, then M⁻¹·Rᵀ row by row
  mjtNum* force = rows + n * nv;               // F, N·m or N
  mjtNum* inverse_inertia = force + nv;        // G, 1/(kg·m²), row-major
  mjtNum* external = inverse_inertia + n * n;  // a_ext, rad/s²
  mjtNum* handed = external + n;               // C-3's torques, N·m
  mju_zero(rows, n * nv);
  for (int i = 0; i < n; ++i) {
    const auto [begin, end] = row_of(outputs[i]);
    for (int k = begin; k < end; ++k) rows[i * nv + d->moment_colind[k]] = d->actuator_moment[k];
  }
  mj_solveM(m, d, rows, rows, n);  // M⁻¹·rᵢᵀ
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const auto [begin, end] = row_of(outputs[j]);
      double g = 0;
      for (int k = begin; k < end; ++k) {
        g += d->actuator_moment[k] * rows[i * nv + d->moment_colind[k]];
      }
      inverse_inertia[i * n + j] = g;
    }
  }
  for (int v = 0; v < nv; ++v) {
    force[v] = d->qfrc_passive[v] + (substepped ? 0.0 : m->dof_damping[v] * d->qvel[v]) -
               d->qfrc_bias[v] + d->qfrc_applied[v] + constraint[v];
  }
  for (int b = 1; b < m->nbody; ++b) {  // xfrc_applied at each body's centre of mass
    const mjtNum* wrench = d->xfrc_applied + 6 * b;
    if (wrench[0] || wrench[1] || wrench[2] || wrench[3] || wrench[4] || wrench[5]) {
      mj_applyFT(m, d, wrench, wrench + 3, d->xipos + 3 * b, b, force);
    }
  }
  for (int j = 0; j < m->nactuator; ++j) {
    for (int o = m->actuator_outadr[j]; o < m->actuator_outadr[j] + m->actuator_outnum[j]; ++o) {
      const bool member = std::find(outputs, outputs + n, o) != outputs + n;
      const double actuator = (member ? 0.0 : OtherActuatorForce(m, d, j, o)) +
                              (substepped ? 0.0 : m->actuator_damping[j] * d->actuator_velocity[o]);
      if (actuator == 0) continue;
      const auto [begin, end] = row_of(o);
      for (int k = begin; k < end; ++k) {
        force[d->moment_colind[k]] += d->actuator_moment[k] * actuator;
      }
    }
  }
  for (int v : gravcomp_dofs_) force[v] += d->qfrc_gravcomp[v];  // counted with the actuators
  if (substepped) {
    SubsteppedForces(m, d, n, outputs, rows, inverse_inertia, force);
    return;
  }
  for (int i = 0; i < n; ++i) external[i] = mju_dot(rows + i * nv, force, nv);  // (M⁻¹·rᵢᵀ)·F
  const double h = m->opt.timestep;
  for (int i = 0; i < n; ++i) d->actuator_force[outputs[i]] = torque[i];  // τ0 unless solved
  if (n == 1) {                                                           // C-2
    if (inverse_inertia[0] > 0) {
      d->actuator_force[outputs[0]] =
          ConsistentTorque(torque[0], stiffness[0], 1.0 / inverse_inertia[0], external[0], h);
    }
  } else {
    try {  // C-3/C-4 allocate beyond 8 steppers: no exception crosses into MuJoCo
      ConsistentTorques(std::span(inverse_inertia, n * n), std::span(stiffness, n),
                        std::span(torque, n), std::span(external, n), h, std::span(handed, n));
      for (int i = 0; i < n; ++i) d->actuator_force[outputs[i]] = handed[i];
    } catch (...) {
    }
  }
}

void Stepper::SubsteppedForces(const mjModel* m, mjData* d, int n, const int* outputs,
                               const mjtNum* rows, const mjtNum* inverse_inertia,
                               const mjtNum* force) const {
  const int nv = m->nv;
  if (n != static_cast<int>(coupled_.size())) return;  // (every member takes part: load checks)
  const double h = m->opt.timestep;                    // s
  const double t0 = d->time;
  const double t1 = d->time + h;    // as MuJoCo's mj_advance will make it, to the bit
  if (member_stiffness_.empty()) {  // the members' drives exist once every instance has loaded
    for (const CoupledActuator& c : coupled_) {
      const Drive& drive = *FromData(d, c.instance).drive_;
      member_stiffness_.push_back(drive.HoldingStiffness() + drive.DetentStiffness());
      // The torque's fastest forcing per rad/s of rotor speed: the full-step ripple (4·Nr, the
      // table's steps and the current loop's) or the detent's highest harmonic h·Nr (S-5).
      double order = 4;
      for (const DetentHarmonic& harmonic : drive.config().motor.detent) {
        order = std::max(order, static_cast<double>(harmonic.order));
      }
      member_forcing_.push_back(order * drive.config().motor.rotor_teeth);
    }
  }
  // The damped dofs MuJoCo's step damps implicitly this step (none with damping disabled).
  const bool damped =
      !(m->opt.disableflags & mjDSBL_DAMPER) &&
      !(m->opt.integrator == mjINT_EULER && (m->opt.disableflags & mjDSBL_EULERDAMP));
  const int s = damped ? static_cast<int>(damped_dofs_.size()) : 0;
  double* theta = substep_scratch_.data();  // rad, rotor side
  double* omega = theta + n;                // rad/s
  double* start_speed = omega + n;          // c0, rad/s
  double* accel = start_speed + n;          // a_x, rad/s²
  double* command = accel + n;
  double* status = command + n;
  double* chord = status + n;  // rad/s
  double* handed = chord + n;  // N·m
  double* p = handed + n;      // R·M⁻¹·D·M⁻¹·Rᵀ
  double* b = p + n * n;       // B, 1/s
  double* u = b + n * n;       // U = R·M⁻¹·E
  double* q = u + n * s;       // Q = Eᵀ·M⁻¹·E
  double* step_damping = q + s * s;
  double* damped_force = step_damping + s;
  double* solved_force = damped_force + s;  // M⁻¹·F
  double* columns = solved_force + nv;      // E's columns, then M⁻¹·E
  double* solved_columns = columns + s * nv;
  double* integrator = solved_columns + s * nv;  // R-1's scratch
  for (int i = 0; i < n; ++i) {
    const CoupledActuator& c = coupled_[i];
    const Stepper& owner = FromData(d, c.instance);
    const Drive& drive = *owner.drive_;
    const Actuator& a = owner.actuators_[c.slot];
    DriveState& state = substep_states_[i];
    state = drive.Load(owner.Slot(m, d, c.instance, c.slot));
    command[i] = owner.Command(m, d, a, &state);  // as Advance reads it
    theta[i] = d->actuator_length[c.output];
    if (!state.started) state = drive.Rest(t0, theta[i], command[i]);
    if (state.theta != theta[i]) drive.Relocate(&state, theta[i]);  // MuJoCo's angle rules
    start_speed[i] = d->actuator_velocity[c.output];
    omega[i] = owner.RotorSpeed(m, d, c.instance, c.slot, start_speed[i]);  // the rotor's own
    accel[i] = mju_dot(rows + i * nv, force, nv);
    status[i] = static_cast<double>(AdvanceStatus::kOk);
    // Should the landing fail: the motor's torque at the step's start.
    const double torque = drive.TorqueAndStiffness(state, theta[i]).first;
    d->actuator_force[c.output] =
        torque * drive.config().transmission.Scale(torque, start_speed[i]);
  }
  if (m->opt.integrator == mjINT_RK4) {
    // Set after loading (which refuses it): RK4's four stages would leave the last stage's
    // tentative states. The motors' torques at the step's start are handed over and each drive
    // advances on its own in advance, as with the explicit coupling.
    for (const CoupledActuator& c : coupled_) {
      FromData(d, c.instance).SubstepSlot(m, d, c.instance, c.slot)[kStamp] = -1;
    }
    WarnOnce(kCauseSubsteppedRk4,
             "mjstepper: coupling = \"substepped\" with the RK4 integrator (set after loading): "
             "the steppers run with the explicit coupling's torque; use integrator Euler or "
             "implicitfast");
    return;
  }
  // R-1's B from P = Σ over damped dofs of (M⁻¹·rᵢᵀ)·D·(M⁻¹·rⱼᵀ).
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      double sum = 0;
      for (int k = 0; k < s; ++k) {
        const int v = damped_dofs_[k];
        sum += rows[i * nv + v] * dof_damping_[k] * rows[j * nv + v];
      }
      p[i * n + j] = sum;
    }
  }
  if (s > 0)
    RotorDamping(std::span(inverse_inertia, n * n), std::span(p, n * n), std::span(b, n * n));

  class Members final : public SubsteppedMotors {
   public:
    Members(const Stepper& leader, const mjData* d, double step_start, double step_end,
            DriveState* states, const double* commands, double* statuses)
        : leader_(leader),
          d_(d),
          step_start_(step_start),
          step_end_(step_end),
          states_(states),
          commands_(commands),
          statuses_(statuses) {}
    std::pair<double, double> TorqueAndStiffness(int i, double theta, double speed) override {
      const Drive& drive = DriveOf(i);
      const auto [torque, stiffness] = drive.TorqueAndStiffness(states_[i], theta);
      // The gear train's efficiency (transmission.h) on what the rotor hands the load.
      const double scale = drive.config().transmission.Scale(torque, speed);
      return {torque * scale, stiffness * scale};
    }
    void Advance(int i, double t0, double t1, double theta1) override {
      // The command holds to the MuJoCo step's end (ctrl is the step's).
      // voltage_peak over the MuJoCo step: its sub-steps' largest.
      const double peak = t0 > step_start_ ? states_[i].voltage_peak : 0.0;  // V
      const AdvanceStatus status =
          DriveOf(i).Advance(&states_[i], t0, t1, theta1, commands_[i], step_end_);
      states_[i].voltage_peak = std::max(peak, states_[i].voltage_peak);
      if (status != AdvanceStatus::kOk && statuses_[i] == 0)
        statuses_[i] = static_cast<int>(status);
    }

   private:
    const Drive& DriveOf(int i) const { return *FromData(d_, leader_.coupled_[i].instance).drive_; }
    const Stepper& leader_;
    const mjData* d_;
    double step_start_;  // s
    double step_end_;    // s
    DriveState* states_;
    const double* commands_;
    double* statuses_;
  } members(*this, d, t0, t1, substep_states_.data(), command, status);

  // Sub-steps for the stiffest rotor mode and for the fastest forcing at the rotors' speeds.
  const double ring = FastestRotorMode(std::span(inverse_inertia, n * n), member_stiffness_);
  double forcing = 0;  // rad/s
  for (int i = 0; i < n; ++i) forcing = std::max(forcing, member_forcing_[i] * std::abs(omega[i]));
  const int substeps = SubstepCount(ring, forcing, h);
  for (int i = 0; i < n; ++i) chord[i] = theta[i];  // θ0, kept for the chord
  IntegrateRotors({.inverse_inertia = std::span(inverse_inertia, n * n),
                   .acceleration = std::span(accel, n),
                   .damping = s > 0 ? std::span<const double>(b, n * n) : std::span<const double>(),
                   .reference_speed = std::span(start_speed, n)},
                  members, t0, t1, substeps, std::span(theta, n), std::span(omega, n),
                  std::span(integrator, 4 * n + n * n));
  for (int i = 0; i < n; ++i) chord[i] = (theta[i] - chord[i]) / h;  // rad/s

  // R-2 with E's columns solved through M's factor (MuJoCo's, from the step's start).
  mju_zero(columns, s * nv);
  for (int k = 0; k < s; ++k) columns[k * nv + damped_dofs_[k]] = 1;
  if (s > 0) mj_solveM(m, d, solved_columns, columns, s);
  mj_solveM(m, d, solved_force, force, 1);
  for (int k = 0; k < s; ++k) {
    const int v = damped_dofs_[k];
    for (int i = 0; i < n; ++i) u[i * s + k] = rows[i * nv + v];
    for (int l = 0; l < s; ++l) q[k * s + l] = solved_columns[k * nv + damped_dofs_[l]];
    step_damping[k] = h * dof_damping_[k];
    damped_force[k] = solved_force[v];
  }
  const bool landed = LandingTorques({.inverse_inertia = std::span(inverse_inertia, n * n),
                                      .damped_rows = std::span(u, n * s),
                                      .damped_block = std::span(q, s * s),
                                      .step_damping = std::span(step_damping, s),
                                      .acceleration = std::span(accel, n),
                                      .damped_force = std::span(damped_force, s),
                                      .start_speed = std::span(start_speed, n)},
                                     std::span(chord, n), h, std::span(handed, n));
  for (int i = 0; i < n; ++i) {
    const CoupledActuator& c = coupled_[i];
    if (landed) d->actuator_force[outputs[i]] = handed[i];
    const Stepper& owner = FromData(d, c.instance);
    mjtNum* slot = owner.SubstepSlot(m, d, c.instance, c.slot);
    slot[kStamp] = t1;
    slot[kNextSpeed] = omega[i];
    slot[kNextChord] = chord[i];
    slot[kStatus] = status[i];
    owner.drive_->Store(substep_states_[i], slot + kSubstepExtras);
  }
}

void Stepper::RestartImplausible(const mjModel* m, mjData* d, int instance) const {
  for (size_t slot = 0; slot < actuators_.size(); ++slot) {
    mjtNum* values = Slot(m, d, instance, slot);
    if (!Drive::Started(values) || drive_->Plausible(values)) continue;
    const Actuator& a = actuators_[slot];
    drive_->Store(drive_->Rest(d->time, d->actuator_length[a.outadr], Command(m, d, a, nullptr)),
                  values);
    WarnOnce(kCauseStatus + static_cast<unsigned>(AdvanceStatus::kBadState),
             fmt::format("mjstepper: actuator '{}' (id {}) at time {:g} s: {}",
                         NameOf(m, m->name_actuatoradr[a.id]), a.id, d->time,
                         Describe(AdvanceStatus::kBadState)));
  }
}

bool Stepper::WarnOnce(unsigned cause, const std::string& message) const {
  const unsigned bit = 1u << cause;
  if (warned_.fetch_or(bit) & bit) return false;
  mju_warning("%s", message.c_str());
  return true;
}

mjtNum* Stepper::ConstraintForces(const mjModel* m, mjData* d, int instance) const {
  return d->plugin_state + m->plugin_stateadr[instance] +
         static_cast<long>(actuators_.size()) * state_size_;
}

void Stepper::Advance(const mjModel* m, mjData* d, int instance) const {
  if (!drive_) return;
  if (!coupled_.empty() && coupled_.front().instance == instance) {  // the coupling's leader
    mjtNum* kept = ConstraintForces(m, d, instance);
    kept[0] = 1;  // kept from now on
    mju_copy(kept + 1, d->qfrc_constraint, m->nv);
  }
  const double timestep = m->opt.timestep;  // s
  const double t1 = d->time;  // s, the step's end: MuJoCo advances time before plugins
  auto actuator_name = [m](const Actuator& a) {
    return fmt::format("actuator '{}' (id {})", NameOf(m, m->name_actuatoradr[a.id]), a.id);
  };
  if (!(timestep > 0 && std::isfinite(timestep))) {
    // Set after loading (the compiler refuses it): the drives are held as they are.
    WarnOnce(kCauseBadTimestep,
             fmt::format("mjstepper: {} at time {:g} s: timestep = {:g} s is not a positive finite "
                         "number; the drive is held unchanged",
                         actuator_name(actuators_.front()), t1, timestep));
    return;
  }
  const double t0 = t1 - timestep;
  if (!InterruptsFit(timestep, drive_->config().isr_period)) {
    // Raised after loading (which refuses it): every interrupt still runs (up to the drive's
    // kMaxTicksPerAdvance), so say what it costs.
    WarnOnce(
        kCauseManyInterrupts,
        fmt::format("mjstepper: timestep {:g} s runs {:.0f} interrupts per step, more than the "
                    "{} a load allows; use isr_period >= {:g} (s) or a smaller timestep",
                    timestep, timestep / drive_->config().isr_period, kMaxInterruptsPerStep,
                    LeastIsrPeriod(timestep)));
  }
  for (size_t slot = 0; slot < actuators_.size(); ++slot) {
    const Actuator& a = actuators_[slot];
    DriveState state = drive_->Load(Slot(m, d, instance, slot));
    // (A bad ctrl is counted by MuJoCo itself, mjWARN_BADCTRL, for plugin actuators too.)
    const double command = Command(m, d, a, &state);
    AdvanceStatus status = AdvanceStatus::kBadTime;
    mjtNum* substep =
        coupling_ == Coupling::kSubstepped ? SubstepSlot(m, d, instance, slot) : nullptr;
    if (substep != nullptr && substep[kStamp] == t1 && Drive::Started(substep + kSubstepExtras)) {
      // The state this step's compute sub-stepped to (SubsteppedForces), and the rotor's speed.
      state = drive_->Load(substep + kSubstepExtras);
      status = static_cast<AdvanceStatus>(static_cast<int>(substep[kStatus]));
      substep[kSpeedKept] = 1;
      substep[kSpeed] = substep[kNextSpeed];
      substep[kChord] = substep[kNextChord];
      substep[kStamp] = -1;  // taken
      // Where MuJoCo's step did not land on the sub-stepped angle (this step's constraint forces
      // differ from the last's, which R-1 assumed), the rotor is where MuJoCo put it.
      const double theta1 = RotorAngleAtEnd(m, d, a);
      if (theta1 != state.theta) drive_->Relocate(&state, theta1);
      drive_->Store(state, Slot(m, d, instance, slot));
    } else if (state.started || std::isfinite(t0)) {
      if (substep != nullptr) substep[kSpeedKept] = 0;  // (compute did not run this step)
      // actuator_length still holds the step's start value here (Euler, implicitfast).
      if (!state.started) state = drive_->Rest(t0, d->actuator_length[a.outadr], command);
      const double theta1 = RotorAngleAtEnd(m, d, a);  // rad, rotor side, at t1
      status = drive_->Advance(&state, t0, t1, theta1, command);
      drive_->Store(state, Slot(m, d, instance, slot));
    }
    if (status != AdvanceStatus::kOk) {
      WarnOnce(kCauseStatus + static_cast<unsigned>(status),
               fmt::format("mjstepper: {} at time {:g} s (timestep {:g} s): {}", actuator_name(a),
                           t1, timestep, Describe(status)));
    }
    // Heat: beyond kMostLawTemperature R(T) and Km(T) are held at their values there (thermal.h);
    // said once per instance with the temperature (issue 33: R read 11.22 Ω for ever, silently).
    if (const std::optional<HeatParams>& heat = drive_->config().heat;
        heat && state.winding_temperature > kMostLawTemperature) {
      WarnOnce(kCauseLawRange,
               fmt::format("mjstepper: {} at time {:g} s: winding temperature {:.1f} °C, beyond "
                           "the {:g} °C to which R(T) and Km(T) are taken: they are held at their "
                           "{:g} °C values (R = {:.4g} Ω) from here; a real winding burnt long "
                           "before (its class: {:g} °C)",
                           actuator_name(a), t1, state.winding_temperature, kMostLawTemperature,
                           kMostLawTemperature, drive_->ResistanceAt(kMostLawTemperature),
                           heat->insulation_limit));
    }
    // Heat: a winding past its insulation class is said once per actuator (SPEC §8).
    if (const std::optional<HeatParams>& heat = drive_->config().heat;
        heat && state.winding_temperature > heat->insulation_limit &&
        !insulation_warned_[slot].exchange(true)) {
      mju_warning("%s",
                  fmt::format("mjstepper: {} at time {:g} s: winding temperature {:.1f} °C "
                              "passed its insulation class {} ({:g} °C); the simulation "
                              "goes on, but a real winding ages fast there: lower the "
                              "current or cool the motor",
                              actuator_name(a), t1, state.winding_temperature,
                              InsulationClassName(heat->insulation_limit), heat->insulation_limit)
                      .c_str());
    }
  }
}

void Stepper::Visualize(const mjModel* m, const mjData* d, mjvScene* scene, int instance) const {
  if (!drive_ || !gauge_) return;
  for (size_t slot = 0; slot < actuators_.size(); ++slot) {
    if (scene->ngeom + 2 > scene->maxgeom) return;
    const Actuator& a = actuators_[slot];
    const int joint = a.gauge_joint;
    if (joint < 0) continue;  // a tendon with no hinge of its own to draw on
    const int body = m->jnt_bodyid[joint];
    const double theta = d->actuator_length[a.outadr];
    const double load_angle = drive_->Signals(CurrentState(m, d, instance, slot), theta).load_angle;
    const double radius = a.gauge_radius;  // m (GaugeRadius)
    // The gauge sits just beyond the rotor body's geoms on the side the camera looks from
    // (mjv_updateScene runs this before it updates the scene's cameras: a renderer that wants
    // this frame's view calls mjv_updateCamera first; a viewer's is a frame old): the rotor never
    // hides it. Without a camera yet (all zero), the +axis side.
    const mjtNum* anchor = d->xanchor + 3 * joint;
    const mjvGLCamera* eyes = scene->camera;  // left and right eye (the same without stereo)
    mjtNum to_eye[3], forward = 0;
    for (int i = 0; i < 3; ++i) {
      to_eye[i] = 0.5 * (eyes[0].pos[i] + eyes[1].pos[i]) - anchor[i];
      forward += eyes[0].forward[i] * eyes[0].forward[i];
    }
    const bool has_camera = forward > 0.25;  // a unit vector once the camera is set
    // The dial's normal: a hinge's axis, its face on the camera's side along it; a slide's
    // carriage has no rotor, so its dial faces the camera (else up) from the carriage's near side,
    // the slide's axis its reference (issue 32, item 4: along the slide, beyond the carriage's
    // end, the dial left the frame that holds the carriage).
    const mjtNum* joint_axis = d->xaxis + 3 * joint;
    const bool slide = m->jnt_type[joint] == mjJNT_SLIDE;
    mjtNum axis[3] = {joint_axis[0], joint_axis[1], joint_axis[2]};
    if (slide) {
      const mjtNum up[3] = {0, 0, 1};
      mju_copy3(axis, has_camera ? to_eye : up);
      if (mju_normalize3(axis) < mjMINVAL) mju_copy3(axis, up);
    }
    // Reference: the slide's axis, or the body's y axis (else x), with its component along the
    // dial's normal removed.
    const mjtNum* xmat = d->xmat + 9 * body;
    mjtNum ref[3];
    for (int k : {-1, 1, 0}) {
      if (k < 0 && !slide) continue;
      const mjtNum column[3] = {k < 0 ? joint_axis[0] : xmat[k],
                                k < 0 ? joint_axis[1] : xmat[3 + k],
                                k < 0 ? joint_axis[2] : xmat[6 + k]};
      mju_addScl3(ref, column, axis, -mju_dot3(column, axis));
      if (mju_normalize3(ref) > 0.1) break;
    }
    // The rotor's electrical arrow at −δ from the command's: u·cos δ − (axis × u)·sin δ.
    mjtNum side[3], rotor[3];
    mju_cross(side, axis, ref);
    mju_scl3(rotor, ref, std::cos(load_angle));
    mju_addToScl3(rotor, side, -std::sin(load_angle));
    const double sense = has_camera && mju_dot3(to_eye, axis) < 0 ? -1.0 : 1.0;
    mjtNum toward[3];  // unit, along the axis toward the camera
    mju_scl3(toward, axis, sense);
    // How far the rotor's geoms reach along `toward` from the anchor: each geom's box (geom_aabb
    // in the geom's frame) projected on it.
    double reach = 0;  // m
    for (int g = m->body_geomadr[body]; g >= 0 && g < m->body_geomadr[body] + m->body_geomnum[body];
         ++g) {
      const mjtNum* aabb = m->geom_aabb + 6 * g;
      const mjtNum* R = d->geom_xmat + 9 * g;
      mjtNum centre_world[3], offset[3];
      mju_mulMatVec3(offset, R, aabb);
      mju_add3(centre_world, d->geom_xpos + 3 * g, offset);
      mju_subFrom3(centre_world, anchor);
      double extent = mju_dot3(centre_world, toward);
      for (int j = 0; j < 3; ++j) {  // |u·R e_j| h_j
        extent +=
            std::abs(toward[0] * R[j] + toward[1] * R[3 + j] + toward[2] * R[6 + j]) * aabb[3 + j];
      }
      reach = std::max(reach, extent);
    }
    mjtNum centre[3];
    // (0.3 radius: the thick arrow's half width, 0.16 radius, and its head's clear the rotor.)
    mju_addScl3(centre, anchor, toward, reach + 0.3 * radius);
    // Command: long and thin, just above; rotor: shorter and thick: both show when they overlap.
    // (MuJoCo draws an arrow of this length about as long as the rotor radius at these widths.)
    struct Arrow {
      const mjtNum* direction;
      float rgba[4];
      double length, width, lift;
    };
    const Arrow arrows[2] = {{ref, {0.1f, 0.85f, 0.25f, 1.0f}, 2.0, 0.09, 0.25},
                             {rotor, {0.85f, 0.2f, 0.9f, 1.0f}, 1.5, 0.16, 0.0}};
    for (const Arrow& arrow : arrows) {
      mjvGeom* geom = scene->geoms + scene->ngeom++;
      mjv_initGeom(geom, mjGEOM_ARROW, nullptr, nullptr, nullptr, arrow.rgba);
      mjtNum from[3], tip[3];
      mju_addScl3(from, centre, toward, arrow.lift * radius);
      mju_addScl3(tip, from, arrow.direction, arrow.length * radius);
      mjv_connector(geom, mjGEOM_ARROW, arrow.width * radius, from, tip);
      geom->category = mjCAT_DECOR;
    }
  }
}

void Stepper::ComputeProbe(const mjModel* m, mjData* d, int instance) const {
  for (int s = 0; s < m->nsensor; ++s) {
    if (m->sensor_plugin[s] != instance) continue;
    const int a = m->sensor_objid[s];
    const int owner = m->actuator_plugin[a];
    const Stepper& drive = FromData(d, owner);
    const auto it = std::find_if(drive.actuators_.begin(), drive.actuators_.end(),
                                 [a](const Actuator& x) { return x.id == a; });
    const int slot = static_cast<int>(it - drive.actuators_.begin());
    const DriveState state = drive.CurrentState(m, d, owner, slot);
    DriveSignals signals = drive.drive_->Signals(state, d->actuator_length[it->outadr]);
    // MuJoCo's rotor speed from the moment row and qvel: the probe runs at the position stage,
    // before MuJoCo computes actuator_velocity.
    signals.omega = drive.RotorSpeed(m, d, owner, slot, MomentRate(d, it->outadr));
    const std::array<double, kNumSignals> values = SignalValues(signals);
    std::copy(values.begin(), values.end(), d->sensordata + m->sensor_adr[s]);
  }
}

double Stepper::RotorSpeed(const mjModel* m, const mjData* d, int instance, int slot,
                           double mujoco) const {
  if (coupling_ != Coupling::kSubstepped) return mujoco;
  // The sub-stepped rotor's speed at the last step's end, moved by whatever moved MuJoCo's speed
  // off the chord it was asked for (this step's constraint forces, a user's write); MuJoCo's own
  // before any step.
  const mjtNum* kept = SubstepSlot(m, d, instance, slot);
  return kept[kSpeedKept] != 0 ? kept[kSpeed] + (mujoco - kept[kChord]) : mujoco;
}

void RegisterStepperPlugin() {
  static const std::vector<const char*>& attributes = AttributeNames();
  mjpPlugin plugin;
  mjp_defaultPlugin(&plugin);
  plugin.name = kPluginName;
  plugin.capabilityflags = mjPLUGIN_ACTUATOR | mjPLUGIN_SENSOR;
  // The signals are functions of the drive state at the step's start and of actuator_length, both
  // known after mj_fwdPosition; the torques among them are recomputed from the currents, not read
  // from actuator_force. So the position stage suffices, and MuJoCo skips mj_rnePostConstraint,
  // which it runs before any acceleration-stage plugin sensor.
  plugin.needstage = mjSTAGE_POS;
  plugin.nattribute = static_cast<int>(attributes.size());
  plugin.attributes = attributes.data();
  plugin.nstate = +[](const mjModel* m, int instance) { return Stepper::StateSize(m, instance); };
  plugin.nsensordata = +[](const mjModel*, int, int) { return static_cast<int>(kNumSignals); };
  plugin.init =
      +[](const mjModel* m, mjData* d, int instance) { return Stepper::Init(m, d, instance); };
  plugin.destroy = +[](mjData* d, int instance) {
    delete reinterpret_cast<Stepper*>(d->plugin_data[instance]);
    d->plugin_data[instance] = 0;
  };
  plugin.reset = +[](const mjModel* m, mjtNum* plugin_state, void*, int instance) {
    Stepper::Reset(m, plugin_state, instance);
  };
  plugin.compute = +[](const mjModel* m, mjData* d, int instance, int capability) {
    Stepper::FromData(d, instance).Compute(m, d, instance, capability);
  };
  plugin.advance = +[](const mjModel* m, mjData* d, int instance) {
    Stepper::FromData(d, instance).Advance(m, d, instance);
  };
  plugin.visualize =
      +[](const mjModel* m, mjData* d, const mjvOption*, mjvScene* scene, int instance) {
        Stepper::FromData(d, instance).Visualize(m, d, scene, instance);
      };
  mjp_registerPlugin(&plugin);
}

}  // namespace mjstepper::plugin
