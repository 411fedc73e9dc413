// ns per mj_step: models/tsui_rigid.xml (mjstepper.stepper, current microstepping at 20 kHz, and
// the same drive ticking at 1 MHz) beside models/tsui_rigid_dcmotor.xml (the same load on MuJoCo's
// dcmotor, inductance on, on a constant 3 V and on 3 V ± 5 %), in one run, same timestep. After a
// warm-up, 7 interleaved rounds of 100000 steps each; the best round of each model is kept (the
// least disturbed). Usage: bench_step [steps_per_round [MODE [TIMESTEP]]] (MODE below).
// For instruction counts, which this VM's drifting clock does not disturb:
//   valgrind --tool=callgrind --collect-atstart=no --toggle-collect='*Round*'
//       build/bench_step 20000 stepper    (or stepper1mhz, dcmotor, dcmotor_ripple):
//   Ir / (8·20000) per step. The 6-DOF arm: bench_step 1000 arm6 [TIMESTEP] (or arm6_ideal,
//   arm6_servo, arm6_substepped; parol6, parol6_servo, parol6_substepped,
//   parol6_substepped_averaged);
//   bench/arm_cost.sh runs them.
#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

namespace {

struct Stepping {
  mjModel* model = nullptr;
  mjData* data = nullptr;
  std::vector<double> ctrl_cycle;  // if not empty: ctrl[0] steps through it, one value per step
};

// Loads `path`; a non-empty `configs` is inserted into each stepper's <config> list (e.g. the 1 MHz
// clock), a non-empty `timestep` (s) replaces the model's 1 ms one, through a VFS under the file's
// own name.
Stepping Load(const std::string& path, double ctrl, const std::string& configs = "",
              const std::string& timestep = "") {
  char error[1024] = "";
  std::ifstream file(path);
  std::stringstream text;
  text << file.rdbuf();
  std::string xml = text.str();
  // Into every stepper of the model (the arm's six; the rotor's one).
  const std::string motor_key = R"(<config key="motor")";
  for (size_t at = xml.find(motor_key); !configs.empty() && at != std::string::npos;
       at = xml.find(motor_key, at + configs.size() + motor_key.size())) {
    xml.insert(at, configs);
  }
  if (!timestep.empty()) {
    const std::string own = R"(<option timestep=")";
    const size_t at = xml.find(own);
    if (at == std::string::npos) {
      fmt::print(stderr, "{}: no {} to replace\n", path, own);
      std::exit(1);
    }
    const size_t begin = at + own.size();
    xml.replace(begin, xml.find('"', begin) - begin, timestep);
  }
  // Another drive (issue 17's chopper, SpreadCycle, StealthChop) in place of the PI loop, at the
  // same peak current (1.9 A): the model's own drive key removed, as MJCF keeps the first.
  if (configs.find(R"(key="drive")") != std::string::npos) {
    const std::string pi = R"(<config key="drive" value="current_microstep"/>)";
    for (size_t at = xml.find(pi); at != std::string::npos; at = xml.find(pi))
      xml.erase(at, pi.size());
  }
  mjVFS vfs;
  mj_defaultVFS(&vfs);
  mj_addBufferVFS(&vfs, "model.xml", xml.data(), static_cast<int>(xml.size()));
  mjModel* m = mj_loadXML("model.xml", &vfs, error, sizeof(error));
  mj_deleteVFS(&vfs);
  if (m == nullptr) {
    fmt::print(stderr, "{}: {}\n", path, error);
    std::exit(1);
  }
  mjData* d = mj_makeData(m);
  d->ctrl[0] = ctrl;
  return {m, d, {}};
}

// ns per step over `steps` steps.
[[gnu::noinline]] double Round(const Stepping& s, long steps) {
  const auto start = std::chrono::steady_clock::now();
  const size_t cycle = s.ctrl_cycle.size();
  for (long k = 0; k < steps; ++k) {
    if (cycle) s.data->ctrl[0] = s.ctrl_cycle[k % cycle];
    mj_step(s.model, s.data);
  }
  return std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start)
             .count() /
         steps;
}

}  // namespace

int main(int argc, char** argv) {
  const long steps = argc > 1 ? std::atol(argv[1]) : 100000;
  mj_loadPluginLibrary(MJSTEPPER_PLUGIN_PATH);
  const std::string dir = MJSTEPPER_SOURCE_DIR "/models/";
  // 100 r/min = 10.47 rad/s for the stepper (velocity input); 3 V on the DC motor.
  // The same drive with its control clock at 1 MHz (50 ticks per step) and no computation delay.
  const std::string fast =
      R"(<config key="isr_period" value="1e-6"/><config key="compute_delay" value="0"/>)";
  // The DC motor on 3 V ± 5 % at 333 Hz, the stepper's full-step rate at 100 r/min: a motion that
  // is never steady, like the stepper's, so that MuJoCo's solver works every step for both (on a
  // constant 3 V it settles, and the warm start makes most steps solver-free).
  auto rippled = [](Stepping s) {
    for (int k = 0; k < 60; ++k) {
      s.ctrl_cycle.push_back(3.0 * (1 + 0.05 * std::sin(2 * std::numbers::pi * k / 60)));
    }
    return s;
  };
  // The A4988-class chopper (30 µs off-time, mixed decay) on the same motor and load, its table
  // read every 50 µs, at the PI drive's 1.9 A peak.
  const std::string chopper =
      R"(<config key="drive" value="chopper"/><config key="decay" value="mixed"/>)"
      R"(<config key="run_current" value="1.3435"/>)";
  // SpreadCycle (TMC2209 timing: TOFF 3, TBL 2, HSTRT 5, HEND 0 at 12 MHz) on the same motor and
  // load at the same peak.
  const std::string spreadcycle =
      R"(<config key="drive" value="spreadcycle"/><config key="run_current" value="1.3435"/>)";
  // StealthChop (averaged voltage PWM, autoscale) on the same motor and load at the same peak.
  const std::string stealthchop =
      R"(<config key="drive" value="stealthchop"/><config key="run_current" value="1.3435"/>)";
  // The two chopper drives cycle-averaged (fidelity = averaged, SPEC §11, issue 30).
  const std::string averaged = R"(<config key="fidelity" value="averaged"/>)";
  // The same chopper with heat (SPEC §8): Tsui's motor has no thermal network, so one is given
  // (the qsh5718_51's, a NEMA 23 like it), which turns heat on.
  const std::string chopper_heat = chopper +
                                   R"(<config key="thermal_resistance_winding" value="1.17"/>)"
                                   R"(<config key="thermal_resistance_housing" value="3.44"/>)"
                                   R"(<config key="heat_capacity_winding" value="30"/>)"
                                   R"(<config key="heat_capacity_housing" value="483"/>)";
  // "stepper", "stepper_explicit", "stepper1mhz", "stepper_averaged" (the PI drive averaged),
  // "chopper", "chopper_heat", "spreadcycle", "chopper_averaged", "spreadcycle_averaged",
  // "stealthchop", "dcmotor" or "dcmotor_ripple":
  // that one alone (for callgrind)
  const std::string only = argc > 2 ? argv[2] : "";
  // "arm6" (models/arm6.xml, six steppers on position trapezoids), "arm6_ideal" (its drives
  // ideal current sources) or "arm6_servo" (the same arm on MuJoCo's position servos), holding the
  // standby pose from qpos0 against gravity, the plugin alone (no probe sensors, unlike `mjstepper
  // run`); an optional timestep (s) replaces their 1 ms.
  // "parol6" (models/parol6.xml, six TMC5160s in StealthChop) likewise, and "parol6_servo" (the
  // same arm on MuJoCo's position servos, its cost baseline); "_substepped" adds the
  // sub-stepped rotor (coupling = substepped), "_averaged" the averaged drives (fidelity =
  // averaged), SPEC §11: e.g. "parol6_substepped_averaged".
  const bool substepped = only.find("_substepped") != std::string::npos;
  const bool averaged_drives = only.ends_with("_averaged");
  const std::size_t name_end = only.starts_with("arm6_servo")     ? 6
                               : only.starts_with("parol6_servo") ? 8
                                                                  : 0;
  const std::string base = only.substr(0, only.find('_', name_end));
  if (base == "arm6" || base == "arm6_servo" || base == "parol6" || base == "parol6_servo") {
    const std::string file = base;
    std::string configs =
        only == "arm6_ideal" ? R"(<config key="drive" value="ideal_current"/>)" : "";
    if (substepped) configs += R"(<config key="coupling" value="substepped"/>)";
    if (averaged_drives) configs += R"(<config key="fidelity" value="averaged"/>)";
    const Stepping s = Load(dir + file + ".xml", 0.0, configs, argc > 3 ? argv[3] : "");
    double best = 1e300;
    for (int round = 0; round < 8; ++round) best = std::min(best, Round(s, steps));
    fmt::print("{} at {:g} s: {:.1f} ns/step, {:.3g} s per simulated second\n", only,
               s.model->opt.timestep, best, best * 1e-9 / s.model->opt.timestep);
    mj_deleteData(s.data);
    mj_deleteModel(s.model);
    return 0;
  }
  // The PI drive with the torque at the step's start (the coupling before issue 20).
  const std::string explicit_coupling = R"(<config key="coupling" value="explicit"/>)";
  if (only == "stepper" || only == "stepper_explicit" || only == "stepper1mhz" ||
      only == "stepper_averaged" || only == "chopper" || only == "chopper_heat" ||
      only == "spreadcycle" || only == "chopper_averaged" || only == "spreadcycle_averaged" ||
      only == "stealthchop" || only == "dcmotor" || only == "dcmotor_ripple") {
    const Stepping s =
        only == "stepper"            ? Load(dir + "tsui_rigid.xml", 10.472)
        : only == "stepper_explicit" ? Load(dir + "tsui_rigid.xml", 10.472, explicit_coupling)
        : only == "stepper1mhz"      ? Load(dir + "tsui_rigid.xml", 10.472, fast)
        : only == "stepper_averaged" ? Load(dir + "tsui_rigid.xml", 10.472, averaged)
        : only == "chopper"          ? Load(dir + "tsui_rigid.xml", 10.472, chopper)
        : only == "chopper_heat"     ? Load(dir + "tsui_rigid.xml", 10.472, chopper_heat)
        : only == "spreadcycle"      ? Load(dir + "tsui_rigid.xml", 10.472, spreadcycle)
        : only == "chopper_averaged" ? Load(dir + "tsui_rigid.xml", 10.472, chopper + averaged)
        : only == "spreadcycle_averaged"
            ? Load(dir + "tsui_rigid.xml", 10.472, spreadcycle + averaged)
        : only == "stealthchop" ? Load(dir + "tsui_rigid.xml", 10.472, stealthchop)
        : only == "dcmotor"     ? Load(dir + "tsui_rigid_dcmotor.xml", 3.0)
                                : rippled(Load(dir + "tsui_rigid_dcmotor.xml", 3.0));
    double best = 1e300;
    for (int round = 0; round < 8; ++round) best = std::min(best, Round(s, steps));
    fmt::print("{}: {:.1f} ns/step\n", only, best);
    mj_deleteData(s.data);
    mj_deleteModel(s.model);
    return 0;
  }
  const Stepping stepper = Load(dir + "tsui_rigid.xml", 10.472);
  const Stepping stepper_fast = Load(dir + "tsui_rigid.xml", 10.472, fast);
  const Stepping dcmotor = Load(dir + "tsui_rigid_dcmotor.xml", 3.0);
  const Stepping dcmotor_ripple = rippled(Load(dir + "tsui_rigid_dcmotor.xml", 3.0));
  const Stepping* all[4] = {&stepper, &stepper_fast, &dcmotor, &dcmotor_ripple};
  const long round_steps[4] = {steps, steps / 10, steps, steps};    // 1 MHz: a tenth, it is slower
  for (int i = 0; i < 4; ++i) Round(*all[i], round_steps[i] / 10);  // warm-up, past the start
  // Rounds interleaved, the best of each kept: this VM's speed drifts by tens of percent over
  // seconds, and interleaving exposes every model to the same drift.
  double best[4] = {1e300, 1e300, 1e300, 1e300};
  for (int round = 0; round < 7; ++round) {
    for (int i = 0; i < 4; ++i) best[i] = std::min(best[i], Round(*all[i], round_steps[i]));
  }
  fmt::print("MuJoCo {}\n", mj_versionString());
  fmt::print("tsui_rigid.xml, 20 kHz  (mjstepper.stepper):   {:8.1f} ns/step\n", best[0]);
  fmt::print("tsui_rigid.xml, 1 MHz   (mjstepper.stepper):   {:8.1f} ns/step\n", best[1]);
  fmt::print("tsui_rigid_dcmotor.xml  (dcmotor, 3 V):        {:8.1f} ns/step\n", best[2]);
  fmt::print("tsui_rigid_dcmotor.xml  (dcmotor, 3 V ± 5 %):  {:8.1f} ns/step\n", best[3]);
  fmt::print("ratio 20 kHz / dcmotor: {:.2f} (3 V), {:.2f} (3 V ± 5 %); 1 MHz / 20 kHz: {:.2f}\n",
             best[0] / best[2], best[0] / best[3], best[1] / best[0]);
  for (const Stepping* s : all) {
    mj_deleteData(s->data);
    mj_deleteModel(s->model);
  }
  return 0;
}
