#include "size.h"

#include <fmt/format.h>
#include <fmt/ostream.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <optional>
#include <ostream>
#include <span>
#include <stdexcept>

#include "cancel.h"
#include "config.h"
#include "core/attributes.h"
#include "core/command_profile.h"
#include "core/controllers/registry.h"
#include "core/motion_profile.h"
#include "core/thermal.h"
#include "core/units.h"
#include "csv_writer.h"
#include "options.h"
#include "output_file.h"
#include "stepper_model.h"

namespace mjstepper::tools {
namespace {

// A file name's part from an actuator's name: letters, digits, '_' and '-', every other character
// '_', so that no name can lead a path elsewhere.
std::string FilePart(const std::string& name) {
  std::string out;
  for (char ch : name) {
    out += std::isalnum(static_cast<unsigned char>(ch)) || ch == '-' ? ch : '_';
  }
  return out.empty() ? "_" : out;
}

const StepperActuator& FindStepper(const StepperModel& sm, const std::string& name,
                                   const std::string& option, const std::string& text) {
  for (const StepperActuator& s : sm.steppers) {
    if (s.name == name) return s;
  }
  std::string names;
  for (const StepperActuator& s : sm.steppers) names += (names.empty() ? "" : ", ") + s.name;
  throw std::invalid_argument(fmt::format("{} {}={}: no stepper actuator named '{}' (steppers: {})",
                                          option, name, text, name, names));
}

// The <config> value `key` of the stepper's plugin instance ("" when not given).
std::string ConfigText(const mjModel* m, const StepperActuator& s, const char* key) {
  const char* value = mj_getPluginConfig(m, m->actuator_plugin[s.actuator], key);
  return value != nullptr ? value : "";
}

// A CSV text field, quoted (RFC 4180) when it holds a comma, a quote or a line break.
std::string CsvText(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char ch : text) out += ch == '"' ? std::string("\"\"") : std::string(1, ch);
  return out + "\"";
}

std::string XmlEscape(const std::string& text) {
  std::string out;
  for (char ch : text) {
    switch (ch) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += ch;
    }
  }
  return out;
}

// The pull-out bench of a stepper: its <config> with the motion profile off, on a free rotor of
// rotor-side inertia `inertia` (kg·m²) and the actuator's damping, no gravity, at a timestep that
// resolves its holding resonance (ω·h <= 0.1, and no coarser than the drive's interrupt period).
// A joint's --move, --speed or --accel values in its own SI unit (rad or m and their rates): a
// slide or a tendon takes lengths, a hinge angles, and a hinge with a declared carriage (a
// pulley or lead screw, README "Linear axes") either, lengths at the carriage turned into the
// joint's angle, q = x/r.
std::vector<double> JointValues(const mjModel* m, const StepperActuator& s,
                                const std::string& option, const std::string& text,
                                JointQuantity quantity, bool single) {
  const double radius = s.config.transmission.MetresPerRadian();  // m/rad, 0: none
  const bool hinge = !RadPerMetre(m, s).has_value() || radius > 0;
  bool linear = false;
  std::vector<double> values =
      ParseJointValues(option, text, quantity,
                       radius > 0 ? std::nullopt : std::optional<bool>(!hinge), single, &linear);
  if (radius > 0 && linear) {
    for (double& v : values) v /= radius;
  }
  return values;
}

std::string BenchModel(const mjModel* m, const StepperActuator& s, double inertia) {
  const StepperResolution r = Resolution(m, s);
  const double omega = std::sqrt((r.stiffness + r.detent_stiffness) / inertia);  // rad/s
  double h = s.config.isr_period;                                                // s
  if (omega > 0 && 0.1 / omega < h) h = 0.1 / omega;
  // A force-limited actuator applies at most its forcerange: so does the bench's.
  const std::string limits =
      m->actuator_forcelimited[s.actuator]
          ? fmt::format(" forcelimited=\"true\" forcerange=\"{:.17g} {:.17g}\"",
                        m->actuator_forcerange[2 * s.actuator],
                        m->actuator_forcerange[2 * s.actuator + 1])
          : "";
  std::string config;
  for (const char* key : plugin::AttributeNames()) {
    const std::string name = key;
    // The bench is a bare rotor: its carriage (a linear joint's) is the sized joint's, in Size.
    if (name.starts_with("profile") || name == "gauge" || name == "pulley_teeth" ||
        name == "belt_pitch" || name == "lead") {
      continue;
    }
    const std::string value = ConfigText(m, s, key);
    if (!value.empty()) {
      config += fmt::format("      <config key=\"{}\" value=\"{}\"/>\n", name, XmlEscape(value));
    }
  }
  return fmt::format(
      "<mujoco model=\"size_bench\">\n"
      "  <option timestep=\"{:.6g}\" integrator=\"implicitfast\" gravity=\"0 0 0\"/>\n"
      "  <extension><plugin plugin=\"mjstepper.stepper\"/></extension>\n"
      "  <worldbody><body name=\"rotor\"><joint name=\"shaft\" type=\"hinge\" axis=\"0 0 1\"/>\n"
      "    <inertial pos=\"0 0 0\" mass=\"0.001\" diaginertia=\"1e-12 1e-12 1e-12\"/></body>"
      "</worldbody>\n"
      "  <actuator>\n"
      "    <plugin name=\"{}\" joint=\"shaft\" plugin=\"mjstepper.stepper\" armature=\"{:.17g}\" "
      "damping=\"{:.17g}\"{}>\n{}"
      "      <config key=\"profile\" value=\"none\"/>\n"
      "      <config key=\"gauge\" value=\"off\"/>\n"
      "    </plugin>\n"
      "  </actuator>\n"
      "</mujoco>\n",
      h, XmlEscape(s.name), inertia, m->actuator_damping[s.actuator], limits, config);
}

// Centred moving average of v over n samples (fewer at the ends).
std::vector<double> MovingAverage(const std::vector<double>& v, long n) {
  std::vector<double> prefix(v.size() + 1, 0.0);
  for (size_t i = 0; i < v.size(); ++i) prefix[i + 1] = prefix[i] + v[i];
  std::vector<double> out(v.size());
  const long size = static_cast<long>(v.size());
  for (long i = 0; i < size; ++i) {
    const long lo = std::max(0L, i - n / 2), hi = std::min(size, lo + n);
    out[i] = (prefix[hi] - prefix[lo]) / static_cast<double>(hi - lo);
  }
  return out;
}

// The pull-out torque at |speed|, linear between the curve's points (held beyond its ends).
double PullOutAt(const std::vector<PullOutPoint>& curve, double speed) {
  speed = std::abs(speed);
  if (speed <= curve.front().speed) return curve.front().torque;
  for (size_t k = 1; k < curve.size(); ++k) {
    if (speed <= curve[k].speed) {
      const double f = (speed - curve[k - 1].speed) / (curve[k].speed - curve[k - 1].speed);
      return curve[k - 1].torque + f * (curve[k].torque - curve[k - 1].torque);
    }
  }
  return curve.back().torque;
}

// (T_po − |τ|)/max(T_po, |τ|): 1 − |τ|/T_po while the motor has the torque; beyond its curve,
// minus the share of the demand it lacks (−1: no torque at that speed at all).
double Margin(double torque, double pullout) {
  const double scale = std::max(pullout, std::abs(torque));
  return scale > 0 ? (pullout - std::abs(torque)) / scale : 1.0;
}

// The rotor-side torque each stepper's joint needs at each time of `times` (the steps' starts) to
// follow its drive's plan exactly: the steppers' joints on their plans (MotionProfile, fed each
// step's ctrl as the drive is), every other dof held at `start`'s pose, through mj_inverse;
// qfrc_inverse/gear. Empty for a stepper that is not on a hinge or slide joint.
// Whether `joint` is in a fixed tendon with a spring (a compliant belt, models/belt_axis.xml): the
// far end's dofs are not on any plan, and held at the start pose they would stretch the belt by
// the whole move, so such a joint's demand is the simulated motor torque, as a tendon's.
bool WindsSpring(const mjModel* m, int joint) {
  for (int t = 0; t < m->ntendon; ++t) {
    if (!(m->tendon_stiffness[t] > 0)) continue;
    for (int w = m->tendon_adr[t]; w < m->tendon_adr[t] + m->tendon_num[t]; ++w) {
      if (m->wrap_type[w] == mjWRAP_JOINT && m->wrap_objid[w] == joint) return true;
    }
  }
  return false;
}

std::vector<std::vector<double>> InverseDynamicsDemand(const mjModel* m,
                                                       const std::vector<StepperActuator>& steppers,
                                                       const RunOptions& run, const mjData* start,
                                                       const std::vector<double>& times) {
  const double h = m->opt.timestep;
  DataPtr data(mj_makeData(m));
  mjData* d = data.get();
  struct Axis {
    int dof = -1, qpos = -1;
    double gear = 1;
    double damping = 0;  // N·m·s/rad, the actuator's own (rotor side): in the bench's curve
    MotionProfile profile;
    MotionProfile::State plan;
    std::optional<CommandProfile> ctrl;  // the run's, or hold the start angle
    double start = 0;                    // rad, rotor
    double omega = 0;                    // rad/s, the plan's speed at this sample
  };
  std::vector<Axis> axes(steppers.size());
  std::vector<std::vector<double>> out(steppers.size());
  for (size_t i = 0; i < steppers.size(); ++i) {
    const StepperActuator& s = steppers[i];
    const int type = m->actuator_trntype[s.actuator];
    const int joint = m->actuator_trnid[2 * s.actuator];
    if (type != mjTRN_JOINT ||
        (m->jnt_type[joint] != mjJNT_HINGE && m->jnt_type[joint] != mjJNT_SLIDE) ||
        WindsSpring(m, joint)) {
      continue;
    }
    Axis& a = axes[i];
    a.dof = m->jnt_dofadr[joint];
    a.qpos = m->jnt_qposadr[joint];
    a.gear = Gear(m, s);
    a.damping = m->actuator_damping[s.actuator];
    a.profile = s.config.profile;
    a.start = start->actuator_length[s.outadr];
    a.plan = MotionProfile::Rest(start->time, a.start);
    if (const auto it = run.ctrl.find(s.name); it != run.ctrl.end()) {
      a.ctrl = CommandProfile::Parse(it->second);
    }
    out[i].reserve(times.size());
  }
  for (double t : times) {
    ThrowIfCancelled();  // (cancel.h)
    mju_copy(d->qpos, start->qpos, m->nq);
    mju_zero(d->qvel, m->nv);
    mju_zero(d->qacc, m->nv);
    for (Axis& a : axes) {
      if (a.dof < 0) continue;
      const double target =
          a.ctrl ? a.ctrl->ControlForStep(t - times.front(), h, InputMode::kPosition, 0) : a.start;
      CommandSample c{.theta = target};
      if (a.profile.kind != ProfileKind::kNone) {
        a.profile.Update(&a.plan, t, t + h, target);
        c = a.profile.Evaluate(a.plan, t);
      }
      // actuator_length = gear·q on a joint transmission (the start pose's own q is gear⁻¹ of it)
      d->qpos[a.qpos] = start->qpos[a.qpos] + (c.theta - a.start) / a.gear;
      d->qvel[a.dof] = c.omega / a.gear;
      a.omega = c.omega;
      d->qacc[a.dof] = c.accel / a.gear;
    }
    mj_inverse(m, d);
    for (size_t i = 0; i < axes.size(); ++i) {
      // The actuator's damping (in qfrc_passive, so in qfrc_inverse) is also on the bench, whose
      // curve is the torque left beyond it: it is counted there, not here.
      const Axis& a = axes[i];
      if (a.dof >= 0) out[i].push_back(d->qfrc_inverse[a.dof] / a.gear - a.damping * a.omega);
    }
  }
  return out;
}

}  // namespace

SizeResult Size(const SizeOptions& o, std::ostream& progress) {
  RequireInRange("--dwell", Range("dwell"), o.dwell);
  RequireInRange("--cycles", Range("cycles"), o.cycles);
  RequireInRange("--pullout-points", Range("pullout-points"), o.pullout_points);
  if (o.moves.empty()) {
    throw std::invalid_argument(
        "size: no move: give --move ACTUATOR=P1,P2,…UNIT for at least one stepper, e.g. "
        "--move j2=30,-10deg");
  }

  // 1. The model as the user runs it: its steppers, gears, transmissions and start pose; its
  // timestep judged once, here, before any bench or cycle runs.
  const ToolJudgesTimestep judged;
  const StepperModel user = LoadStepperModel(o.run.model, o.run.overrides);
  const mjModel* m0 = user.model.get();
  DataPtr data0(mj_makeData(m0));
  int key = -1;
  if (!o.run.keyframe.empty()) {
    key = mj_name2id(m0, mjOBJ_KEY, o.run.keyframe.c_str());
    if (key < 0) {
      throw std::invalid_argument(fmt::format("--keyframe {}: {} has no keyframe of that name",
                                              o.run.keyframe, o.run.model));
    }
    mj_resetDataKeyframe(m0, data0.get(), key);
  }
  ApplyTimestepRule(user, key, o.run.model, o.run.allow_coarse, progress);
  mj_forward(m0, data0.get());

  const size_t n = user.steppers.size();
  if (!o.out.empty()) {  // every file the sizing will write, before the work, each once
    std::vector<std::pair<std::string, std::string>> files = {{"--out", o.out + ".csv"}};
    if (!o.run.log.empty()) files.emplace_back("--log", o.run.log);
    if (!o.run.render.video.empty()) files.emplace_back("--render", o.run.render.video);
    for (const StepperActuator& s : user.steppers) {
      for (const std::string& file : SizeJointOutputs(o.out, s.name)) {
        for (const auto& [option, other] : files) {
          if (other == file) {
            throw std::invalid_argument(fmt::format(
                "--out {}: '{}' writes {}, which {} writes too{}", o.out, s.name, file, option,
                option == "--out" ? " (actuator names that differ only in characters a file "
                                    "name cannot hold)"
                                  : ""));
          }
        }
        files.emplace_back("--out", file);
      }
    }
    CheckDistinctOutputs(files);
    for (const auto& [option, file] : files) CheckOutputPath(file);
  }
  std::vector<std::vector<double>> waypoints(n);  // per stepper: joint values, empty: holds
  size_t poses = 0;
  std::vector<ConfigOverride> overrides = o.run.overrides;
  for (const auto& [name, text] : o.moves) {
    const StepperActuator& s = FindStepper(user, name, "--move", text);
    const size_t i = &s - user.steppers.data();
    waypoints[i] =
        JointValues(m0, s, "--move " + name + "=", text, JointQuantity::kPosition, false);
    if (poses != 0 && waypoints[i].size() != poses) {
      throw std::invalid_argument(fmt::format(
          "--move {}={}: {} waypoints, but the other joints have {}: one value per pose", name,
          text, waypoints[i].size(), poses));
    }
    poses = waypoints[i].size();
  }
  // Speeds and accelerations become the drive's profile (rotor side: gear × the joint's).
  for (const auto* rates : {&o.speeds, &o.accelerations}) {
    const bool speed = rates == &o.speeds;
    const char* option = speed ? "--speed" : "--accel";
    for (const auto& [name, text] : *rates) {
      const StepperActuator& s = FindStepper(user, name, option, text);
      const double value =
          JointValues(m0, s, fmt::format("{} {}=", option, name), text,
                      speed ? JointQuantity::kSpeed : JointQuantity::kAcceleration, true)[0];
      for (const StepperActuator& other : user.steppers) {
        if (&other != &s &&
            m0->actuator_plugin[other.actuator] == m0->actuator_plugin[s.actuator]) {
          throw std::invalid_argument(fmt::format(
              "{} {}={}: '{}' shares its plugin <instance> with '{}', so its profile would change "
              "both; give each its own <instance>",
              option, name, text, name, other.name));
        }
      }
      overrides.push_back({name, speed ? "profile_speed" : "profile_accel",
                           fmt::format("{:.17g}", std::abs(Gear(m0, s)) * value)});
    }
  }
  for (size_t i = 0; i < n; ++i) {
    if (waypoints[i].empty()) continue;
    const StepperActuator& s = user.steppers[i];
    if (s.config.input != InputMode::kPosition) {
      throw std::invalid_argument(fmt::format(
          "--move {}: size moves a joint through its drive's motion profile, which needs input = "
          "position; set {}.input=position",
          s.name, s.name));
    }
    if (s.config.profile.kind == ProfileKind::kNone) {
      if (!o.speeds.contains(s.name) || !o.accelerations.contains(s.name)) {
        throw std::invalid_argument(fmt::format(
            "--move {}: its drive has no motion profile (profile = none): give --speed {}=… and "
            "--accel {}=…, or set {}.profile=trapezoid",
            s.name, s.name, s.name, s.name));
      }
      overrides.push_back({s.name, "profile", "trapezoid"});
    }
  }

  // 2. The model with the move's profiles; the poses' times from each drive's own plan.
  const StepperModel sm = LoadStepperModel(o.run.model, overrides);
  for (const auto& [body, mass] : o.run.masses) SetBodyMass(sm.model.get(), body, mass);
  const mjModel* m = sm.model.get();
  std::vector<std::vector<double>> targets(n);  // rotor side, rad: start, the poses, start
  double start_time = 0;                        // s: no drive moves before its profile_start
  for (size_t i = 0; i < n; ++i) {
    if (waypoints[i].empty()) continue;
    const StepperActuator& s = sm.steppers[i];
    const double start = data0->actuator_length[s.outadr];
    targets[i].push_back(start);
    for (double q : waypoints[i]) {
      targets[i].push_back(Gear(m, s) * q);
      if (!(std::abs(targets[i].back()) <= kMaxProfileAngle)) {
        throw std::invalid_argument(fmt::format(
            "--move {}={}: {:g} (joint) is {:g} rad at the rotor (gear {:g}), beyond ±{:g} rad",
            s.name, o.moves.at(s.name), q, targets[i].back(), Gear(m, s), kMaxProfileAngle));
      }
    }
    targets[i].push_back(start);
    // profile_start is a time of the simulation's clock, which a keyframe may start anywhere.
    start_time = std::max(start_time, s.config.profile.start_time - data0->time);
  }
  SizeResult result;
  result.cycles = o.cycles;
  double t = start_time;
  for (size_t k = 0; k + 1 < poses + 2; ++k) {
    double longest = 0;  // s
    for (size_t i = 0; i < n; ++i) {
      if (targets[i].empty()) continue;
      MotionProfile profile = sm.steppers[i].config.profile;
      profile.start_time = 0;
      MotionProfile::State plan = MotionProfile::Rest(0, 0);
      profile.Update(&plan, 0, m->opt.timestep, targets[i][k + 1] - targets[i][k]);
      longest = std::max(longest, plan.t_end - plan.t0);
    }
    result.pose_times.push_back(t);
    t += std::max(longest + o.dwell, m->opt.timestep);  // a still leg lasts at least a step
  }
  result.cycle_time = t;
  if (!(result.cycle_time / m->opt.timestep <= kMaxSizeSteps)) {
    throw std::invalid_argument(fmt::format(
        "size: the cycle lasts {:g} s, {:g} steps of the model's {:g} s, beyond the {:g} a sizing "
        "keeps: shorten --dwell, raise --speed / --accel or take fewer poses in --move",
        result.cycle_time, result.cycle_time / m->opt.timestep, m->opt.timestep, kMaxSizeSteps));
  }

  // 3. One cycle at the model's own timestep.
  RunOptions run = o.run;
  run.overrides = overrides;
  run.keep_traces = true;
  run.duration = result.cycle_time;
  for (size_t i = 0; i < n; ++i) {
    if (targets[i].empty()) continue;
    // The first pose from t = 0 (no drive moves before its profile_start), each next one from
    // its time.
    std::string text = fmt::format("targets({:.17g}rad", targets[i][1]);
    for (size_t k = 2; k < targets[i].size(); ++k) {
      text += fmt::format(", {:.17g}rad@{:.17g}s", targets[i][k], result.pose_times[k - 1]);
    }
    run.ctrl[sm.steppers[i].name] = text + ")";
  }
  if (o.run.progress) {
    fmt::print(progress, "size: one cycle of {:.3f} s ({} poses) at the model's timestep {:g} s\n",
               result.cycle_time, poses, m->opt.timestep);
  }
  // Estimated before it runs (stepper_model.h), the cycle alone (the benches are one rotor each).
  const double cycle_steps = result.cycle_time / m->opt.timestep;
  SayEstimate(progress, o.run.progress,
              fmt::format("size: the cycle of {} poses, {:.0f} steps", poses, cycle_steps),
              cycle_steps * WallTimePerStep(m, data0.get()));
  if (run.render.enabled()) {
    const double frames = std::floor(run.duration * run.render.fps / run.render.playback) + 1;
    RequireInRange("the cycle · --fps / --playback", Range("frames"), frames,
                   fmt::format("{:g} s · {:g} /s / {:g} = {:g} frames", run.duration,
                               run.render.fps, run.render.playback, frames));
  }
  run.judge_timestep = false;  // judged in 1.
  result.run = Run(run, progress);

  // 4. Each joint: its demand, its motor's curve on the bench, the margin, the heat.
  const double h = m->opt.timestep;
  const long window = std::max(1L, std::lround(kDemandWindow / h));
  const std::vector<std::vector<double>> demand =
      InverseDynamicsDemand(m, sm.steppers, run, data0.get(), result.run.traces[0].time);
  for (size_t i = 0; i < n; ++i) {
    const StepperActuator& s = sm.steppers[i];
    const StepperTrace& trace = result.run.traces[i];
    SizeJoint j;
    j.name = s.name;
    j.motor = ConfigText(m, s, "motor");
    if (j.motor.empty()) j.motor = "tsui2009";
    j.drive = ControllerName(s.config.controller);
    j.gear = Gear(m, s);
    j.rad_per_metre = RadPerMetre(m, s).value_or(0.0);
    std::vector<double> omega(trace.time.size());
    for (size_t k = 0; k < omega.size(); ++k) {
      omega[k] = trace.omega_cmd[k] + trace.velocity_error[k];
    }
    j.time = trace.time;
    j.motor_speed = MovingAverage(omega, window);
    j.motor_torque = MovingAverage(trace.torque, window);
    j.inverse_dynamics = !demand[i].empty();
    j.speed = j.inverse_dynamics ? trace.omega_cmd : j.motor_speed;
    j.torque = j.inverse_dynamics ? demand[i] : j.motor_torque;
    for (size_t k = 0; k < j.time.size(); ++k) {
      j.peak_speed = std::max(j.peak_speed, std::abs(j.speed[k]));
      j.peak_torque = std::max(j.peak_torque, std::abs(j.torque[k]));
    }
    j.lost_steps = result.run.steppers[i].lost_steps;

    // The bench: a rotor of the joint's rotor-side inertia at the start pose (qpos0 or the
    // keyframe's), the other joints held.
    j.bench_inertia = ReflectedInertia(m, s.actuator, data0.get());  // at the start pose
    if (!(j.bench_inertia > 0) || !std::isfinite(j.bench_inertia)) {
      throw std::invalid_argument(fmt::format(
          "size: stepper '{}' moves no inertia at qpos0 (its rotor-side inertia is {:g} kg·m²): "
          "give its actuator an armature, or its transmission a dof",
          s.name, j.bench_inertia));
    }
    PullOutOptions po;
    po.model = fmt::format("size_bench_{}.xml", FilePart(s.name));
    po.model_text = BenchModel(m, s, j.bench_inertia);
    po.actuator = s.name;
    const double top = 1.15 * std::max(j.peak_speed, 1.0);  // rad/s
    for (int k = 0; k < o.pullout_points; ++k)
      po.speeds.push_back(top * k / (o.pullout_points - 1));
    const Drive drive(s.config);
    po.max_torque = 1.5 * s.config.motor.torque_constant * drive.RestCurrentMagnitude();
    if (!(po.max_torque > 0)) po.max_torque = 1.5 * std::max(j.peak_torque, 1e-3);
    po.rate = po.max_torque / 2.0;  // N·m/s: 2 s from no load to max_torque
    // To each speed at the move's acceleration, or slower where the bench's inertia would need
    // more than a quarter of the holding torque for it (the curve is the motor's at speed).
    po.acceleration = std::min(
        s.config.profile.kind != ProfileKind::kNone ? s.config.profile.max_accel : po.acceleration,
        0.25 * po.max_torque / 1.5 / j.bench_inertia);
    po.threads = o.threads;
    po.judge_timestep = false;  // the sized model's step, judged on the model by Size
    po.progress = o.run.progress;
    if (o.run.progress) fmt::print(progress, "size: pull-out of '{}' on its bench\n", s.name);
    j.pullout = PullOut(po, progress);
    for (PullOutPoint& p : j.pullout) {  // the bench is a bare rotor: the joint's carriage
      if (j.rad_per_metre == 0) continue;
      p.carriage_speed = p.speed / j.rad_per_metre;
      p.force = p.torque * std::abs(j.rad_per_metre);
    }

    j.margin = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < j.time.size(); ++k) {
      const double pullout = PullOutAt(j.pullout, j.speed[k]);
      const double margin = Margin(j.torque[k], pullout);
      if (margin < j.margin) {
        j.margin = margin;
        j.worst_time = j.time[k];
        j.worst_speed = j.speed[k];
        j.worst_torque = j.torque[k];
        j.worst_pullout = pullout;
      }
    }

    if (s.config.heat && trace.time.size() >= 2) {
      const HeatParams& heat = *s.config.heat;
      j.heat = true;
      j.insulation_limit = heat.insulation_limit;
      double resistance_time = 0;  // Ω·s, ∫R dt over the steps the energy covers
      for (size_t k = 0; k + 1 < trace.time.size(); ++k) resistance_time += trace.resistance[k] * h;
      j.current_squared =
          (trace.energy_copper.back() - trace.energy_copper.front()) / resistance_time;
      j.temperature_cycle = trace.winding_temperature.back();
      std::array<double, 2> rise = {trace.winding_temperature.back() - heat.ambient_temperature,
                                    trace.housing_temperature.back() - heat.ambient_temperature};
      if (o.cycles > 1) {
        const ThermalNetwork network(heat.network);
        rise = RiseUnderCurrent(network, heat, s.config.motor.resistance, j.current_squared, rise,
                                result.cycle_time * (o.cycles - 1), 8 * (o.cycles - 1));
      }
      j.temperature = heat.ambient_temperature + rise[0];
      j.temperature_steady =
          SteadyWindingTemperature(heat, s.config.motor.resistance, j.current_squared);
    }
    result.joints.push_back(std::move(j));
  }
  return result;
}

std::vector<std::string> SizeJointOutputs(const std::string& prefix, const std::string& joint) {
  const std::string base = prefix + "_" + FilePart(joint);
  return {base + "_demand.csv", base + "_pullout.csv", base + ".png"};
}

void WriteSizeCsvs(const std::string& prefix, const SizeResult& r) {
  {
    OutputFile out(prefix + ".csv");
    std::string text =
        "joint,motor,drive,gear[rad/unit],bench_inertia[kg·m²],peak_speed[rad/s],"
        "peak_torque[N·m],worst_time[s],worst_speed[rad/s],worst_torque[N·m],"
        "worst_pullout[N·m],margin[1],lost_steps[full steps],current_squared[A²],"
        "winding_temperature_cycle[°C],winding_temperature_cycles[°C],"
        "winding_temperature_steady[°C],insulation_limit[°C],cycles[1],cycle_time[s],"
        "rad_per_metre[rad/m]\n";
    for (const SizeJoint& j : r.joints) {
      text += fmt::format(
          "{},{},{},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},"
          "{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{},{:.17g},{:.17g}\n",
          CsvText(j.name), CsvText(j.motor), CsvText(j.drive), j.gear, j.bench_inertia,
          j.peak_speed, j.peak_torque, j.worst_time, j.worst_speed, j.worst_torque, j.worst_pullout,
          j.margin, j.lost_steps + 0.0, j.current_squared, j.heat ? j.temperature_cycle : NAN,
          j.heat ? j.temperature : NAN, j.heat ? j.temperature_steady : NAN,
          j.heat ? j.insulation_limit : NAN, r.cycles, r.cycle_time,
          j.rad_per_metre != 0 ? j.rad_per_metre : NAN);
    }
    out.Write(text.data(), text.size());
    out.Commit();
  }
  for (const SizeJoint& j : r.joints) {
    const std::vector<std::string> files = SizeJointOutputs(prefix, j.name);
    std::vector<std::string> header = {"time[s]",          "speed[rad/s]", "torque[N·m]",
                                       "pullout[N·m]",     "margin[1]",    "motor_speed[rad/s]",
                                       "motor_torque[N·m]"};
    const double k_rpm = j.rad_per_metre;  // rotor rad per m of the carriage; 0: rotary
    if (k_rpm != 0) {
      header.insert(header.end(), {"carriage_speed[mm/s]", "force[N]", "pullout_force[N]"});
    }
    CsvWriter demand(files[0], header);
    for (size_t k = 0; k < j.time.size(); ++k) {
      const double pullout = PullOutAt(j.pullout, j.speed[k]);
      const double row[] = {j.time[k],
                            j.speed[k],
                            j.torque[k],
                            pullout,
                            Margin(j.torque[k], pullout),
                            j.motor_speed[k],
                            j.motor_torque[k],
                            k_rpm != 0 ? 1e3 * j.speed[k] / k_rpm : 0.0,
                            j.torque[k] * std::abs(k_rpm),
                            pullout * std::abs(k_rpm)};
      demand.Row(std::span<const double>(row, k_rpm != 0 ? 10 : 7));
    }
    demand.Commit();
    WritePullOutCsv(files[1], j.pullout);
  }
}

void PrintSizeTable(const SizeResult& r, std::ostream& out) {
  fmt::print(out,
             "size: a cycle of {:.3f} s; rotor-side torques and speeds; the demand τ is the torque "
             "the joint needs to follow its drive's plan (inverse dynamics); margin = 1 − |τ|/T_po "
             "at the worst point of the move; lost steps of the simulated cycle; winding after 1 "
             "and {} cycle(s), and in continuous duty\n",
             r.cycle_time, r.cycles);
  fmt::print(out, "  {:<10} {:<16} {:>7} {:>9} {:>8} | {:>9} {:>8} {:>8} {:>7} | {:>5} | {}\n",
             "joint", "motor", "gear", "top r/min", "peak N·m", "at r/min", "τ N·m", "T_po N·m",
             "margin", "lost", "winding °C (1, N, continuous / limit)");
  for (const SizeJoint& j : r.joints) {
    const std::string heat =
        j.heat
            ? fmt::format(
                  "{:.1f}, {:.1f}, {:.1f} / {:g}{}", j.temperature_cycle, j.temperature,
                  j.temperature_steady, j.insulation_limit,
                  std::max(j.temperature, j.temperature_steady) > j.insulation_limit ? " OVER" : "")
            : std::string("no heat model");
    fmt::print(out,
               "  {:<10} {:<16} {:>7.4g} {:>9.1f} {:>8.4f} | {:>9.1f} {:>8.4f} {:>8.4f} {:>6.1f}% "
               "| {:>+5.0f} | {}\n",
               j.name, j.motor, j.gear, RadPerSecToRpm(j.peak_speed), j.peak_torque,
               RadPerSecToRpm(std::abs(j.worst_speed)), std::abs(j.worst_torque), j.worst_pullout,
               100 * j.margin, j.lost_steps, heat);
    if (j.rad_per_metre != 0) {                    // a linear axis: the same at its carriage
      const double k = std::abs(j.rad_per_metre);  // rotor rad per m
      fmt::print(out,
                 "  {:<10} at the carriage: top {:.1f} mm/s, peak {:.1f} N; at the worst point "
                 "{:.1f} mm/s, {:.1f} N of {:.1f} N\n",
                 "", 1e3 * j.peak_speed / k, j.peak_torque * k, 1e3 * std::abs(j.worst_speed) / k,
                 std::abs(j.worst_torque) * k, j.worst_pullout * k);
    }
  }
}

}  // namespace mjstepper::tools
