#include "cli.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "core/attributes.h"
#include "core/command_profile.h"
#include "installation.h"
#include "output_file.h"

// The version and the MuJoCo built against, from CMake (CMakeLists.txt, from pyproject.toml); a
// build that does not set them (the fuzzers' own) says so.
#ifndef MJSTEPPER_VERSION
#define MJSTEPPER_VERSION "(unversioned build)"
#endif
#ifndef MJSTEPPER_MUJOCO_VERSION
#define MJSTEPPER_MUJOCO_VERSION "unknown"
#endif

namespace mjstepper::tools {
namespace {

// --start: how a run (or a sizing's cycle) starts under gravity (runner.h, StartMode).
void AddStart(CLI::App* app, StartMode* start) {
  app->add_option("--start", *start,
                  "settled (default): when gravity loads a stepper, the drives first hold their "
                  "start for 0.5 s while gravity is ramped in over 0.3 s, so the motion starts "
                  "from the load angle that holds the load, as a powered-up arm does; aligned: "
                  "full gravity at t = 0 on rotors at their aligned angle (overshoots to up to "
                  "twice the static load angle)")
      ->transform(CLI::Validator(
          [](std::string& value) -> std::string {
            if (value == "settled")
              value = "0";
            else if (value == "aligned")
              value = "1";
            else
              return fmt::format("'{}': must be settled or aligned", Excerpt(value));
            return "";
          },
          "settled|aligned"));
}

// A CLI11 transform for a model (or --klipper map) file: the path given when it is a file, else
// the installation's example model it names (installation.h, FindModel), so `mjstepper info
// tsui_rigid` and the docs' `models/…` paths work outside a clone (issue 32, item 6).
const CLI::Validator kModelFile(
    [](std::string& text) -> std::string {
      const std::string found = FindModel(text);
      if (found.empty()) {
        return fmt::format(
            "'{}': no such file, nor an example model of that name (`mjstepper models` lists them)",
            Excerpt(text));
      }
      text = found;
      return "";
    },
    "FILE", "model file");

// A CLI11 validator for an output path or prefix: not empty (issue 33: `--out ''` wrote files
// named by their suffix alone, `_raw.csv`, into the working folder), and not a device or another
// special file (issue 33: `--out /dev/null` wrote /dev/null_raw.csv and /dev/null_psd.csv).
const CLI::Validator kNonEmptyPath(
    [](std::string& text) -> std::string {
      if (text.empty()) return "an empty path: give a file or a prefix";
      std::error_code error;
      const auto status = std::filesystem::status(text, error);  // (through symlinks)
      if (!error && std::filesystem::exists(status) && !std::filesystem::is_regular_file(status) &&
          !std::filesystem::is_directory(status)) {
        return fmt::format(
            "'{}' is a device or another special file, not a file to write nor a prefix for "
            "files beside it: give a path in a folder (to discard the output, leave the option "
            "out where it is optional)",
            Excerpt(text));
      }
      return "";
    },
    "PATH", "non-empty");

// A CLI11 validator for a 64-bit unsigned integer, checked on its text before CLI11 converts it
// (issue 33: `--seed -1` wrapped to 2^64 − 1 and a larger number was clamped, both silently).
const CLI::Validator kUnsigned64(
    [](std::string& text) -> std::string {
      std::uint64_t value = 0;
      const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
      if (error == std::errc() && end == text.data() + text.size()) return "";
      return fmt::format("\"{}\" is not an integer in [0, {}]", text,
                         std::numeric_limits<std::uint64_t>::max());
    },
    "UINT64", "unsigned 64-bit");

// A CLI11 validator: a finite number within the named range (NaN and inf fail); its description,
// "in [lo, hi] unit", shows in --help.
CLI::Validator InRange(const char* name) {
  const OptionRange& r = Range(name);
  return CLI::Validator(
      [&r](std::string& text) -> std::string {
        double v = 0;
        if (!ParseFiniteDouble(text, &v)) return fmt::format("\"{}\" is not a finite number", text);
        if (v >= r.lo && v <= r.hi) return "";
        return fmt::format("{} is not in [{:g}, {:g}] {}", text, r.lo, r.hi, r.unit);
      },
      fmt::format("in [{:g}, {:g}] {}", r.lo, r.hi, r.unit), name);
}

// `--NAME`, checked by InRange(NAME): the option's name and its range's key are one string.
template <class T>
CLI::Option* AddBounded(CLI::App* app, const char* name, T& value, const std::string& help) {
  return app->add_option(fmt::format("--{}", name), value, help)->check(InRange(name));
}

const char* kAllowCoarseHelp =
    "run although the timestep is too coarse for a mode a stepper takes part in (ω·h > 0.2 with "
    "the detent's worst-case stiffness; info lists the modes), warning once; a mode without a "
    "stepper only warns";

const char* kSetHelp =
    "ACTUATOR.KEY=VALUE: change a stepper's <config> for this run, e.g. shaft.damping=all or "
    "shaft.drive=servo (repeatable)";

}  // namespace

CommandLine::CommandLine(bool out_optional)
    : app_("mjstepper: stepper motors and their drives on MuJoCo joints") {
  app_.require_subcommand(1);
  app_.set_version_flag("--version",
                        "mjstepper " MJSTEPPER_VERSION " (MuJoCo " MJSTEPPER_MUJOCO_VERSION ")");
  Command& c = c_;

  run_ = app_.add_subcommand("run", "step a model with command profiles, log to CSV");
  run_->add_option("model", c.run.model, "MJCF model")->required()->transform(kModelFile);
  AddBounded(run_, "duration", c.run.duration, "simulated time, s")->required();
  run_->add_option(
      "--ctrl", ctrl_,
      "ACTUATOR=PROFILE, e.g. 'shaft=ramp(0rpm,200rpm,0.8s)'; profiles: constant(X), "
      "ramp(A,B,T), trapezoid(V,Ta,Tc,Td), targets(A0,A1@T1,…) (angle targets for "
      "a drive's own profile), shaped(PROFILE, mzv 40Hz) (through an input shaper: zv, mzv, "
      "zvd, ei, 2hump_ei, 3hump_ei); units rpm, rad/s, rad/s², rad, deg, s (on "
      "a slide, a tendon or a hinge with pulley_teeth or lead also m, mm, m/s, mm/s, "
      "m/s², mm/s² at the carriage); speeds "
      "within ±1e4 rad/s, angles ±1e7 rad, times 1e6 s; or steps(FILE), a "
      "STEP/DIR list (one step time in s per line, optionally +1/-1) for input=steps");
  run_->add_option("--klipper", c.run.klipper,
                   "MAP: a real print's step stream, Klipper's MCU commands from its batch mode "
                   "(parsedump.py output) onto the actuators the map names, each as a steps(FILE) "
                   "--ctrl (models/prints/README.md)")
      ->transform(kModelFile);
  run_->add_option("--log", c.run.log, "CSV log (a regular file or nothing; written whole)");
  run_->add_option("--accel-log", c.run.accel_log,
                   "the toolhead's virtual ADXL345 in Klipper's raw format (#time,accel_x,"
                   "accel_y,accel_z; s, mm/s²)");
  run_->add_option("--accelerometer", c.run.accelerometer,
                   "the MuJoCo accelerometer sensor --accel-log reads")
      ->default_val("toolhead_accel");
  run_->add_option("--render", c.run.render.video, "MP4 video of the run (ffmpeg)");
  run_->add_option("--frames", c.run.render.frames_dir, "folder for PNG frames");
  run_->add_option("--camera", c.run.render.renderer.camera,
                   "named camera of the model (default: the free camera)");
  run_->add_option("--size", size_, "frame size WxH, each in [16, 8192] pixels")
      ->default_val(size_);
  AddBounded(run_, "fps", c.run.render.fps, "video frames per second")->default_val(30);
  AddBounded(run_, "playback", c.run.render.playback,
             "simulated seconds per video second (0.1: ten times slower)")
      ->default_val(1.0);
  run_->add_option("--overlay", c.run.render.overlay_steppers,
                   "stepper whose plots are drawn (repeat for more; default: every stepper)");
  run_->add_flag("--no-overlay", no_overlay_, "no plots or text on the frames");
  run_->add_option("--plot", c.run_plot, "PNG plot of the run (needs --log)");
  AddBounded(run_, "log-every", c.run.log_every, "log one row every N steps")->default_val(1);
  run_->add_flag("--quiet", quiet_, "no progress line");
  run_->add_option("--set", sets_, kSetHelp);
  run_->add_option("--keyframe", c.run.keyframe,
                   "start from the model's keyframe of this name (the drives start at rest on "
                   "their rotors there)");
  AddStart(run_, &c.run.start);
  run_->add_flag("--allow-coarse", c.run.allow_coarse, kAllowCoarseHelp);
  run_->add_option("--mass", masses_,
                   "BODY=KG: a body's mass for this run, its inertia scaled with it, e.g. "
                   "payload=2 in models/arm3.xml (repeatable; KG in [1e-9, 1e6])");
  run_->add_option("--load", loads_,
                   "ACTUATOR=TORQUE: the constant load torque τl (N·m, against positive motion) "
                   "of a load actuator, <general gainprm=\"0\" biastype=\"affine\">, e.g. load=0.1 "
                   "in models/kim_*.xml (repeatable; TORQUE in [-1e4, 1e4])");

  sweep_ = app_.add_subcommand("sweep", "constant-speed runs over a speed list: the resonance map");
  map_ = app_.add_subcommand(
      "map", "resonance map: the sweep over a grid of speed × one load parameter, on all cores");
  pullout_ = app_.add_subcommand(
      "pullout", "pull-out torque curve: at each speed, a rising load torque until the first slip");
  for (CLI::App* sub : {sweep_, map_, pullout_}) {
    SweepOptions* so = sub == map_ ? &c.map.sweep : &c.sweep;
    std::string* model = sub == pullout_ ? &c.pullout.model : &so->model;
    std::string* actuator = sub == pullout_ ? &c.pullout.actuator : &so->actuator;
    int* threads = sub == pullout_ ? &c.pullout.threads : &so->threads;
    sub->add_option("model", *model, "MJCF model")->required()->transform(kModelFile);
    sub->add_option("--speeds", c.speeds_text,
                    "from:to:step or a,b,c with a unit (rpm, r/min, rad/s at the rotor; mm/s, m/s "
                    "at a linear axis's carriage): 10:200:2.5rpm; each within ±1e4 (SI), at "
                    "most 1e5 speeds")
        ->required();
    sub->add_option("--actuator", *actuator, "the stepper (default: the only one)");
    sub->add_option("--out", c.out, "output prefix: writes PREFIX.csv and PREFIX.png")
        ->required(!out_optional)
        ->check(kNonEmptyPath);
    if (sub != pullout_) {
      AddBounded(sub, "settle", so->settle, "s after reaching speed before measuring")
          ->default_val(so->settle);
      AddBounded(sub, "measure", so->measure,
                 "s measured at each speed (at least 100 timesteps of the model)")
          ->default_val(so->measure);
    }
    AddBounded(sub, "threads", *threads, "worker threads (default: one per core)");
    sub->add_option("--set", sets_, kSetHelp);
    sub->add_flag("--allow-coarse", allow_coarse_, kAllowCoarseHelp);
    sub->add_flag("--quiet", quiet_, "no progress line");
  }
  map_->add_option("--vary", vary_,
                   "the load parameter and its values: stiffness:JOINT=a,b,c (N·m/rad or N/m, "
                   "each in [0, 1e12]) or mass:BODY=a,b,c (kg, each in [1e-9, 1e6], inertia "
                   "scaled with it)")
      ->required();
  AddBounded(pullout_, "rate", c.pullout.rate, "N·m/s: how fast the load torque rises")
      ->default_val(c.pullout.rate);
  AddBounded(pullout_, "max-torque", c.pullout.max_torque, "N·m: stop a run that holds this")
      ->default_val(c.pullout.max_torque);

  identify_ = app_.add_subcommand(
      "identify", "estimate detent harmonics and static friction from constant-speed runs");
  identify_->add_option("model", c.identify.model, "MJCF with the stepper and a turning actuator")
      ->required()
      ->transform(kModelFile);
  identify_->add_option("--actuator", c.identify.actuator, "the stepper")->default_val("shaft");
  identify_->add_option("--dyno", c.identify.dyno, "the actuator that turns the shaft (rad/s)")
      ->default_val("dyno");
  c.speeds_text = "10,30rpm";
  identify_->add_option("--speeds", c.speeds_text, "two or more speeds, e.g. 10,30rpm")
      ->default_val(c.speeds_text);
  AddBounded(identify_, "orders", c.identify.orders, "harmonic orders to fit, each once")
      ->default_val(std::vector<int>{4, 2, 1});
  identify_->add_option("--set", sets_, kSetHelp);

  resonance_ = app_.add_subcommand(
      "resonance-test",
      "Klipper's TEST_RESONANCES on a simulated printer: the toolhead shaken along one axis "
      "through its steppers, a virtual ADXL345 log in Klipper's raw format, the PSD and the input "
      "shapers fitted to it");
  resonance_->add_option("model", c.resonance.model, "MJCF printer (see models/README.md)")
      ->required()
      ->transform(kModelFile);
  resonance_->add_option("--axis", axis_, "x or y")->required()->check(CLI::IsMember({"x", "y"}));
  resonance_
      ->add_option("--out", c.out,
                   "output prefix: PREFIX_raw.csv (Klipper's raw accelerometer format), "
                   "PREFIX_psd.csv (Klipper's calibration CSV), PREFIX.png")
      ->required()
      ->check(kNonEmptyPath);
  AddBounded(resonance_, "min-freq", c.resonance.test.min_freq, "Hz (Klipper's default 5)");
  AddBounded(resonance_, "max-freq", c.resonance.test.max_freq, "Hz (Klipper's 133.33)");
  AddBounded(resonance_, "accel-per-hz", accel_per_hz_, "mm/s² per Hz (Klipper's 75)");
  AddBounded(resonance_, "hz-per-sec", c.resonance.test.hz_per_sec, "Hz/s (Klipper's 1)");
  resonance_
      ->add_option("--accelerometer", c.resonance.accelerometer,
                   "the toolhead's accelerometer sensor")
      ->default_val("toolhead_accel");
  AddBounded(resonance_, "accel-rate", c.resonance.adxl.rate,
             "Hz, the ADXL345's output data rate (3200)");
  resonance_->add_option("--accel-range", accel_range_, "g, the ADXL345's range (±2, 4, 8, 16)")
      ->check(CLI::IsMember({2, 4, 8, 16}));
  AddBounded(resonance_, "accel-noise", accel_noise_,
             "µg/√Hz, the ADXL345's noise density on X and Y (data sheet: 290; Z at "
             "430/290 of it; 0: none)");
  resonance_->add_option("--seed", c.resonance.adxl.seed, "the accelerometer noise's seed")
      ->check(kUnsigned64);
  resonance_->add_option("--set", sets_, kSetHelp);
  resonance_->add_flag("--quiet", quiet_, "no progress line");

  size_cmd_ = app_.add_subcommand(
      "size",
      "size a joint's motor, drive and bus for a move: each joint's torque-speed demand beside "
      "its simulated pull-out curve, the margin at the worst point, lost steps, and the "
      "winding's temperature after N cycles");
  {
    CLI::App* sub = size_cmd_;
    RunOptions& run = c.size.run;
    sub->add_option("model", run.model, "MJCF model")->required()->transform(kModelFile);
    sub->add_option("--move", moves_,
                    "ACTUATOR=P1,P2,…UNIT: the joint's waypoints, one per pose (deg or rad on a "
                    "hinge, mm or m on a slide); the cycle goes from the start pose through each "
                    "pose and back; every moved joint has as many (repeatable)")
        ->required();
    sub->add_option("--speed", move_speeds_,
                    "ACTUATOR=SPEED: the joint's top speed (deg/s, rad/s, rpm; mm/s, m/s), set as "
                    "its drive's profile_speed (default: the drive's own)");
    sub->add_option("--accel", move_accels_,
                    "ACTUATOR=ACCELERATION: the joint's acceleration (deg/s², rad/s²; mm/s², "
                    "m/s²), set as its drive's profile_accel (default: the drive's own)");
    AddBounded(sub, "dwell", c.size.dwell, "s at each pose")->default_val(c.size.dwell);
    AddBounded(sub, "cycles", c.size.cycles, "N: the winding's temperature after N cycles")
        ->default_val(c.size.cycles);
    AddBounded(sub, "pullout-points", c.size.pullout_points,
               "speeds of each joint's pull-out curve (0 to 1.15 × its top speed)")
        ->default_val(c.size.pullout_points);
    sub->add_option("--out", c.out,
                    "output prefix: PREFIX.csv (the table), and per joint PREFIX_JOINT.png, "
                    "PREFIX_JOINT_demand.csv, PREFIX_JOINT_pullout.csv")
        ->required(!out_optional)
        ->check(kNonEmptyPath);
    AddBounded(sub, "threads", c.size.threads, "pull-out workers (default: one per core)");
    sub->add_option("--set", sets_, kSetHelp);
    sub->add_option("--mass", masses_, "BODY=KG: a body's mass, e.g. payload=0.5 (repeatable)");
    sub->add_option("--keyframe", run.keyframe, "start (and end) each cycle at this keyframe");
    AddStart(sub, &run.start);
    sub->add_flag("--allow-coarse", run.allow_coarse, kAllowCoarseHelp);
    sub->add_option("--log", run.log, "CSV log of the cycle (every signal)");
    sub->add_option("--render", run.render.video, "MP4 video of the cycle (ffmpeg)");
    sub->add_option("--camera", run.render.renderer.camera, "named camera of the model");
    sub->add_option("--size", size_, "frame size WxH")->default_val(size_);
    AddBounded(sub, "fps", run.render.fps, "video frames per second")->default_val(30);
    AddBounded(sub, "playback", run.render.playback, "simulated seconds per video second")
        ->default_val(1.0);
    sub->add_flag("--quiet", quiet_, "no progress line");
  }

  attach_ = app_.add_subcommand(
      "attach",
      "put steppers on the joints of any MJCF or URDF robot: writes an MJCF with a stepper "
      "actuator on each named joint (its rotor inertia as armature), the timestep the rule "
      "recommends and a keyframe 'start'");
  attach_->add_option("robot", c.attach.robot, "the robot, MJCF or URDF")
      ->required()
      ->transform(kModelFile);
  attach_
      ->add_option("--stepper", attach_steppers_,
                   "JOINT:key=value,... (repeatable): the joint's stepper, e.g. "
                   "L1:motor=17hs24_2104s,driver=tmc5160,drive=stealthchop,gear=6.4,"
                   "run_current=1.7,ihold=21,microsteps=32; gear= sets the actuator's gear, "
                   "every other key is a plugin attribute (plugin/README.md)")
      ->required();
  attach_->add_option("--out", c.attach.out, "the MJCF written")->required()->check(kNonEmptyPath);
  attach_
      ->add_option("--meshdir", c.attach.meshdir,
                   "the robot's mesh folder, each mesh by its file's base name (for a URDF's "
                   "package:// URIs)")
      ->check(CLI::ExistingDirectory);

  plot_ = app_.add_subcommand("plot", "PNG plot of run logs or sweep CSVs");
  plot_->add_option("csv", c.plot_csvs, "CSV written by run, sweep or pullout")
      ->required()
      ->check(CLI::ExistingFile);
  plot_->add_option("--out", c.out, "PNG")->required()->check(kNonEmptyPath);
  plot_->add_option("--labels", c.plot_labels, "one label per sweep CSV");
  plot_->add_option("--title", c.plot_title, "title");
  plot_->add_flag("--versus-speed", c.versus_speed,
                  "run logs: velocity errors against commanded speed instead of time");

  models_ = app_.add_subcommand(
      "models", "list the example models (any of them runs by name: mjstepper info tsui_rigid)");
  info_ = app_.add_subcommand("info", "list the steppers of a model and check it");
  info_->add_option("model", c.model, "MJCF model")->required()->transform(kModelFile);

  tables_ = app_.add_subcommand(
      "tables",
      "print the drive, attribute, signal and option tables (Markdown), or --write them "
      "into a README between its <!-- BEGIN x --> / <!-- END x --> markers");
  tables_->add_option("--write", c.tables_file, "README to update in place")
      ->check(CLI::ExistingFile);
}

std::vector<OptionDoc> OptionDocs() {
  CommandLine line(/*out_optional=*/false);
  std::vector<OptionDoc> docs;
  for (const CLI::App* sub : line.app().get_subcommands({})) {
    for (const CLI::Option* o : sub->get_options()) {
      if (o->get_lnames().empty() && !o->get_positional()) continue;  // -h
      const bool positional = o->get_positional() && o->get_lnames().empty();
      const std::string name = positional ? o->get_name() : o->get_lnames().front();
      if (name == "help") continue;
      std::string python = name;
      std::replace(python.begin(), python.end(), '-', '_');
      docs.push_back({.command = sub->get_name(),
                      .option = positional ? name : "--" + name,
                      .python = python,
                      .flag = o->get_expected_max() == 0,
                      .positional = positional,
                      .required = o->get_required(),
                      .help = o->get_description()});
    }
  }
  return docs;
}

std::string OptionListMarkdown() {
  // The subcommands with a Python function (python/mjstepper/_experiments.py), by its name.
  const std::map<std::string, std::string> python = {
      {"run", "run"},         {"sweep", "sweep"},       {"map", "map"},
      {"pullout", "pullout"}, {"identify", "identify"}, {"resonance-test", "resonance_test"},
      {"size", "size"},       {"attach", "attach"}};
  std::vector<std::string> order;
  std::map<std::string, std::vector<const OptionDoc*>> by_name;
  const std::vector<OptionDoc> docs = OptionDocs();
  for (const OptionDoc& d : docs) {
    if (by_name[d.option].empty()) order.push_back(d.option);
    by_name[d.option].push_back(&d);
  }
  std::string out =
      "| option | Python | commands | what (the first command's words; `--help` has each "
      "command's) |\n|---|---|---|---|\n";
  for (const std::string& name : order) {
    const std::vector<const OptionDoc*>& uses = by_name[name];
    std::string commands;
    bool in_python = false;
    for (const OptionDoc* d : uses) {
      commands += fmt::format("{}{}", commands.empty() ? "" : ", ", d->command);
      in_python |= python.contains(d->command);
    }
    const OptionDoc& d = *uses.front();
    std::string keyword = "—";
    if (in_python) {
      keyword = d.flag ? fmt::format("`{}=True`", d.python) : fmt::format("`{}=`", d.python);
      if (d.positional) keyword = fmt::format("`{}` (first argument)", d.python);
    }
    std::string help = d.help;
    for (size_t p = help.find('|'); p != std::string::npos; p = help.find('|', p + 2))
      help.replace(p, 1, "\\|");
    out += fmt::format("| `{}` | {} | {} | {} |\n", d.positional ? d.python : name, keyword,
                       commands, help);
  }
  return out;
}

int CommandLine::Exit(const CLI::ParseError& e) {
  std::ostringstream out, err;
  const int status = app_.exit(e, out, err);
  std::cout << out.str();  // the help, whole
  std::cerr << BoundedMessage(err.str());
  return status == 0 ? 0 : kUsageExit;
}

const Command& CommandLine::Parse(int argc, const char* const* argv) {
  app_.parse(argc, argv);
  Check();
  return c_;
}

void CommandLine::Check() {
  Command& c = c_;
  std::vector<ConfigOverride> overrides;
  for (const std::string& s : sets_) overrides.push_back(ParseOverride(s));
  if (*run_) {
    c.kind = CommandKind::kRun;
    RunOptions& run = c.run;
    run.overrides = overrides;
    run.progress = !quiet_;
    for (const std::string& item : ctrl_) {
      const size_t eq = item.find('=');
      if (eq == std::string::npos || eq == 0) {
        throw std::invalid_argument(
            fmt::format("--ctrl {}: expected ACTUATOR=PROFILE", Excerpt(item)));
      }
      const std::string profile = item.substr(eq + 1);
      try {
        // Its grammar and bounds, before any work; linear units are checked here at 1 rad/m
        // and again with the stepper's own gear once the model is loaded (runner.cc).
        CommandProfile::Parse(profile, 1.0);
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(fmt::format("--ctrl {}: {}", Excerpt(item), e.what()));
      }
      run.ctrl[item.substr(0, eq)] = profile;
    }
    run.masses = NamedNumbers("--mass", "BODY=KG, KG a finite number", Range("mass"), masses_);
    run.loads = NamedNumbers("--load", "ACTUATOR=TORQUE, TORQUE a finite number in N·m",
                             Range("load"), loads_);
    ParseSize(size_, &run.render.renderer.width, &run.render.renderer.height);
    run.render.overlays = !no_overlay_;
    if (!c.run_plot.empty() && run.log.empty()) {
      throw std::invalid_argument("--plot needs --log: the plot is drawn from the log");
    }
    if (run.render.enabled()) {
      const double frames = std::floor(run.duration * run.render.fps / run.render.playback) + 1;
      RequireInRange("--duration · --fps / --playback", Range("frames"), frames,
                     fmt::format("{:g} s · {:g} /s / {:g} = {:g} frames", run.duration,
                                 run.render.fps, run.render.playback, frames));
    }
    std::vector<std::pair<std::string, std::string>> outputs;
    for (const auto& [option, path] : {std::pair<const char*, const std::string&>{"--log", run.log},
                                       {"--accel-log", run.accel_log},
                                       {"--plot", c.run_plot},
                                       {"--render", run.render.video},
                                       {"--frames", run.render.frames_dir}}) {
      if (!path.empty()) outputs.emplace_back(option, path);
    }
    CheckDistinctOutputs(outputs);
    for (const auto& [option, path] : outputs) {
      (option == "--frames" ? c.output_dirs : c.outputs).push_back(path);
    }
    return;
  }
  if (*sweep_ || *map_) {
    SweepOptions& so = *sweep_ ? c.sweep : c.map.sweep;
    c.kind = *sweep_ ? CommandKind::kSweep : CommandKind::kMap;
    so.speeds = ParseSpeedList(c.speeds_text, "--speeds", &so.speeds_at_carriage);
    so.progress = !quiet_;
    so.allow_coarse = allow_coarse_;
    so.overrides = overrides;
    if (*map_) {
      const size_t eq = vary_.find('=');
      const size_t colon = vary_.find(':');
      const std::string kind = vary_.substr(0, std::min(colon, eq));
      if (eq == std::string::npos || colon > eq || (kind != "stiffness" && kind != "mass")) {
        throw std::invalid_argument(
            fmt::format("--vary {}: expected stiffness:JOINT=a,b,c or mass:BODY=a,b,c", vary_));
      }
      c.map.parameter = vary_.substr(0, eq);
      std::stringstream list(vary_.substr(eq + 1));
      for (std::string item; std::getline(list, item, ',');) {
        double value = 0;
        if (!ParseFiniteDouble(item, &value)) {
          throw std::invalid_argument(
              fmt::format("--vary {}: \"{}\" is not a finite number", vary_, item));
        }
        RequireInRange("--vary", Range(kind), value, fmt::format("{} ({})", vary_, item));
        c.map.values.push_back(value);
      }
      if (c.map.values.empty()) {
        throw std::invalid_argument(fmt::format("--vary {}: no value", Excerpt(vary_)));
      }
      const double runs = static_cast<double>(c.map.values.size() * so.speeds.size());
      RequireInRange("--speeds × --vary", Range("speeds"), runs, fmt::format("{:g} runs", runs));
    }
    if (!c.out.empty()) c.outputs = {c.out + ".csv", c.out + ".png"};  // --out PREFIX
    return;
  }
  if (*pullout_) {
    c.kind = CommandKind::kPullOut;
    c.pullout.speeds = ParseSpeedList(c.speeds_text, "--speeds", &c.pullout.speeds_at_carriage);
    c.pullout.progress = !quiet_;
    c.pullout.allow_coarse = allow_coarse_;
    c.pullout.overrides = overrides;
    if (c.pullout.max_torque / c.pullout.rate > 1000) {
      throw std::invalid_argument(fmt::format(
          "--max-torque {:g} / --rate {:g} = {:g} s: the load may rise for at most 1000 s of "
          "simulated time per speed",
          c.pullout.max_torque, c.pullout.rate, c.pullout.max_torque / c.pullout.rate));
    }
    if (!c.out.empty()) c.outputs = {c.out + ".csv", c.out + ".png"};  // --out PREFIX
    return;
  }
  if (*identify_) {
    c.kind = CommandKind::kIdentify;
    c.identify.speeds = ParseSpeedList(c.speeds_text);
    c.identify.overrides = overrides;
    return;
  }
  if (*resonance_) {
    c.kind = CommandKind::kResonance;
    c.resonance.axis = axis_.at(0);
    c.resonance.test.accel_per_hz = accel_per_hz_ / 1000;  // m/s² per Hz
    c.resonance.adxl.range = accel_range_ * kStandardGravity;
    const double density = accel_noise_ * 1e-6 * kStandardGravity;  // m/s²/√Hz
    c.resonance.adxl.noise_density = {density, density, density * 430 / 290};
    c.resonance.overrides = overrides;
    c.resonance.progress = !quiet_;
    c.resonance.out = c.out;
    if (!(c.resonance.test.max_freq > c.resonance.test.min_freq)) {
      throw std::invalid_argument(fmt::format("--max-freq {:g}: must be above --min-freq {:g}",
                                              c.resonance.test.max_freq,
                                              c.resonance.test.min_freq));
    }
    RequireInRange("--max-freq, --min-freq and --hz-per-sec", Range("test-duration"),
                   c.resonance.test.Duration(),
                   fmt::format("give {:g} s of test", c.resonance.test.Duration()));
    c.outputs = {c.out + "_raw.csv", c.out + "_psd.csv", c.out + ".png"};
    return;
  }
  if (*size_cmd_) {
    c.kind = CommandKind::kSize;
    SizeOptions& size = c.size;
    size.run.overrides = overrides;
    size.run.progress = !quiet_;
    size.run.masses = NamedNumbers("--mass", "BODY=KG, KG a finite number", Range("mass"), masses_);
    ParseSize(size_, &size.run.render.renderer.width, &size.run.render.renderer.height);
    size.out = c.out;
    // ACTUATOR=TEXT items, their grammar and units checked before any work (hinge or slide is
    // known once the model is loaded: size.cc checks the family then).
    for (const auto& [items, option, quantity, target] :
         {std::tuple{&moves_, "--move", JointQuantity::kPosition, &size.moves},
          std::tuple{&move_speeds_, "--speed", JointQuantity::kSpeed, &size.speeds},
          std::tuple{&move_accels_, "--accel", JointQuantity::kAcceleration,
                     &size.accelerations}}) {
      for (const std::string& item : *items) {
        const size_t eq = item.find('=');
        if (eq == std::string::npos || eq == 0) {
          throw std::invalid_argument(
              fmt::format("{} {}: expected ACTUATOR=VALUES", option, Excerpt(item)));
        }
        const std::string name = item.substr(0, eq), text = item.substr(eq + 1);
        ParseJointValues(fmt::format("{} {}=", option, name), text, quantity, std::nullopt,
                         quantity != JointQuantity::kPosition);
        if (!target->emplace(name, text).second) {
          throw std::invalid_argument(
              fmt::format("{} {}: '{}' given twice", option, Excerpt(item), Excerpt(name)));
        }
      }
    }
    std::vector<std::pair<std::string, std::string>> outputs;
    if (!size.run.log.empty()) outputs.emplace_back("--log", size.run.log);
    if (!size.run.render.video.empty()) outputs.emplace_back("--render", size.run.render.video);
    if (!c.out.empty()) outputs.emplace_back("--out", c.out + ".csv");
    CheckDistinctOutputs(outputs);
    for (const auto& [option, path] : outputs) c.outputs.push_back(path);
    return;
  }
  if (*attach_) {
    c.kind = CommandKind::kAttach;
    c.attach.steppers.clear();
    for (const std::string& item : attach_steppers_) {
      c.attach.steppers.push_back(ParseAttachStepper(item));
    }
    CheckDistinctOutputs({{"robot", c.attach.robot}, {"--out", c.attach.out}});
    c.outputs = {c.attach.out};
    return;
  }
  if (*plot_) {
    c.kind = CommandKind::kPlot;
    std::vector<std::pair<std::string, std::string>> files;
    for (const std::string& csv : c.plot_csvs) files.emplace_back("csv", csv);
    files.emplace_back("--out", c.out);
    CheckDistinctOutputs(files);
    c.outputs = {c.out};
    return;
  }
  if (*info_) {
    c.kind = CommandKind::kInfo;
    return;
  }
  if (*models_) {
    c.kind = CommandKind::kModels;
    return;
  }
  c.kind = CommandKind::kTables;
}

void CheckOutputs(const Command& c) {
  for (const std::string& path : c.outputs) CheckOutputPath(path);
  for (const std::string& dir : c.output_dirs) CheckOutputDirectory(dir);
}

}  // namespace mjstepper::tools
