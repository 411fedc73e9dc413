// ns per mj_step: models/tsui_rigid.xml (mjstepper.stepper, current microstepping at 20 kHz)
// beside models/tsui_rigid_dcmotor.xml (the same load on MuJoCo's dcmotor, inductance on), in one
// run, same timestep. After a warm-up, 7 interleaved rounds of 100000 steps each; the best round of
// each model is kept (the least disturbed). Usage: bench_step [steps_per_round].
// For instruction counts, which this VM's drifting clock does not disturb:
//   valgrind --tool=callgrind --collect-atstart=no --toggle-collect='*Round*'
//       build/bench_step 20000 stepper      (or dcmotor): Ir / (8·20000) per step.
#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

namespace {

struct Stepping {
  mjModel* model = nullptr;
  mjData* data = nullptr;
};

// Loads `path`; a non-empty `configs` is inserted into its stepper's <config> list (e.g. the 1 MHz
// clock), through a VFS under the file's own name.
Stepping Load(const std::string& path, double ctrl, const std::string& configs = "") {
  char error[1024] = "";
  std::ifstream file(path);
  std::stringstream text;
  text << file.rdbuf();
  std::string xml = text.str();
  if (!configs.empty()) xml.insert(xml.find("<config key=\"motor\""), configs);
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
  return {m, d};
}

// ns per step over `steps` steps.
[[gnu::noinline]] double Round(const Stepping& s, long steps) {
  const auto start = std::chrono::steady_clock::now();
  for (long k = 0; k < steps; ++k) mj_step(s.model, s.data);
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
  // "stepper", "stepper1mhz" or "dcmotor": that one alone (for callgrind)
  const std::string only = argc > 2 ? argv[2] : "";
  if (only == "stepper" || only == "stepper1mhz" || only == "dcmotor") {
    const Stepping s = only == "stepper"       ? Load(dir + "tsui_rigid.xml", 10.472)
                       : only == "stepper1mhz" ? Load(dir + "tsui_rigid.xml", 10.472, fast)
                                               : Load(dir + "tsui_rigid_dcmotor.xml", 3.0);
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
  Round(stepper, steps / 10);  // warm-up, and leave the start transient
  Round(stepper_fast, steps / 10);
  Round(dcmotor, steps / 10);
  // Rounds interleaved, the best of each kept: this VM's speed drifts by tens of percent over
  // seconds, and interleaving exposes every model to the same drift.
  double best_stepper = 1e300, best_fast = 1e300, best_dcmotor = 1e300;
  for (int round = 0; round < 7; ++round) {
    best_stepper = std::min(best_stepper, Round(stepper, steps));
    best_fast = std::min(best_fast, Round(stepper_fast, steps / 10));
    best_dcmotor = std::min(best_dcmotor, Round(dcmotor, steps));
  }
  fmt::print("MuJoCo {}\n", mj_versionString());
  fmt::print("tsui_rigid.xml, 20 kHz  (mjstepper.stepper): {:8.1f} ns/step\n", best_stepper);
  fmt::print("tsui_rigid.xml, 1 MHz   (mjstepper.stepper): {:8.1f} ns/step\n", best_fast);
  fmt::print("tsui_rigid_dcmotor.xml  (built-in dcmotor):  {:8.1f} ns/step\n", best_dcmotor);
  fmt::print("ratio 20 kHz / dcmotor: {:.2f}; 1 MHz / 20 kHz: {:.2f}\n",
             best_stepper / best_dcmotor, best_fast / best_stepper);
  for (const Stepping& s : {stepper, stepper_fast, dcmotor}) {
    mj_deleteData(s.data);
    mj_deleteModel(s.model);
  }
  return 0;
}
