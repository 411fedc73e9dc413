// The mjstepper command: run a model with command profiles and log it, or describe its steppers.
#include <fmt/format.h>
#include <fmt/ostream.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "config.h"
#include "core/attributes.h"
#include "core/signals.h"
#include "core/units.h"
#include "csv_writer.h"
#include "identify.h"
#include "plot.h"
#include "runner.h"
#include "stepper_model.h"
#include "sweep.h"

namespace mjstepper::tools {
namespace {

// "NAME=NUMBER" items of a repeatable option as a map; throws naming the item and the form.
std::map<std::string, double> NamedNumbers(const char* option, const char* form,
                                           const std::vector<std::string>& items) {
  std::map<std::string, double> out;
  for (const std::string& item : items) {
    const size_t eq = item.find('=');
    double value = 0;
    if (eq == std::string::npos || eq == 0 ||
        !mjstepper::ParseFiniteDouble(item.substr(eq + 1), &value)) {
      throw std::invalid_argument(fmt::format("{} {}: expected {}", option, item, form));
    }
    out[item.substr(0, eq)] = value;
  }
  return out;
}

int Info(const std::string& path) {
  const StepperModel sm = LoadStepperModel(path);
  const mjModel* m = sm.model.get();
  const double h = m->opt.timestep;
  fmt::print("{}: timestep {:g} s, {} stepper(s)\n", path, h, sm.steppers.size());
  for (const StepperActuator& s : sm.steppers) {
    const Drive drive(s.config);
    const MotorParams& p = s.config.motor;
    const StepperResolution r = Resolution(m, s);  // at qpos0, the other joints held
    const double inertia = r.inertia, stiffness = r.stiffness, omega_n = r.omega_n;
    const double fn = omega_n / kTwoPi;  // Hz, T(1)
    fmt::print(
        "  {}: drive {}, input {}\n"
        "    Nr {}, R {:g} Ω, L {:g} H, Km {:g} N·m/A, {} detent harmonic(s)\n"
        "    rest current {:g} A, holding stiffness T' = {} = {:.4g} N·m/rad\n"
        "    rotor-side inertia at qpos0 (rotor and load, other joints held) J = {:.4g} kg·m²\n"
        "      → fn = (1/2π)·√(T'/J) = {:.2f} Hz (S-1..S-7)\n",
        s.name, ControllerName(s.config.controller),
        s.config.input == InputMode::kPosition ? "position (ctrl in rad)"
                                               : "velocity (ctrl in rad/s)",
        p.rotor_teeth, p.resistance, p.inductance, p.torque_constant, p.detent.size(),
        drive.RestCurrentMagnitude(), StiffnessFormula(s.config.controller), stiffness, inertia,
        fn);
    if (!(stiffness > 0)) {
      fmt::print("    no holding stiffness: something else must hold or turn the shaft\n");
      continue;
    }
    fmt::print(
        "    largest timestep that resolves it: {:.3g} s (ωn·h <= {}, with the detent's worst-case "
        "stiffness Σ h·Nr·Kdh = {:.4g} N·m/rad added to T'); the model's: {:g} s\n",
        r.largest_timestep, kMaxOmegaTimesStep, r.detent_stiffness, h);
    for (const DetentHarmonic& dh : p.detent) {
      fmt::print("    detent h = {}: resonance at {:.1f} r/min (h·Nr·n/60 = fn)\n", dh.order,
                 60.0 * fn / (dh.order * p.rotor_teeth));
    }
    if (h > r.largest_timestep) {
      fmt::print(
          "    warning: timestep {:g} s is too coarse for this stepper: ωn·h = {:.3f} > {} (T' and "
          "the detent); use timestep <= {:.3g} s\n",
          h, kMaxOmegaTimesStep * h / r.largest_timestep, kMaxOmegaTimesStep, r.largest_timestep);
    }
  }
  const double highest = HighestMode(m, sm.steppers);  // rad/s
  if (highest > 0) {
    fmt::print(
        "  model: highest natural frequency (joint springs and the steppers' T', M at qpos0) "
        "{:.1f} Hz: largest timestep {:.3g} s\n",
        highest / kTwoPi, kMaxOmegaTimesStep / highest);
    if (highest * h > kMaxOmegaTimesStep) {
      fmt::print("  warning: timestep {:g} s is too coarse for the model's highest mode: ωn·h = "
                 "{:.3f} > {}\n",
                 h, highest * h, kMaxOmegaTimesStep);
    }
  }
  return 0;  // warnings inform; they do not fail the command
}

// The README tables, made from the tables the parser and the sensors use.
int WriteTables(const std::string& path) {
  const std::vector<std::pair<std::string, std::string>> sections = {
      {"presets", plugin::PresetTableMarkdown()},
      {"drives", plugin::DriveListMarkdown()},
      {"attributes", plugin::AttributeTableMarkdown()},
      {"signals", SignalTableMarkdown()}};
  if (path.empty()) {
    for (const auto& [name, table] : sections) fmt::print("{}\n", table);
    return 0;
  }
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string text = buffer.str();
  for (const auto& [name, table] : sections) {
    const std::string begin = fmt::format("<!-- BEGIN {} -->\n", name);
    const std::string end = fmt::format("<!-- END {} -->", name);
    const size_t b = text.find(begin), e = text.find(end);
    if (b == std::string::npos || e == std::string::npos || e < b) {
      throw std::runtime_error(fmt::format("{}: no {} ... {} markers", path, begin, end));
    }
    text.replace(b + begin.size(), e - b - begin.size(), table);
  }
  {
    std::ofstream out(path + ".tmp");
    out << text;
    if (!out.flush()) throw std::runtime_error("cannot write " + path + ".tmp");
  }
  MoveIntoPlace(path + ".tmp", path);  // never half-written
  fmt::print("wrote {}\n", path);
  return 0;
}

}  // namespace
}  // namespace mjstepper::tools

int main(int argc, char** argv) {
  using namespace mjstepper::tools;
  using mjstepper::RadPerSecToRpm;
  CLI::App app{"mjstepper: stepper motors and their drives on MuJoCo joints"};
  app.require_subcommand(1);

  RunOptions run;
  std::vector<std::string> ctrl;
  CLI::App* run_cmd = app.add_subcommand("run", "step a model with command profiles, log to CSV");
  run_cmd->add_option("model", run.model, "MJCF model")->required()->check(CLI::ExistingFile);
  run_cmd->add_option("--duration", run.duration, "simulated time, s")->required();
  run_cmd->add_option("--ctrl", ctrl,
                      "ACTUATOR=PROFILE, e.g. 'shaft=ramp(0rpm,200rpm,0.8s)'; profiles: "
                      "constant(X), ramp(A,B,T), trapezoid(V,Ta,Tc,Td); units rpm, rad/s, rad, "
                      "deg, s");
  run_cmd->add_option("--log", run.log, "CSV log (written to FILE.tmp, then renamed)");
  std::string run_plot, size = "1280x720";
  run_cmd->add_option("--render", run.render.video, "MP4 video of the run (ffmpeg)");
  run_cmd->add_option("--frames", run.render.frames_dir, "folder for PNG frames");
  run_cmd->add_option("--camera", run.render.renderer.camera,
                      "named camera of the model (default: the free camera)");
  run_cmd->add_option("--size", size, "frame size WxH")->default_val(size);
  run_cmd->add_option("--fps", run.render.fps, "video frames per second")->default_val(30);
  run_cmd
      ->add_option("--playback", run.render.playback,
                   "simulated seconds per video second (0.1: ten times slower)")
      ->default_val(1.0);
  run_cmd->add_option("--overlay", run.render.overlay_steppers,
                      "stepper whose plots are drawn (at most two; default: the first two)");
  bool no_overlay = false;
  run_cmd->add_flag("--no-overlay", no_overlay, "no plots or text on the frames");
  run_cmd->add_option("--plot", run_plot, "PNG plot of the run (needs --log)");
  run_cmd->add_option("--log-every", run.log_every, "log one row every N steps")->default_val(1);
  bool quiet = false;
  run_cmd->add_flag("--quiet", quiet, "no progress line");
  std::vector<std::string> sets;
  const char* set_help =
      "ACTUATOR.KEY=VALUE: change a stepper's <config> for this run, e.g. "
      "shaft.damping=all or shaft.drive=servo (repeatable)";
  run_cmd->add_option("--set", sets, set_help);
  run_cmd->add_option("--keyframe", run.keyframe,
                      "start from the model's keyframe of this name (the drives start at rest on "
                      "their rotors there)");
  run_cmd->add_flag("--allow-coarse", run.allow_coarse,
                    "run although a stepper's timestep is too coarse for its resonance "
                    "(ωn·h > 0.2, see info)");
  std::vector<std::string> masses;
  run_cmd->add_option("--mass", masses,
                      "BODY=KG: a body's mass for this run, its inertia scaled with it, e.g. "
                      "payload=2 in models/arm3.xml (repeatable)");
  std::vector<std::string> loads;
  run_cmd->add_option("--load", loads,
                      "ACTUATOR=TORQUE: the constant load torque τl (N·m, against positive "
                      "motion) of a load actuator, <general gainprm=\"0\" biastype=\"affine\">, "
                      "e.g. load=0.1 in models/kim_*.xml (repeatable)");

  SweepOptions sweep;
  std::string speeds, sweep_out;
  double settle = sweep.settle, measure = sweep.measure;
  CLI::App* sweep_cmd =
      app.add_subcommand("sweep", "constant-speed runs over a speed list: the resonance map");
  sweep_cmd->add_option("model", sweep.model, "MJCF model")->required()->check(CLI::ExistingFile);
  sweep_cmd->add_option("--speeds", speeds, "from:to:step or a,b,c with a unit: 10:200:2.5rpm")
      ->required();
  sweep_cmd->add_option("--actuator", sweep.actuator, "stepper to sweep (default: the only one)");
  sweep_cmd->add_option("--out", sweep_out, "output prefix: writes PREFIX.csv and PREFIX.png")
      ->required();
  sweep_cmd->add_option("--settle", settle, "s after reaching speed before measuring")
      ->default_val(settle);
  sweep_cmd->add_option("--measure", measure, "s measured at each speed")->default_val(measure);
  sweep_cmd->add_option("--threads", sweep.threads, "worker threads (default: one per core)");
  sweep_cmd->add_option("--set", sets, set_help);
  sweep_cmd->add_flag("--quiet", quiet, "no progress line");

  MapOptions map;
  std::string map_speeds, map_vary, map_out;
  CLI::App* map_cmd = app.add_subcommand(
      "map", "resonance map: the sweep over a grid of speed × one load parameter, on all cores");
  map_cmd->add_option("model", map.sweep.model, "MJCF model")
      ->required()
      ->check(CLI::ExistingFile);
  map_cmd->add_option("--speeds", map_speeds, "from:to:step or a,b,c with a unit")->required();
  map_cmd
      ->add_option("--vary", map_vary,
                   "the load parameter and its values: stiffness:JOINT=a,b,c (N·m/rad or N/m) "
                   "or mass:BODY=a,b,c (kg, inertia scaled with it)")
      ->required();
  map_cmd->add_option("--actuator", map.sweep.actuator, "the stepper (default: the only one)");
  map_cmd->add_option("--out", map_out, "output prefix: writes PREFIX.csv and PREFIX.png")
      ->required();
  map_cmd->add_option("--settle", map.sweep.settle, "s after reaching speed before measuring")
      ->default_val(map.sweep.settle);
  map_cmd->add_option("--measure", map.sweep.measure, "s measured at each speed")
      ->default_val(map.sweep.measure);
  map_cmd->add_option("--threads", map.sweep.threads, "worker threads (default: one per core)");
  map_cmd->add_option("--set", sets, set_help);
  map_cmd->add_flag("--quiet", quiet, "no progress line");

  PullOutOptions pullout;
  std::string pullout_speeds, pullout_out;
  CLI::App* pullout_cmd = app.add_subcommand(
      "pullout", "pull-out torque curve: at each speed, a rising load torque until the first slip");
  pullout_cmd->add_option("model", pullout.model, "MJCF model")
      ->required()
      ->check(CLI::ExistingFile);
  pullout_cmd->add_option("--speeds", pullout_speeds, "from:to:step or a,b,c with a unit")
      ->required();
  pullout_cmd->add_option("--actuator", pullout.actuator, "the stepper (default: the only one)");
  pullout_cmd->add_option("--out", pullout_out, "output prefix: writes PREFIX.csv and PREFIX.png")
      ->required();
  pullout_cmd->add_option("--rate", pullout.rate, "N·m/s: how fast the load torque rises")
      ->default_val(pullout.rate);
  pullout_cmd->add_option("--max-torque", pullout.max_torque, "N·m: stop a run that holds this")
      ->default_val(pullout.max_torque);
  pullout_cmd->add_option("--threads", pullout.threads, "worker threads (default: one per core)");
  pullout_cmd->add_option("--set", sets, set_help);
  pullout_cmd->add_flag("--quiet", quiet, "no progress line");

  IdentifyOptions identify;
  std::string identify_speeds = "10,30rpm";
  CLI::App* identify_cmd = app.add_subcommand(
      "identify", "estimate detent harmonics and static friction from constant-speed runs");
  identify_cmd->add_option("model", identify.model, "MJCF with the stepper and a turning actuator")
      ->required()
      ->check(CLI::ExistingFile);
  identify_cmd->add_option("--actuator", identify.actuator, "the stepper")->default_val("shaft");
  identify_cmd
      ->add_option("--dyno", identify.dyno, "the actuator that turns the shaft (ctrl: rad/s)")
      ->default_val("dyno");
  identify_cmd->add_option("--speeds", identify_speeds, "two or more speeds, e.g. 10,30rpm")
      ->default_val(identify_speeds);
  identify_cmd->add_option("--orders", identify.orders, "harmonic orders to fit")
      ->default_val(std::vector<int>{4, 2, 1});
  identify_cmd->add_option("--set", sets, set_help);

  std::vector<std::string> plot_csvs, plot_labels;
  std::string plot_out, plot_title;
  CLI::App* plot_cmd = app.add_subcommand("plot", "PNG plot of run logs or sweep CSVs");
  plot_cmd->add_option("csv", plot_csvs, "CSV written by run, sweep or pullout")
      ->required()
      ->check(CLI::ExistingFile);
  plot_cmd->add_option("--out", plot_out, "PNG")->required();
  plot_cmd->add_option("--labels", plot_labels, "one label per sweep CSV");
  plot_cmd->add_option("--title", plot_title, "title");
  bool versus_speed = false;
  plot_cmd->add_flag("--versus-speed", versus_speed,
                     "run logs: velocity errors against commanded speed instead of time");

  std::string info_model;
  CLI::App* info_cmd = app.add_subcommand("info", "list the steppers of a model and check it");
  info_cmd->add_option("model", info_model, "MJCF model")->required()->check(CLI::ExistingFile);

  std::string tables_file;
  CLI::App* tables_cmd = app.add_subcommand(
      "tables", "print the drive, attribute and signal tables (Markdown), or --write them into "
                "a README between its <!-- BEGIN x --> / <!-- END x --> markers");
  tables_cmd->add_option("--write", tables_file, "README to update in place")
      ->check(CLI::ExistingFile);

  CLI11_PARSE(app, argc, argv);
  try {
    if (*tables_cmd) return WriteTables(tables_file);
    if (*run_cmd) {
      for (const std::string& c : ctrl) {
        const size_t eq = c.find('=');
        if (eq == std::string::npos || eq == 0) {
          throw std::invalid_argument(fmt::format("--ctrl {}: expected ACTUATOR=PROFILE", c));
        }
        run.ctrl[c.substr(0, eq)] = c.substr(eq + 1);
      }
      run.masses = NamedNumbers("--mass", "BODY=KG, KG a finite number", masses);
      run.loads =
          NamedNumbers("--load", "ACTUATOR=TORQUE, TORQUE a finite number in N·m", loads);
      run.progress = !quiet;
      for (const std::string& s : sets) run.overrides.push_back(ParseOverride(s));
      if (std::sscanf(size.c_str(), "%dx%d", &run.render.renderer.width,
                      &run.render.renderer.height) != 2) {
        throw std::invalid_argument(fmt::format("--size {}: expected WxH, e.g. 640x480", size));
      }
      run.render.overlays = !no_overlay;
      if (!run_plot.empty() && run.log.empty()) {
        throw std::invalid_argument("--plot needs --log: the plot is drawn from the log");
      }
      if (!run_plot.empty()) CheckOutputPath(run_plot);  // before the run, not after it
      const RunResult result = Run(run, std::cerr);
      PrintSummary(result, run.log, std::cout);
      if (!run_plot.empty()) {
        Plot("log", {run.log}, {}, run_plot);
        fmt::print("  plot: {}\n", run_plot);
      }
      return 0;
    }
    if (*plot_cmd) {
      std::ifstream first(plot_csvs[0]);
      std::string header;
      std::getline(first, header);
      const bool pullout_csv = header.find("pull_out_torque") != std::string::npos;
      const bool sweep_csv = !pullout_csv && header.rfind("speed[r/min]", 0) == 0;
      if (!sweep_csv && plot_csvs.size() != 1) {
        throw std::invalid_argument(
            "plot: give one run log or pull-out CSV, or any number of sweep CSVs");
      }
      Plot(pullout_csv ? "pullout" : sweep_csv ? "sweep" : "log", plot_csvs, plot_labels,
           plot_out, plot_title, versus_speed && !sweep_csv && !pullout_csv);
      fmt::print("wrote {}\n", plot_out);
      return 0;
    }
    if (*identify_cmd) {
      identify.speeds = ParseSpeedList(identify_speeds);
      for (const std::string& s : sets) identify.overrides.push_back(ParseOverride(s));
      const Identified id = Identify(identify);
      fmt::print("{}: identified from the torque turning '{}' at {}\n", identify.model,
                 identify.actuator, identify_speeds);
      for (const mjstepper::DetentHarmonic& dh : id.harmonics) {
        fmt::print("  Kd{} = {:.5f} N·m, phi{} = {:+.4f} rad\n", dh.order, dh.amplitude, dh.order,
                   dh.phase);
      }
      fmt::print("  Fs = {:.5f} N·m, B = {:.6f} N·m·s/rad; fit residual {:.2e} N·m RMS\n",
                 id.static_friction, id.viscous_damping, id.residual_rms);
      fmt::print("  <config key=\"damping_detent\" value=\"{}\"/>\n", id.DampingDetent());
      fmt::print("  <config key=\"friction_compensation\" value=\"{:.5g}\"/>\n",
                 id.static_friction);
      return 0;
    }
    if (*map_cmd) {
      map.sweep.speeds = ParseSpeedList(map_speeds);
      map.sweep.progress = !quiet;
      for (const std::string& s : sets) map.sweep.overrides.push_back(ParseOverride(s));
      const size_t eq = map_vary.find('=');
      if (eq == std::string::npos || eq == 0) {
        throw std::invalid_argument(
            fmt::format("--vary {}: expected stiffness:JOINT=a,b,c or mass:BODY=a,b,c", map_vary));
      }
      map.parameter = map_vary.substr(0, eq);
      std::stringstream list(map_vary.substr(eq + 1));
      for (std::string item; std::getline(list, item, ',');) {
        double value = 0;
        if (!mjstepper::ParseFiniteDouble(item, &value)) {
          throw std::invalid_argument(
              fmt::format("--vary {}: \"{}\" is not a finite number", map_vary, item));
        }
        map.values.push_back(value);
      }
      const auto start = std::chrono::steady_clock::now();
      const std::vector<MapPoint> points = Map(map, std::cerr);
      WriteMapCsv(map_out + ".csv", map.parameter, points);
      Plot("map", {map_out + ".csv"}, {}, map_out + ".png",
           fmt::format("{}: velocity ripple over speed × {}", map.sweep.model, map.parameter));
      fmt::print("{} runs in {:.1f} s\n  wrote {}.csv\n  wrote {}.png\n", points.size(),
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                 map_out, map_out);
      return 0;
    }
    if (*pullout_cmd) {
      pullout.speeds = ParseSpeedList(pullout_speeds);
      pullout.progress = !quiet;
      for (const std::string& s : sets) pullout.overrides.push_back(ParseOverride(s));
      const auto start = std::chrono::steady_clock::now();
      const std::vector<PullOutPoint> points = PullOut(pullout, std::cerr);
      WritePullOutCsv(pullout_out + ".csv", points);
      Plot("pullout", {pullout_out + ".csv"}, {}, pullout_out + ".png",
           fmt::format("{}: pull-out torque", pullout.model));
      const auto best = std::max_element(
          points.begin(), points.end(),
          [](const PullOutPoint& a, const PullOutPoint& b) { return a.torque < b.torque; });
      fmt::print("{} speeds in {:.1f} s; highest pull-out torque {:.3f} N·m at {:.1f} r/min\n"
                 "  wrote {}.csv\n  wrote {}.png\n",
                 points.size(),
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                 best->torque, RadPerSecToRpm(best->speed), pullout_out, pullout_out);
      return 0;
    }
    if (*sweep_cmd) {
      sweep.speeds = ParseSpeedList(speeds);
      sweep.settle = settle;
      sweep.measure = measure;
      sweep.progress = !quiet;
      for (const std::string& s : sets) sweep.overrides.push_back(ParseOverride(s));
      const auto start = std::chrono::steady_clock::now();
      const std::vector<SweepPoint> points = Sweep(sweep, std::cerr);
      WriteSweepCsv(sweep_out + ".csv", points);
      Plot("sweep", {sweep_out + ".csv"}, {}, sweep_out + ".png",
           fmt::format("{}: constant-speed sweep", sweep.model));
      const auto worst = std::max_element(points.begin(), points.end(),
                                          [](const SweepPoint& a, const SweepPoint& b) {
                                            return a.peak_to_peak_error < b.peak_to_peak_error;
                                          });
      fmt::print(
          "{} speeds in {:.1f} s; largest velocity ripple {:.2f} r/min peak-to-peak at {:.1f} "
          "r/min ({:.1f} Hz)\n  wrote {}.csv\n",
          points.size(),
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
          RadPerSecToRpm(worst->peak_to_peak_error), RadPerSecToRpm(worst->speed),
          worst->dominant_frequency, sweep_out);
      fmt::print("  wrote {}.png\n", sweep_out);
      return 0;
    }
    return mjstepper::tools::Info(info_model);
  } catch (const std::exception& e) {
    fmt::print(std::cerr, "mjstepper: {}\n", e.what());
    return 1;
  }
}
