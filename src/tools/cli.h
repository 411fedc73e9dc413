// The mjstepper command line: every subcommand, option and bound, parsed and checked in one place
// before any work (the command, its tests and the command-line fuzzer all use this parser). No
// MuJoCo here: what needs the model (a timestep, an actuator's name) is checked when it loads.
#ifndef MJSTEPPER_TOOLS_CLI_H_
#define MJSTEPPER_TOOLS_CLI_H_

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "attach.h"
#include "identify.h"
#include "options.h"
#include "output_file.h"
#include "resonance.h"
#include "runner.h"
#include "size.h"
#include "sweep.h"

namespace mjstepper::tools {

enum class CommandKind {
  kRun,
  kSweep,
  kMap,
  kPullOut,
  kIdentify,
  kResonance,
  kSize,
  kAttach,
  kPlot,
  kInfo,
  kModels,
  kTables
};

/// A parsed, checked command.
struct Command {
  CommandKind kind = CommandKind::kInfo;
  RunOptions run;
  std::string run_plot;  ///< PNG of the run's log; empty: none
  SweepOptions sweep;
  MapOptions map;
  PullOutOptions pullout;
  IdentifyOptions identify;
  ResonanceOptions resonance;
  SizeOptions size;
  AttachOptions attach;
  std::string speeds_text;  ///< --speeds as given (sweep, map, pullout, identify)
  std::string out;          ///< output prefix (sweep, map, pullout) or PNG (plot)
  std::vector<std::string> plot_csvs, plot_labels;
  std::string plot_title;
  bool versus_speed = false;
  std::string model;  ///< info
  std::string tables_file;
  std::vector<std::string> outputs;      ///< files the command will write
  std::vector<std::string> output_dirs;  ///< folders it will write into (--frames)
};

/// Checks, before any work, that each output may be written (output_file.h), making missing
/// parent folders. (Parse only reads the file system.)
void CheckOutputs(const Command& command);

/// One option of one subcommand, as the parser declares it: the one list of the front-ends'
/// options (README, "Options of every front-end"; the Python package's keywords are checked
/// against it).
struct OptionDoc {
  std::string command;  ///< subcommand: run, sweep, …
  std::string option;   ///< "--duration", or a positional argument's name ("model")
  std::string python;   ///< the Python keyword: the name with '_' for '-' ("log_every")
  bool flag = false;    ///< takes no value (Python: True or False)
  bool positional = false;
  bool required = false;
  std::string help;  ///< what it does, as --help says
};

/// Every subcommand's options (no --help), in the parser's order.
std::vector<OptionDoc> OptionDocs();
/// OptionDocs as a Markdown table, one row per option name: its subcommands, its Python keyword
/// and what it does (`mjstepper tables`).
std::string OptionListMarkdown();

class CommandLine {
 public:
  /// `out_optional`: sweep, map and pull-out compute without --out (the Python package returns
  /// their results; the command writes them, so there --out is required).
  explicit CommandLine(bool out_optional = false);
  CommandLine(const CommandLine&) = delete;
  CommandLine& operator=(const CommandLine&) = delete;

  /// Parses and checks argv. Throws CLI::ParseError (including --help: Exit prints it) for what
  /// CLI11 checks (unknown options, a bound of an option), std::invalid_argument for the rest,
  /// each naming the option and its bound.
  const Command& Parse(int argc, const char* const* argv);
  /// Prints a CLI::ParseError as CLI11 does; its exit status.
  /// Prints what CLI11 says of `e` (help and --version to stdout, a usage error to stderr) and
  /// returns the exit status: 0 for help and --version, 2 for a malformed command line (README,
  /// "Exit status").
  /// Prints a parse error (its message bounded: BoundedMessage) or the help, as CLI11 does; the
  /// exit status (0 for --help, else kUsageExit).
  int Exit(const CLI::ParseError& e);
  static constexpr int kUsageExit = 2;
  CLI::App& app() { return app_; }

 private:
  void Check();  // after CLI11: what its validators cannot see alone

  CLI::App app_;
  Command c_;
  CLI::App *run_, *sweep_, *map_, *pullout_, *identify_, *resonance_, *size_cmd_, *attach_, *plot_,
      *info_, *models_, *tables_;
  // Raw texts parsed by Check.
  std::vector<std::string> ctrl_, sets_, masses_, loads_, moves_, move_speeds_, move_accels_,
      attach_steppers_;
  std::string size_ = "1280x720", vary_, axis_;
  double accel_per_hz_ = 75;  // mm/s² per Hz, as Klipper states it
  int accel_range_ = 16;      // g
  double accel_noise_ = 290;  // µg/√Hz on X and Y
  bool quiet_ = false, no_overlay_ = false, allow_coarse_ = false;  // flags of several
};

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_CLI_H_
