// mjstepper._engine: the experiments of src/tools (one C++ function each) and the mjstepper
// command, bound for the Python package with nanobind (DESIGN.md §10).
//
// The Python front-end (python/mjstepper/__init__.py) turns its keyword arguments into the command
// line they stand for and hands it to `compute`, which parses and checks it with the command's own
// parser (cli.h), runs the experiment (command.h's Execute), writes the files asked for
// (WriteOutputs) and returns the result as columns: (name, unit, values) each, the units SI. So
// every check, default, bound and error message is the command's, and a result is the same
// double for double whichever front-end asked for it. `main` is the command itself (the wheel's
// `mjstepper` entry point); `write_outputs` writes a result assembled elsewhere (the Ray sweep's
// rows) through the same writers.
#include <fmt/format.h>
#include <nanobind/nanobind.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <initializer_list>
#include <iostream>
#include <optional>
#include <span>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>
#include <variant>
#include <vector>

#include "cancel.h"
#include "command.h"
#include "core/step_times.h"
#include "installation.h"
#include "options.h"

namespace nb = nanobind;

namespace mjstepper::tools {
namespace {

// One column of a result table: its name, its unit, and how a row holds it.
template <class Row>
struct Column {
  const char* name;
  const char* unit;
  double (*get)(const Row&);
  void (*set)(Row&, double);
};

// The result tables, one list of columns each (the Python Table's fields, in this order).
const Column<SweepPoint> kSweepColumns[] = {
    {"speed", "rad/s", [](const SweepPoint& p) { return p.speed; },
     [](SweepPoint& p, double v) { p.speed = v; }},
    {"rms_error", "rad/s", [](const SweepPoint& p) { return p.rms_error; },
     [](SweepPoint& p, double v) { p.rms_error = v; }},
    {"peak_to_peak_error", "rad/s", [](const SweepPoint& p) { return p.peak_to_peak_error; },
     [](SweepPoint& p, double v) { p.peak_to_peak_error = v; }},
    {"dominant_frequency", "Hz", [](const SweepPoint& p) { return p.dominant_frequency; },
     [](SweepPoint& p, double v) { p.dominant_frequency = v; }},
    {"lost_steps", "full steps", [](const SweepPoint& p) { return p.lost_steps; },
     [](SweepPoint& p, double v) { p.lost_steps = v; }},
    {"carriage_speed", "m/s (NaN: a rotary axis)",
     [](const SweepPoint& p) { return p.carriage_speed; },
     [](SweepPoint& p, double v) { p.carriage_speed = v; }}};

const Column<PullOutPoint> kPullOutColumns[] = {
    {"speed", "rad/s", [](const PullOutPoint& p) { return p.speed; },
     [](PullOutPoint& p, double v) { p.speed = v; }},
    {"torque", "N·m", [](const PullOutPoint& p) { return p.torque; },
     [](PullOutPoint& p, double v) { p.torque = v; }},
    {"slipped_unloaded", "bool",
     [](const PullOutPoint& p) { return p.slipped_unloaded ? 1.0 : 0.0; },
     [](PullOutPoint& p, double v) { p.slipped_unloaded = v != 0; }},
    {"held_max", "bool", [](const PullOutPoint& p) { return p.held_max ? 1.0 : 0.0; },
     [](PullOutPoint& p, double v) { p.held_max = v != 0; }},
    {"carriage_speed", "m/s (NaN: a rotary axis)",
     [](const PullOutPoint& p) { return p.carriage_speed; },
     [](PullOutPoint& p, double v) { p.carriage_speed = v; }},
    {"force", "N (NaN: a rotary axis)", [](const PullOutPoint& p) { return p.force; },
     [](PullOutPoint& p, double v) { p.force = v; }}};

const Column<StepperSummary> kSummaryColumns[] = {
    {"final_speed", "rad/s", [](const StepperSummary& s) { return s.final_speed; }, nullptr},
    {"rms_velocity_error", "rad/s", [](const StepperSummary& s) { return s.rms_velocity_error; },
     nullptr},
    {"max_velocity_error", "rad/s", [](const StepperSummary& s) { return s.max_velocity_error; },
     nullptr},
    {"max_load_angle", "electrical rad", [](const StepperSummary& s) { return s.max_load_angle; },
     nullptr},
    {"lost_steps", "full steps", [](const StepperSummary& s) { return s.lost_steps; }, nullptr},
    {"carriage_speed", "m/s (NaN: a rotary axis)",
     [](const StepperSummary& s) { return s.carriage_speed; }, nullptr},
    {"carriage_position", "m (NaN: a rotary axis)",
     [](const StepperSummary& s) { return s.carriage_position; }, nullptr}};

const Column<DetentHarmonic> kHarmonicColumns[] = {
    {"order", "1", [](const DetentHarmonic& h) { return double(h.order); }, nullptr},
    {"amplitude", "N·m", [](const DetentHarmonic& h) { return h.amplitude; }, nullptr},
    {"phase", "rad", [](const DetentHarmonic& h) { return h.phase; }, nullptr}};

const Column<ShaperFit> kFitColumns[] = {
    {"frequency", "Hz", [](const ShaperFit& f) { return f.frequency; }, nullptr},
    {"vibration", "1", [](const ShaperFit& f) { return f.vibration; }, nullptr},
    {"smoothing", "m", [](const ShaperFit& f) { return f.smoothing; }, nullptr},
    {"max_accel", "m/s²", [](const ShaperFit& f) { return f.max_accel; }, nullptr},
    {"corner_deviation", "m", [](const ShaperFit& f) { return f.corner_deviation; }, nullptr}};

const Column<SizeJoint> kSizeColumns[] = {
    {"gear", "rad per joint unit", [](const SizeJoint& j) { return j.gear; }, nullptr},
    {"bench_inertia", "kg·m²", [](const SizeJoint& j) { return j.bench_inertia; }, nullptr},
    {"peak_speed", "rad/s", [](const SizeJoint& j) { return j.peak_speed; }, nullptr},
    {"peak_torque", "N·m", [](const SizeJoint& j) { return j.peak_torque; }, nullptr},
    {"worst_time", "s", [](const SizeJoint& j) { return j.worst_time; }, nullptr},
    {"worst_speed", "rad/s", [](const SizeJoint& j) { return j.worst_speed; }, nullptr},
    {"worst_torque", "N·m", [](const SizeJoint& j) { return j.worst_torque; }, nullptr},
    {"worst_pullout", "N·m", [](const SizeJoint& j) { return j.worst_pullout; }, nullptr},
    {"margin", "1", [](const SizeJoint& j) { return j.margin; }, nullptr},
    {"lost_steps", "full steps", [](const SizeJoint& j) { return j.lost_steps + 0.0; }, nullptr},
    {"current_squared", "A²", [](const SizeJoint& j) { return j.current_squared; }, nullptr},
    {"winding_temperature_cycle", "°C",
     [](const SizeJoint& j) { return j.heat ? j.temperature_cycle : NAN; }, nullptr},
    {"winding_temperature_cycles", "°C",
     [](const SizeJoint& j) { return j.heat ? j.temperature : NAN; }, nullptr},
    {"winding_temperature_steady", "°C",
     [](const SizeJoint& j) { return j.heat ? j.temperature_steady : NAN; }, nullptr},
    {"insulation_limit", "°C", [](const SizeJoint& j) { return j.heat ? j.insulation_limit : NAN; },
     nullptr},
    {"rad_per_metre", "rotor rad per m of the carriage (NaN: a rotary joint)",
     [](const SizeJoint& j) { return j.rad_per_metre != 0 ? j.rad_per_metre : NAN; }, nullptr}};

// A column as Python's (name, unit, [values]).
nb::tuple PyColumn(const char* name, const char* unit, nb::list values) {
  return nb::make_tuple(nb::str(name), nb::str(unit), values);
}

template <class Row, size_t N>
void AppendColumns(nb::list& out, const Column<Row> (&columns)[N], std::span<const Row> rows) {
  for (const Column<Row>& c : columns) {
    nb::list values;
    for (const Row& r : rows) values.append(nb::float_(c.get(r)));
    out.append(PyColumn(c.name, c.unit, values));
  }
}

template <class Row, size_t N>
nb::list Columns(const Column<Row> (&columns)[N], std::span<const Row> rows) {
  nb::list out;
  AppendColumns(out, columns, rows);
  return out;
}

nb::list Floats(const std::vector<double>& v) {
  nb::list out;
  for (double x : v) out.append(nb::float_(x));
  return out;
}

// Columns of per-sample vectors (a trace's, a demand's): (name, unit, values) each.
struct SampleColumn {
  const char* name;
  const char* unit;
  const std::vector<double>* values;
};
nb::list SampleColumns(std::initializer_list<SampleColumn> columns) {
  nb::list out;
  for (const SampleColumn& c : columns) out.append(PyColumn(c.name, c.unit, Floats(*c.values)));
  return out;
}

// A map's parameter's unit: stiffness of a hinge (N·m/rad) or slide (N/m) joint, or a mass.
const char* ParameterUnit(const std::string& parameter) {
  return parameter.starts_with("mass:") ? "kg" : "N·m/rad or N/m";
}

nb::dict ToPython(const Command& c, const Result& result) {
  nb::dict out;
  std::visit(
      [&](const auto& r) {
        using R = std::decay_t<decltype(r)>;
        if constexpr (std::is_same_v<R, std::vector<SweepPoint>>) {
          out["table"] = Columns(kSweepColumns, std::span<const SweepPoint>(r));
        } else if constexpr (std::is_same_v<R, std::vector<PullOutPoint>>) {
          out["table"] = Columns(kPullOutColumns, std::span<const PullOutPoint>(r));
        } else if constexpr (std::is_same_v<R, std::vector<MapPoint>>) {
          nb::list columns, values;
          std::vector<SweepPoint> points;
          for (const MapPoint& p : r) {
            values.append(nb::float_(p.value));
            points.push_back(p.point);
          }
          columns.append(PyColumn("value", ParameterUnit(c.map.parameter), values));
          AppendColumns(columns, kSweepColumns, std::span<const SweepPoint>(points));
          out["table"] = columns;
          out["parameter"] = c.map.parameter;
        } else if constexpr (std::is_same_v<R, RunResult>) {
          nb::list names, profiles;
          for (const StepperSummary& s : r.steppers) {
            names.append(nb::str(s.name.c_str()));
            profiles.append(nb::str(s.profile.c_str()));
          }
          nb::list summary;
          summary.append(PyColumn("name", "", names));
          summary.append(PyColumn("profile", "", profiles));
          AppendColumns(summary, kSummaryColumns, std::span<const StepperSummary>(r.steppers));
          out["steppers"] = summary;
          nb::dict traces;
          for (size_t i = 0; i < r.traces.size() && i < r.steppers.size(); ++i) {
            const StepperTrace& t = r.traces[i];
            traces[nb::str(r.steppers[i].name.c_str())] =
                SampleColumns({{"time", "s", &t.time},
                               {"omega_cmd", "rad/s", &t.omega_cmd},
                               {"velocity_error", "rad/s", &t.velocity_error},
                               {"current_a", "A", &t.current_a},
                               {"load_angle", "electrical rad", &t.load_angle},
                               {"torque", "N·m", &t.torque},
                               {"winding_temperature", "°C", &t.winding_temperature}});
          }
          out["traces"] = traces;
          out["steps"] = r.steps;
          out["sim_time"] = r.sim_time;
          out["wall_time"] = r.wall_time;
          out["frames"] = r.frames;
        } else if constexpr (std::is_same_v<R, SizeResult>) {
          nb::list names, motors, drives;
          for (const SizeJoint& j : r.joints) {
            names.append(nb::str(j.name.c_str()));
            motors.append(nb::str(j.motor.c_str()));
            drives.append(nb::str(j.drive.c_str()));
          }
          nb::list table;
          table.append(PyColumn("joint", "", names));
          table.append(PyColumn("motor", "", motors));
          table.append(PyColumn("drive", "", drives));
          AppendColumns(table, kSizeColumns, std::span<const SizeJoint>(r.joints));
          out["table"] = table;
          nb::dict demands, curves;
          for (const SizeJoint& j : r.joints) {
            demands[nb::str(j.name.c_str())] =
                SampleColumns({{"time", "s", &j.time},
                               {"speed", "rad/s", &j.speed},
                               {"torque", "N·m", &j.torque},
                               {"motor_speed", "rad/s", &j.motor_speed},
                               {"motor_torque", "N·m", &j.motor_torque}});
            curves[nb::str(j.name.c_str())] =
                Columns(kPullOutColumns, std::span<const PullOutPoint>(j.pullout));
          }
          out["demand"] = demands;
          out["pullout"] = curves;
          out["cycle_time"] = r.cycle_time;
          out["cycles"] = r.cycles;
        } else if constexpr (std::is_same_v<R, AttachResult>) {
          nb::list joints;
          for (const std::string& j : r.joints) joints.append(nb::str(j.c_str()));
          out["out"] = r.out;
          out["timestep"] = r.timestep;
          out["joints"] = joints;
        } else if constexpr (std::is_same_v<R, Identified>) {
          out["harmonics"] =
              Columns(kHarmonicColumns, std::span<const DetentHarmonic>(r.harmonics));
          out["static_friction"] = r.static_friction;
          out["viscous_damping"] = r.viscous_damping;
          out["residual_rms"] = r.residual_rms;
          out["damping_detent"] = r.DampingDetent();
        } else if constexpr (std::is_same_v<R, ResonanceResult>) {
          nb::list psd;
          psd.append(PyColumn("frequency", "Hz", Floats(r.frequency)));
          psd.append(PyColumn("psd", "(m/s²)²/Hz", Floats(r.psd)));
          out["psd"] = psd;
          nb::list names;
          for (const ShaperFit& f : r.fits) names.append(nb::str(f.shaper.name.c_str()));
          nb::list fits;
          fits.append(PyColumn("shaper", "", names));
          AppendColumns(fits, kFitColumns, std::span<const ShaperFit>(r.fits));
          out["fits"] = fits;
          out["peak_frequency"] = r.peak_frequency;
          out["recommended"] = r.recommended >= 0
                                   ? nb::object(nb::str(r.fits[r.recommended].shaper.name.c_str()))
                                   : nb::none();
          out["samples"] = r.samples;
          nb::list warnings;
          for (const std::string& w : r.warnings) warnings.append(nb::str(w.c_str()));
          out["warnings"] = warnings;
        }
      },
      result);
  return out;
}

// Rows of `columns` (name → values, as Python gives them back) in a table's column order.
template <class Row, size_t N>
std::vector<Row> RowsFrom(const Column<Row> (&columns)[N], const nb::dict& values) {
  std::vector<Row> rows;
  bool first = true;  // the first column sets the length every other must have
  for (const Column<Row>& c : columns) {
    if (!values.contains(c.name)) {
      throw std::invalid_argument(fmt::format("write_outputs: no column '{}'", c.name));
    }
    const std::vector<double> v = nb::cast<std::vector<double>>(values[c.name]);
    if (first) rows.resize(v.size());
    first = false;
    if (v.size() != rows.size()) {
      throw std::invalid_argument(fmt::format("write_outputs: column '{}' has {} rows, not {}",
                                              c.name, v.size(), rows.size()));
    }
    for (size_t i = 0; i < v.size(); ++i) c.set(rows[i], v[i]);
  }
  return rows;
}

// A parsed and checked command from Python's argv (without the program's name).
struct Parsed {
  explicit Parsed(const std::vector<std::string>& args) : cli(/*out_optional=*/true) {
    std::vector<const char*> argv = {"mjstepper"};
    for (const std::string& a : args) argv.push_back(a.c_str());
    try {
      command = &cli.Parse(static_cast<int>(argv.size()), argv.data());
    } catch (const CLI::ParseError& e) {
      // CLI11's own words (an unknown option, a bound): as the command prints them.
      std::ostringstream out, err;
      cli.app().exit(e, out, err);
      std::string text = err.str().empty() ? out.str() : err.str();
      // The command's advice to run --help is not Python's: the message alone.
      if (const size_t help = text.find("Run with --help"); help != std::string::npos) {
        text.erase(help);
      }
      while (!text.empty() && text.back() == '\n') text.pop_back();
      throw std::invalid_argument(BoundedMessage(text.empty() ? std::string(e.what()) : text));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(BoundedMessage(e.what()));
    }
  }
  CommandLine cli;
  const Command* command = nullptr;
};

// Runs `work` (an experiment, the command) without the GIL on a thread of its own while the
// caller's thread looks for Python's signals every kSignalPoll (issue 33: Ctrl-C waited for the
// whole call, 13.5 s of a 200 s run, hours of a long one): a KeyboardInterrupt (or any signal
// handler's exception) asks the experiment to stop at its next step (cancel.h), waits for it, and
// is raised here. Its result, or its own exception.
template <class Work>
auto Interruptible(Work work) -> decltype(work()) {
  constexpr auto kSignalPoll = std::chrono::milliseconds(50);
  const CancelScope scope;
  std::optional<decltype(work())> result;
  std::exception_ptr error;
  std::atomic<bool> done{false};
  bool interrupted = false;
  {
    nb::gil_scoped_release release;  // other Python threads (and Ray's) run meanwhile
    std::thread worker([&] {
      try {
        result.emplace(work());
      } catch (...) {
        error = std::current_exception();
      }
      done = true;
    });
    while (!done) {
      std::this_thread::sleep_for(kSignalPoll);
      if (interrupted) continue;
      nb::gil_scoped_acquire acquire;
      if (PyErr_CheckSignals() != 0) {  // the handler raised: its exception is set
        interrupted = true;
        RequestCancel();
      }
    }
    worker.join();
  }
  if (interrupted) throw nb::python_error();  // the KeyboardInterrupt the handler set
  if (error) {
    // The experiment's own message, bounded as the command prints it (BoundedMessage).
    try {
      std::rethrow_exception(error);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(mjstepper::BoundedMessage(e.what()));
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(mjstepper::BoundedMessage(e.what()));
    }
  }
  return std::move(*result);
}

nb::dict Compute(const std::vector<std::string>& args, bool keep_traces) {
  const Parsed parsed(args);
  Command c = *parsed.command;
  c.run.keep_traces = keep_traces;  // a run's per-step records, for Python (no command option)
  CheckOutputs(c);
  CheckPrograms(c);
  const Result result = Interruptible([&] {
    Result r = Execute(c, std::cerr);
    WriteOutputs(c, r);
    return r;
  });
  return ToPython(c, result);
}

void WriteOutputsFrom(const std::vector<std::string>& args, const nb::dict& columns) {
  const Parsed parsed(args);
  const Command& c = *parsed.command;
  CheckOutputs(c);
  CheckPrograms(c);
  Result result;
  switch (c.kind) {
    case CommandKind::kSweep:
      result = RowsFrom(kSweepColumns, columns);
      break;
    case CommandKind::kPullOut:
      result = RowsFrom(kPullOutColumns, columns);
      break;
    case CommandKind::kMap: {
      const std::vector<SweepPoint> points = RowsFrom(kSweepColumns, columns);
      const std::vector<double> values = nb::cast<std::vector<double>>(columns["value"]);
      if (values.size() != points.size()) {
        throw std::invalid_argument("write_outputs: column 'value' has another length");
      }
      std::vector<MapPoint> rows;
      for (size_t i = 0; i < points.size(); ++i) rows.push_back({values[i], points[i]});
      result = rows;
      break;
    }
    default:
      throw std::invalid_argument("write_outputs: only sweep, map and pullout results");
  }
  nb::gil_scoped_release release;
  WriteOutputs(c, result);
}

}  // namespace
}  // namespace mjstepper::tools

NB_MODULE(_engine, m) {
  using namespace mjstepper::tools;
  m.doc() = "mjstepper's experiments and command (src/tools), bound from C++";
  m.def(
      "set_installation",
      [](std::string plugin_library, std::string python, std::string plot_script,
         std::string models_dir) {
        SetInstallation({std::move(plugin_library), std::move(python), std::move(plot_script),
                         std::move(models_dir)});
      },
      "Where the engine finds the plugin library, the plotting Python and its script.");
  m.def("find_model", &FindModel, nb::arg("path"),
        "The model file `path` names: itself when a file, else the example model of that path or "
        "name; \"\" when neither (installation.h).");
  m.def(
      "read_step_times",
      [](const std::string& path) {
        // The command's reader (core/step_times.h), the one reader of the format (issue 33: a
        // Python reader beside it took 1_0e-3, which this refuses).
        mjstepper::StepTimes steps = [&] {
          nb::gil_scoped_release release;
          return mjstepper::StepTimes::Read(path);
        }();
        std::vector<double> times(steps.size()), directions(steps.size());
        for (size_t k = 0; k < steps.size(); ++k) {
          times[k] = steps.TimeAt(k);
          directions[k] = steps.CountAt(k) - (k > 0 ? steps.CountAt(k - 1) : 0.0);
        }
        return nb::make_tuple(times, directions);
      },
      nb::arg("path"),
      "A step-time file as steps(FILE) reads it: (times in s, directions ±1); ValueError naming "
      "the file, the line and the rule.");
  m.def(
      "parse_speeds", [](const std::string& text) { return ParseSpeedList(text); }, nb::arg("text"),
      "A --speeds list (\"10:200:2.5rpm\", \"1,2rad/s\") in rad/s.");
  m.def(
      "main",
      [](const std::vector<std::string>& argv) {
        std::vector<const char*> pointers;
        for (const std::string& a : argv) pointers.push_back(a.c_str());
        return Interruptible(
            [&] { return Main(static_cast<int>(pointers.size()), pointers.data()); });
      },
      nb::arg("argv"), "The mjstepper command on argv (argv[0] the program's name); its status.");
  m.def("compute", &Compute, nb::arg("args"), nb::arg("keep_traces") = false,
        "Parses and checks a command line (without the program's name) as the command does, "
        "runs its experiment, writes the files it names, returns the result as columns (a run's "
        "per-step traces with keep_traces).");
  m.def(
      "check", [](const std::vector<std::string>& args) { const Parsed parsed(args); },
      nb::arg("args"), "Parses and checks a command line; raises ValueError naming what is wrong.");
  m.def(
      "options",
      [] {
        std::vector<std::tuple<std::string, std::string, std::string, bool>> rows;
        for (const OptionDoc& d : OptionDocs())
          rows.emplace_back(d.command, d.option, d.python, d.flag);
        return rows;
      },
      "Every subcommand's options as the command's parser declares them: (command, option, "
      "Python keyword, is a flag) each (README, \"Options of every front-end\").");
  m.def("write_outputs", &WriteOutputsFrom, nb::arg("args"), nb::arg("columns"),
        "Writes a sweep, map or pull-out result given as {column: values} to the files the "
        "command line names (its --out), as the command writes them.");
  // The most values any list option of the command takes (options.h): the Python front-end
  // bounds its sequences by it before it reads an item (issue 33).
  m.attr("max_items") = kMaxRuns;
  // std::invalid_argument arrives as ValueError, std::runtime_error as RuntimeError (nanobind).
}
