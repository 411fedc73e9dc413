// ns per mj_step: models/tsui_rigid.xml (mjstepper.stepper, current microstepping at 20 kHz)
// beside models/tsui_rigid_dcmotor.xml (the same load on MuJoCo's dcmotor, inductance on), in one
// run, same timestep. Each model: warm-up, then the best of 5 rounds of 100000 steps (minimum:
// the least disturbed by the other core's load). Usage: bench_step [steps_per_round].
#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace {

double NsPerStep(const std::string& path, double ctrl, long steps) {
  char error[1024] = "";
  mjModel* m = mj_loadXML(path.c_str(), nullptr, error, sizeof(error));
  if (m == nullptr) {
    fmt::print(stderr, "{}: {}\n", path, error);
    std::exit(1);
  }
  mjData* d = mj_makeData(m);
  d->ctrl[0] = ctrl;
  for (long k = 0; k < steps / 10; ++k) mj_step(m, d);  // warm-up, and leave the start transient
  double best = 1e300;
  for (int round = 0; round < 5; ++round) {
    const auto start = std::chrono::steady_clock::now();
    for (long k = 0; k < steps; ++k) mj_step(m, d);
    const double ns =
        std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count();
    best = std::min(best, ns / steps);
  }
  mj_deleteData(d);
  mj_deleteModel(m);
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  const long steps = argc > 1 ? std::atol(argv[1]) : 100000;
  mj_loadPluginLibrary(MJSTEPPER_PLUGIN_PATH);
  const std::string dir = MJSTEPPER_SOURCE_DIR "/models/";
  // 100 r/min = 10.47 rad/s for the stepper (velocity input); 3 V on the DC motor.
  const double stepper = NsPerStep(dir + "tsui_rigid.xml", 10.472, steps);
  const double dcmotor = NsPerStep(dir + "tsui_rigid_dcmotor.xml", 3.0, steps);
  fmt::print("MuJoCo {}\n", mj_versionString());
  fmt::print("tsui_rigid.xml          (mjstepper.stepper): {:8.1f} ns/step\n", stepper);
  fmt::print("tsui_rigid_dcmotor.xml  (built-in dcmotor):  {:8.1f} ns/step\n", dcmotor);
  fmt::print("ratio stepper / dcmotor: {:.2f}\n", stepper / dcmotor);
  return 0;
}
