// Soak: one model stepped for hours of simulated time under an ever-changing command, watching
// what a long run could go wrong with: memory (resident set), NaN anywhere in the state or the
// signals, phase currents beyond what the bus can drive (Vbus/R), MuJoCo's warnings, lost steps.
// Not a test (an hour of simulated time is minutes of wall time): BENCHMARKS.md has its figures.
//
//   build/soak MODEL [--hours H] [--segment S] [--seed N]
//
// Every S seconds (simulated) each stepper gets a new command drawn from a fixed pseudo-random
// sequence: velocity-input drives a speed among the low-speed resonances, mid-band speeds, stops
// and reversals (ramped at 2000 r/min/s); position-input drives a target angle within ±0.8 rad of
// the joint (rotor side: × gear), straight to the drive's own profile if it has one, else ramped.
// At each segment's end the run goes on in a copy (mj_copyData), as a user's rollout would. Exit
// status 1 if any NaN, out-of-bound current or MuJoCo warning was seen.
#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "core/signals.h"
#include "core/units.h"
#include "stepper_model.h"

namespace {

using mjstepper::RpmToRadPerSec;
using mjstepper::SignalIndex;

// A line of /proc/self/status in kB: "VmRSS:" (the resident set now) or "VmHWM:" (its peak, from
// the same counters; getrusage's ru_maxrss is kept apart and can read below VmRSS).
long StatusKb(const std::string& field) {
  std::ifstream status("/proc/self/status");
  std::string key;
  long value = 0;
  while (status >> key) {
    if (key == field) {
      status >> value;
      return value;
    }
    status.ignore(1 << 10, '\n');
  }
  return -1;
}

long ResidentKb() { return StatusKb("VmRSS:"); }
long PeakResidentKb() { return StatusKb("VmHWM:"); }

bool AllFinite(const mjtNum* values, int n) {
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(values[i])) return false;
  }
  return true;
}

struct Watch {
  double max_current = 0;  // A, max |ia|, |ib|
  double bound = 0;        // A, Vbus / R: no drive can push more through the winding at rest
  double lost_steps = 0;   // full steps, at the end
  double max_abs_lost = 0;
};

}  // namespace

int main(int argc, char** argv) {
  std::string model;
  double hours = 1.0, segment = 5.0;
  unsigned seed = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "soak: %s needs a value\n", arg.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (arg == "--hours") {
      hours = std::atof(next().c_str());
    } else if (arg == "--segment") {
      segment = std::atof(next().c_str());
    } else if (arg == "--seed") {
      seed = static_cast<unsigned>(std::atol(next().c_str()));
    } else if (model.empty() && arg[0] != '-') {
      model = arg;
    } else {
      std::fprintf(stderr, "usage: soak MODEL [--hours H] [--segment S] [--seed N]\n");
      return 2;
    }
  }
  if (model.empty() || !(hours > 0) || !(segment > 0)) {
    std::fprintf(stderr, "usage: soak MODEL [--hours H > 0] [--segment S > 0] [--seed N]\n");
    return 2;
  }

  try {
    const mjstepper::tools::StepperModel sm = mjstepper::tools::LoadStepperModel(model);
    const mjModel* m = sm.model.get();
    mjstepper::tools::DataPtr data(mj_makeData(m)), spare(mj_makeData(m));
    mjData* d = data.get();
    mj_forward(m, d);
    const int n = static_cast<int>(sm.steppers.size());
    static const int kCurrentA = SignalIndex("current_a");
    static const int kCurrentB = SignalIndex("current_b");
    static const int kLostSteps = SignalIndex("lost_steps");

    std::vector<Watch> watch(n);
    std::vector<double> target(n, 0.0), command(n, 0.0), gear(n, 1.0);
    for (int s = 0; s < n; ++s) {
      const mjstepper::DriveConfig& c = sm.steppers[s].config;
      watch[s].bound = c.bus_voltage / c.motor.resistance;
      gear[s] = mjstepper::tools::Gear(m, sm.steppers[s]);
      command[s] = target[s] = c.input == mjstepper::InputMode::kPosition
                                   ? d->actuator_length[sm.steppers[s].outadr]
                                   : 0.0;
    }
    // Speeds (r/min) around Tsui's resonances (42.5, 85, 170), mid-band, stops, both directions.
    const double speeds[] = {0, 42.5, -45, 85, -90, 170, -167.5, 300, -600, 0, 1000, -120};
    std::mt19937 random(seed);
    const double h = m->opt.timestep;
    const double accel = RpmToRadPerSec(2000);  // rad/s², the ramp to each new speed
    const double slew = 20.0;                   // rad/s, ramped angle targets without a profile
    const long steps = std::lround(hours * 3600 / h);
    const long per_segment = std::max(1L, std::lround(segment / h));

    long nan_steps = 0, warnings = 0, copies = 0;
    long rss_first_minute = -1;
    const long rss_start = ResidentKb();
    const auto start = std::chrono::steady_clock::now();
    auto last_report = start;
    for (long k = 0; k < steps; ++k) {
      if (k % per_segment == 0) {
        if (k > 0) {  // go on in a copy of the state
          mj_copyData(spare.get(), m, d);
          std::swap(data, spare);
          d = data.get();
          ++copies;
        }
        for (int s = 0; s < n; ++s) {
          if (sm.steppers[s].config.input == mjstepper::InputMode::kVelocity) {
            target[s] = RpmToRadPerSec(speeds[random() % std::size(speeds)]);
          } else {
            const double joint = std::uniform_real_distribution<double>(-0.8, 0.8)(random);
            target[s] = gear[s] * joint;  // rotor side
          }
        }
      }
      for (int s = 0; s < n; ++s) {
        const mjstepper::DriveConfig& c = sm.steppers[s].config;
        if (c.input == mjstepper::InputMode::kPosition &&
            c.profile.kind != mjstepper::ProfileKind::kNone) {
          command[s] = target[s];  // the drive plans its own move
        } else {
          const double rate = c.input == mjstepper::InputMode::kVelocity ? accel : slew;
          command[s] += std::clamp(target[s] - command[s], -rate * h, rate * h);
        }
        d->ctrl[sm.steppers[s].ctrladr] = command[s];
      }
      const double t = d->time;
      mj_step(m, d);
      if (const std::string unstable = mjstepper::tools::InstabilityMessage(d, t);
          !unstable.empty()) {
        throw std::runtime_error(unstable);
      }
      if (!AllFinite(d->qpos, m->nq) || !AllFinite(d->qvel, m->nv) ||
          !AllFinite(d->sensordata, m->nsensordata)) {
        ++nan_steps;
      }
      for (int s = 0; s < n; ++s) {
        const double* signals = d->sensordata + sm.steppers[s].sensor_adr;
        watch[s].max_current = std::max(
            {watch[s].max_current, std::abs(signals[kCurrentA]), std::abs(signals[kCurrentB])});
        watch[s].lost_steps = signals[kLostSteps];
        watch[s].max_abs_lost = std::max(watch[s].max_abs_lost, std::abs(signals[kLostSteps]));
      }
      const auto now = std::chrono::steady_clock::now();
      if (rss_first_minute < 0 && (k + 1) * h >= 60) rss_first_minute = ResidentKb();
      if (now - last_report > std::chrono::seconds(10)) {
        last_report = now;
        std::fprintf(stderr, "\r  soak: %5.1f %% (%.0f / %.0f s simulated), RSS %ld kB",
                     100.0 * (k + 1) / steps, (k + 1) * h, hours * 3600, ResidentKb());
      }
    }
    for (int w = 0; w < mjNWARNING; ++w) warnings += d->warning[w].number;
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::fprintf(stderr, "\n");

    bool sound = nan_steps == 0 && warnings == 0;
    fmt::print(
        "soak {}: {:.3f} h simulated ({} steps of {:g} s) in {:.1f} s wall ({:.0f} ns/step), "
        "{} copies, seed {}\n",
        model, steps * h / 3600, steps, h, wall, 1e9 * wall / steps, copies, seed);
    fmt::print(
        "  resident set: {} kB at start, {} kB after 1 min simulated, {} kB at the end; "
        "peak {} kB\n",
        rss_start, rss_first_minute, ResidentKb(), PeakResidentKb());
    fmt::print("  steps with a NaN in qpos, qvel or sensordata: {}; MuJoCo warnings: {}\n",
               nan_steps, warnings);
    for (int s = 0; s < n; ++s) {
      const bool within = watch[s].max_current <= watch[s].bound;
      sound &= within;
      fmt::print(
          "  {}: max |phase current| {:.3f} A (rated {:.3g} A; bound Vbus/R = {:.3f} A: {}); "
          "lost steps at the end {:g}, largest |count| {:g}\n",
          sm.steppers[s].name, watch[s].max_current, sm.steppers[s].config.motor.rated_current,
          watch[s].bound, within ? "within" : "EXCEEDED", watch[s].lost_steps,
          watch[s].max_abs_lost);
    }
    fmt::print("  {}\n", sound ? "sound" : "NOT SOUND");
    return sound ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "\nsoak: %s\n", e.what());
    return 1;
  }
}
