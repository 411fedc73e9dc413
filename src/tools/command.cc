// The mjstepper command: every subcommand, from argv to its printed result and exit status. The
// program src/tools/main.cc and the Python package's `mjstepper` entry point both call Main.
#include "command.h"

#include <fmt/format.h>
#include <fmt/ostream.h>

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
#include <type_traits>
#include <variant>
#include <vector>

#include "cli.h"
#include "config.h"
#include "core/attributes.h"
#include "core/controllers/driver_chip.h"
#include "core/signals.h"
#include "core/substep.h"
#include "core/thermal.h"
#include "core/units.h"
#include "identify.h"
#include "installation.h"
#include "output_file.h"
#include "plot.h"
#include "runner.h"
#include "size.h"
#include "stepper_model.h"
#include "sweep.h"
#include "video_writer.h"

namespace mjstepper::tools {
namespace {

// The STEP/DIR table, StallGuard and heat of a drive that has them (issue 17).
void PrintDriverDetails(const DriveConfig& c) {
  std::visit(
      [&](const auto& unit) {
        if constexpr (requires { unit.table.peak_current; }) {
          fmt::print(
              "    STEP/DIR table: {} microsteps per full step ({:.4g} rad each), interpolation "
              "{}, peak {:.4g} A (√2·run_current after the chip's rounding)\n",
              unit.table.microsteps, StepAngle(c), unit.table.interpolate ? "on" : "off",
              unit.table.peak_current);
        }
        if constexpr (SwitchingUnit<std::decay_t<decltype(unit)>>) {
          if (const double f = SwitchingCycle(c); f > 0) {  // Hz
            fmt::print(
                "    chopper: fastest steady cycle {:.1f} kHz (its own rules, a tenth to all of "
                "the peak, drop within ±Vbus/2); at a step above 1/(2·f) = {:.3g} s the torque "
                "handed to MuJoCo is the currents' less their ripple, the last cycle's at the "
                "same time into it, which one sample per step would fold into the rotor "
                "(docs/coupling.md, \"The CoreXY after a move\")\n",
                f / 1e3, RoundDown3(0.5 / f));
          }
        }
        if constexpr (requires { unit.stallguard.version; }) {
          if (unit.stallguard.version != 0) {
            fmt::print(
                "    StallGuard{}: SG_RESULT 0..{:g} at Km·|ω|·cos δi / {:g} V, once per full "
                "step; "
                "no stall flag below {:.3g} rad/s ({:.1f} r/min); CoolStep {}\n",
                unit.stallguard.version, unit.stallguard.FullScale(),
                unit.stallguard.full_scale_emf, unit.stallguard.min_speed,
                RadPerSecToRpm(unit.stallguard.min_speed),
                unit.stallguard.semin > 0 ? "on" : "off");
          }
        }
      },
      c.controller);
  if (c.heat) {
    const ThermalNetwork network(c.heat->network);
    const auto tau = network.TimeConstants();  // s
    fmt::print(
        "    heat: winding and housing from {:g} °C (ambient {:g} °C), modes' time constants "
        "{:.1f} and "
        "{:.1f} min, {:.1f} K per W held; warning above {:g} °C (insulation class)\n",
        c.heat->initial_temperature, c.heat->ambient_temperature, tau[0] / 60, tau[1] / 60,
        network.SteadyRise(1.0)[0], c.heat->insulation_limit);
  }
}

int Info(const std::string& path) {
  const ToolJudgesTimestep judged;  // the verdict is printed below, whole
  const StepperModel sm = LoadStepperModel(path);
  const mjModel* m = sm.model.get();
  const double h = m->opt.timestep;
  fmt::print("{}: timestep {:g} s, {} stepper(s)\n", path, h, sm.steppers.size());
  // The modes at qpos0 with each stepper's T' (the resonances a speed excites).
  const std::vector<plugin::Mode> modes = plugin::ComputeModes(m, ModalSteppers(sm));
  for (size_t i = 0; i < sm.steppers.size(); ++i) {
    const StepperActuator& s = sm.steppers[i];
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
        "      → fn = (1/2π)·√(T'/J) = {:.2f} Hz with the other joints held (S-1..S-7)\n",
        s.name, ControllerName(s.config.controller),
        s.config.input == InputMode::kPosition   ? "position (ctrl in rad)"
        : s.config.input == InputMode::kVelocity ? "velocity (ctrl in rad/s)"
                                                 : "steps (ctrl in microsteps)",
        p.rotor_teeth, p.resistance, p.inductance, p.torque_constant, p.detent.size(),
        drive.RestCurrentMagnitude(), StiffnessFormula(s.config.controller), stiffness, inertia,
        fn);
    PrintDriverDetails(s.config);
    if (!(stiffness > 0)) {
      fmt::print("    no holding stiffness: something else must hold or turn the shaft\n");
      continue;
    }
    fmt::print(
        "    detent's worst-case stiffness Σ h·Nr·Kdh = {:.4g} N·m/rad (added to T' for the "
        "timestep rule)\n",
        r.detent_stiffness);
    const std::vector<ResonantSpeed> speeds = ResonantSpeeds(modes, i, s.config);
    fmt::print(
        "    resonant speeds n_h = 60·f/(h·Nr) (rotor r/min, h·Nr·n/60 = f: SPEC §2-3) of the "
        "modes it takes part in (>= {:g} % of the mode's potential energy in its T'):\n",
        100 * plugin::kMinParticipation);
    for (size_t k = 0; k < speeds.size();) {
      std::string line =
          fmt::format("      mode {} at {:.1f} Hz ({:.0f} % in its T'):", speeds[k].mode + 1,
                      speeds[k].frequency, 100 * speeds[k].participation);
      const int mode = speeds[k].mode;
      for (; k < speeds.size() && speeds[k].mode == mode; ++k) {
        line += fmt::format(" h = {} {:.1f} r/min;", speeds[k].order, speeds[k].speed);
      }
      line.back() = '\n';
      fmt::print("{}", line);
    }
    if (speeds.empty()) fmt::print("      none\n");
  }
  fmt::print(
      "  model: {} mode(s) at qpos0 (M; joint and tendon springs; the steppers' T'; equalities "
      "and limits active there held, contacts free):\n",
      modes.size());
  for (size_t k = 0; k < modes.size(); ++k) {
    fmt::print("    mode {} at {:.2f} Hz: {}{}\n", k + 1, modes[k].omega / kTwoPi,
               modes[k].stepper() ? "" : "non-stepper mode, ", modes[k].springs);
  }
  // The one timestep rule, as the plugin's load warning and run judge it.
  const TimestepVerdict verdict = CheckTimestep(sm);
  if (std::isinf(verdict.largest_timestep)) {
    const bool substepped =
        std::any_of(sm.steppers.begin(), sm.steppers.end(),
                    [](const StepperActuator& s) { return s.coupling == Coupling::kSubstepped; });
    fmt::print("  timestep {:g} s: no mode to resolve ({})\n", h,
               substepped ? "the steppers' springs are sub-stepped, and no other spring holds "
                            "the model"
                          : "no spring holds the model");
    if (substepped) {
      fmt::print(
          "  the sub-stepped coupling's fidelity is measured up to {:g} s (docs/coupling.md): "
          "use timestep <= {:g} s\n",
          kSubsteppedMeasuredStep, kSubsteppedMeasuredStep);
    }
  } else if (verdict.failed.empty()) {
    fmt::print(
        "  timestep {:g} s passes every mode with the detents' worst-case stiffness Σ h·Nr·Kdh "
        "added "
        "to T' (ω·h <= {:g}); the largest that does: {:.3g} s\n",
        h, verdict.max_omega_h, verdict.suggestion);
  } else {
    fmt::print("  {}: {}\n", verdict.refuse() ? "warning" : "note",
               verdict.Message("the model", "\n    "));
  }
  if (const std::string note = SubstepNote(sm); !note.empty()) fmt::print("  note: {}\n", note);
  if (const std::string warning = IntegratorWarning(m); !warning.empty())
    fmt::print("  warning: {}\n", warning);
  // A move's ringing after it, with STEP/DIR input: a finer step than the rule's, recommended
  // (core/timestep_rule.h, kRingingOmegaTimesStep), as run and size note it.
  if (std::isfinite(verdict.ringing_timestep)) {
    fmt::print(
        "  ringing after a move (STEP/DIR): the time of each torque change within a step moves "
        "it; a ringing that is a small remainder of the move's kicks (the CoreXY's) stays within "
        "5 % of a fine reference at ω·h <= {:g} on the fastest stepper mode ({:.1f} Hz): "
        "timestep <= {:.3g} s ({}); a larger one (the bed-slinger's Y) to ω·h = {:g} "
        "(docs/coupling.md)\n",
        kRingingOmegaTimesStep, verdict.ringing_frequency, verdict.ringing_timestep,
        verdict.ringing_exceeded() ? fmt::format("{:g} s does not", h)
                                   : fmt::format("{:g} s meets it", h),
        kRingingOmegaTimesStepLargeRing);
  }
  return 0;  // warnings inform; they do not fail the command
}

// `mjstepper models`: the example models, each runnable by name from any folder (FindModel).
int ListModels() {
  const std::string& dir = GetInstallation().models_dir;
  const std::vector<std::string> names = ExampleModels();
  if (names.empty()) {
    fmt::print(stderr, "mjstepper: no example models at '{}'\n", dir);
    return 1;
  }
  fmt::print("{} example models in {} (models/README.md there says what each is):\n", names.size(),
             dir);
  for (const std::string& name : names) fmt::print("  {}\n", name);
  return 0;
}

// The README tables, made from the tables the parser and the sensors use.
int WriteTables(const std::string& path) {
  const std::vector<std::pair<std::string, std::string>> sections = {
      {"presets", plugin::PresetTableMarkdown()}, {"drives", plugin::DriveListMarkdown()},
      {"drivers", DriverTableMarkdown()},         {"attributes", plugin::AttributeTableMarkdown()},
      {"signals", SignalTableMarkdown()},         {"options", OptionRangeTableMarkdown()},
      {"front-end", OptionListMarkdown()}};
  if (path.empty()) {
    for (const auto& [name, table] : sections) fmt::print("{}\n", table);
    return 0;
  }
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string text = buffer.str();
  int replaced = 0;
  for (const auto& [name, table] : sections) {
    const std::string begin = fmt::format("<!-- BEGIN {} -->\n", name);
    const std::string end = fmt::format("<!-- END {} -->", name);
    const size_t b = text.find(begin), e = text.find(end);
    if (b == std::string::npos && e == std::string::npos) continue;  // not this file's table
    if (b == std::string::npos || e == std::string::npos || e < b) {
      throw std::runtime_error(fmt::format("{}: unmatched {} ... {} markers", path, begin, end));
    }
    text.replace(b + begin.size(), e - b - begin.size(), table);
    ++replaced;
  }
  if (replaced == 0) throw std::runtime_error(fmt::format("{}: no <!-- BEGIN x --> markers", path));
  OutputFile out(path);  // never half-written
  out.Write(text.data(), text.size());
  out.Commit();
  fmt::print("wrote {}\n", path);
  return 0;
}

// The printed result of a subcommand that computed one (Execute), after its files are written.
void PrintResult(const Command& c, const Result& result, double seconds) {
  std::visit(
      [&](const auto& r) {
        using R = std::decay_t<decltype(r)>;
        if constexpr (std::is_same_v<R, RunResult>) {
          PrintSummary(r, c.run.log, std::cout);
          if (!c.run_plot.empty()) fmt::print("  plot: {}\n", c.run_plot);
        } else if constexpr (std::is_same_v<R, Identified>) {
          fmt::print("{}: identified from the torque turning '{}' at {}\n", c.identify.model,
                     c.identify.actuator, c.speeds_text);
          for (const DetentHarmonic& dh : r.harmonics) {
            fmt::print("  Kd{} = {:.5f} N·m, phi{} = {:+.4f} rad\n", dh.order, dh.amplitude,
                       dh.order, dh.phase);
          }
          fmt::print("  Fs = {:.5f} N·m, B = {:.6f} N·m·s/rad; fit residual {:.2e} N·m RMS\n",
                     r.static_friction, r.viscous_damping, r.residual_rms);
          fmt::print("  <config key=\"damping_detent\" value=\"{}\"/>\n", r.DampingDetent());
          fmt::print("  <config key=\"friction_compensation\" value=\"{:.5g}\"/>\n",
                     r.static_friction);
        } else if constexpr (std::is_same_v<R, ResonanceResult>) {
          const ResonanceOptions& o = c.resonance;
          fmt::print(
              "{}: {} axis, {:g}-{:g} Hz at {:g} Hz/s, {} accelerometer samples in {:.1f} s\n"
              "  the largest response at {:.1f} Hz\n",
              o.model, o.axis, o.test.min_freq, o.test.max_freq, o.test.hz_per_sec, r.samples,
              seconds, r.peak_frequency);
          // smoothing and max_accel by Klipper's definitions (shaper.h), max_accel rounded to
          // 100 mm/s² as Klipper prints it; the corner deviation is this project's own measure.
          fmt::print(
              "  (smoothing and max_accel as Klipper defines and prints them; corner: how far the "
              "shaped path cuts a square corner at 5000 mm/s²)\n");
          for (const ShaperFit& f : r.fits) {
            fmt::print(
                "  {:9} {:6.1f} Hz: remaining vibration {:5.1f} %, smoothing ~= {:.3f}, max_accel "
                "<= {:.0f} mm/s², corner {:.3f} mm\n",
                f.shaper.name, f.frequency, 100 * f.vibration, f.smoothing * 1000,
                std::round(f.max_accel * 1000 / 100) * 100, f.corner_deviation * 1000);
          }
          if (r.recommended >= 0) {
            const ShaperFit& best = r.fits[r.recommended];
            fmt::print(
                "  recommended: {} at {:.1f} Hz (shaper_type_{} = {}, shaper_freq_{} = {:.1f})\n",
                best.shaper.name, best.frequency, o.axis, best.shaper.name, o.axis, best.frequency);
          }
          for (const std::string& w : r.warnings) fmt::print(stderr, "warning: {}\n", w);
          fmt::print("  wrote {0}_raw.csv\n  wrote {0}_psd.csv\n  wrote {0}.png\n", c.out);
        } else if constexpr (std::is_same_v<R, AttachResult>) {
          fmt::print(
              "steppers on {} joint(s) of {}: {}; timestep {:.3g} s (the rule's largest); keyframe "
              "'start'\n  wrote {}\n",
              r.joints.size(), c.attach.robot, fmt::join(r.joints, ", "), r.timestep, r.out);
        } else if constexpr (std::is_same_v<R, SizeResult>) {
          PrintSizeTable(r, std::cout);
          fmt::print("  {:.1f} s; wrote {}.csv\n", seconds, c.out);
          for (const SizeJoint& j : r.joints) {
            const auto files = SizeJointOutputs(c.out, j.name);
            fmt::print("  wrote {}, {}, {}\n", files[2], files[0], files[1]);
          }
          if (!c.size.run.log.empty()) fmt::print("  wrote {}\n", c.size.run.log);
          if (!c.size.run.render.video.empty()) {
            fmt::print("  wrote {} ({} frames)\n", c.size.run.render.video, r.run.frames);
          }
        } else if constexpr (std::is_same_v<R, std::vector<MapPoint>>) {
          fmt::print("{} runs in {:.1f} s\n  wrote {}.csv\n  wrote {}.png\n", r.size(), seconds,
                     c.out, c.out);
        } else if constexpr (std::is_same_v<R, std::vector<PullOutPoint>>) {
          const auto best = std::max_element(
              r.begin(), r.end(),
              [](const PullOutPoint& a, const PullOutPoint& b) { return a.torque < b.torque; });
          const std::string carriage =
              std::isfinite(best->force) ? fmt::format(" ({:.1f} N at {:.1f} mm/s at the carriage)",
                                                       best->force, 1e3 * best->carriage_speed)
                                         : "";
          fmt::print(
              "{} speeds in {:.1f} s; highest pull-out torque {:.3f} N·m at {:.1f} r/min{}\n"
              "  wrote {}.csv\n  wrote {}.png\n",
              r.size(), seconds, best->torque, RadPerSecToRpm(best->speed), carriage, c.out, c.out);
        } else if constexpr (std::is_same_v<R, std::vector<SweepPoint>>) {
          const auto worst =
              std::max_element(r.begin(), r.end(), [](const SweepPoint& a, const SweepPoint& b) {
                return a.peak_to_peak_error < b.peak_to_peak_error;
              });
          const std::string carriage =
              std::isfinite(worst->carriage_speed)
                  ? fmt::format(", {:.1f} mm/s at the carriage", 1e3 * worst->carriage_speed)
                  : "";
          fmt::print(
              "{} speeds in {:.1f} s; largest velocity ripple {:.2f} r/min peak-to-peak at {:.1f} "
              "r/min ({:.1f} Hz{})\n  wrote {}.csv\n  wrote {}.png\n",
              r.size(), seconds, RadPerSecToRpm(worst->peak_to_peak_error),
              RadPerSecToRpm(worst->speed), worst->dominant_frequency, carriage, c.out, c.out);
        }
      },
      result);
}

// `mjstepper plot`: any CSV the tools write, as PNG.
int PlotCsvs(const Command& c) {
  std::ifstream first(c.plot_csvs[0]);
  std::string header;
  std::getline(first, header);
  const bool pullout_csv = header.find("pull_out_torque") != std::string::npos;
  const bool sweep_csv = !pullout_csv && header.rfind("speed[r/min]", 0) == 0;
  if (!sweep_csv && c.plot_csvs.size() != 1) {
    throw std::invalid_argument(
        "plot: give one run log or pull-out CSV, or any number of sweep CSVs");
  }
  Plot(pullout_csv ? "pullout"
       : sweep_csv ? "sweep"
                   : "log",
       c.plot_csvs, c.plot_labels, c.out, c.plot_title,
       c.versus_speed && !sweep_csv && !pullout_csv);
  fmt::print("wrote {}\n", c.out);
  return 0;
}

}  // namespace

void CheckPrograms(const Command& c) {
  if ((c.kind == CommandKind::kRun && !c.run.render.video.empty()) ||
      (c.kind == CommandKind::kSize && !c.size.run.render.video.empty())) {
    FfmpegProgram();
  }
  const bool plots = c.kind == CommandKind::kPlot ||
                     ((c.kind == CommandKind::kSweep || c.kind == CommandKind::kMap ||
                       c.kind == CommandKind::kPullOut || c.kind == CommandKind::kResonance ||
                       c.kind == CommandKind::kSize) &&
                      !c.out.empty()) ||
                     (c.kind == CommandKind::kRun && !c.run_plot.empty());
  if (plots) PlotProgram();
}

Result Execute(const Command& c, std::ostream& progress) {
  switch (c.kind) {
    case CommandKind::kRun:
      return Run(c.run, progress);
    case CommandKind::kSweep:
      return Sweep(c.sweep, progress);
    case CommandKind::kMap:
      return Map(c.map, progress);
    case CommandKind::kPullOut:
      return PullOut(c.pullout, progress);
    case CommandKind::kIdentify:
      return Identify(c.identify);
    case CommandKind::kResonance:
      return RunResonanceTest(c.resonance, progress);
    case CommandKind::kSize:
      return Size(c.size, progress);
    case CommandKind::kAttach:
      return Attach(c.attach);
    default:
      throw std::logic_error("Execute: this subcommand computes no result");
  }
}

void WriteOutputs(const Command& c, const Result& result) {
  std::visit(
      [&](const auto& r) {
        using R = std::decay_t<decltype(r)>;
        if constexpr (std::is_same_v<R, RunResult>) {
          if (!c.run_plot.empty()) Plot("log", {c.run.log}, {}, c.run_plot);
        } else if constexpr (std::is_same_v<R, ResonanceResult>) {
          // The two CSVs are written by the test itself (resonance.h).
          Plot("resonance", {c.out + "_psd.csv"}, {}, c.out + ".png",
               fmt::format("{}: resonance test, {} axis", c.resonance.model, c.resonance.axis));
        } else if constexpr (std::is_same_v<R, SizeResult>) {
          if (c.out.empty()) return;
          WriteSizeCsvs(c.out, r);
          for (const SizeJoint& j : r.joints) {
            const auto files = SizeJointOutputs(c.out, j.name);
            Plot("size", {files[0], files[1]}, {}, files[2],
                 fmt::format("{}: '{}' ({}, gear {:.4g}): demand against pull-out",
                             c.size.run.model, j.name, j.motor, j.gear));
          }
        } else if constexpr (std::is_same_v<R, std::vector<MapPoint>>) {
          if (c.out.empty()) return;
          WriteMapCsv(c.out + ".csv", c.map.parameter, r);
          Plot("map", {c.out + ".csv"}, {}, c.out + ".png",
               fmt::format("{}: velocity ripple over speed × {}", c.map.sweep.model,
                           c.map.parameter));
        } else if constexpr (std::is_same_v<R, std::vector<PullOutPoint>>) {
          if (c.out.empty()) return;
          WritePullOutCsv(c.out + ".csv", r);
          Plot("pullout", {c.out + ".csv"}, {}, c.out + ".png",
               fmt::format("{}: pull-out torque", c.pullout.model));
        } else if constexpr (std::is_same_v<R, std::vector<SweepPoint>>) {
          if (c.out.empty()) return;
          WriteSweepCsv(c.out + ".csv", r);
          Plot("sweep", {c.out + ".csv"}, {}, c.out + ".png",
               fmt::format("{}: constant-speed sweep", c.sweep.model));
        }
      },
      result);
}

int Main(int argc, const char* const* argv) {
  InstallInterruptCleanup();  // SIGINT, SIGTERM: no temporary left behind
  CommandLine cli;
  try {
    const Command& c = cli.Parse(argc, argv);
    // What must exist before any work: the outputs' places, and the programs the run will start.
    CheckOutputs(c);
    CheckPrograms(c);
    switch (c.kind) {
      case CommandKind::kTables:
        return WriteTables(c.tables_file);
      case CommandKind::kInfo:
        return Info(c.model);
      case CommandKind::kModels:
        return ListModels();
      case CommandKind::kPlot:
        return PlotCsvs(c);
      default: {
        const auto start = std::chrono::steady_clock::now();
        const Result result = Execute(c, std::cerr);
        WriteOutputs(c, result);
        PrintResult(
            c, result,
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        return 0;
      }
    }
  } catch (const CLI::ParseError& e) {
    return cli.Exit(e);
  } catch (const std::exception& e) {
    fmt::print(std::cerr, "mjstepper: {}\n", BoundedMessage(e.what()));
    return 1;
  }
}

}  // namespace mjstepper::tools
