// The mjstepper command as functions: parse (cli.h), check, Execute the experiment, WriteOutputs,
// print. The program (main.cc) runs Main; the Python package (src/python/engine.cc) parses the same
// command line from its keyword arguments, then calls Execute and, when asked for files,
// WriteOutputs: one engine, one parser, one set of checks for every front-end.
#ifndef MJSTEPPER_TOOLS_COMMAND_H_
#define MJSTEPPER_TOOLS_COMMAND_H_

#include <iosfwd>
#include <variant>
#include <vector>

#include "cli.h"

namespace mjstepper::tools {

/// What an experiment computes: run, sweep, map, pull-out, identify, resonance test, sizing.
using Result =
    std::variant<RunResult, std::vector<SweepPoint>, std::vector<MapPoint>,
                 std::vector<PullOutPoint>, Identified, ResonanceResult, SizeResult, AttachResult>;

/// Checks that the programs the command will start (ffmpeg, the plotting Python) are there,
/// before any work; throws naming the missing one.
void CheckPrograms(const Command& command);

/// Runs the experiment the command names (not info, plot or tables): progress on `progress`.
/// Throws std::invalid_argument / std::runtime_error with a message for the user.
Result Execute(const Command& command, std::ostream& progress);

/// The files a command writes after its experiment: CSVs and PNGs under --out (none without one),
/// a run's --plot. (A run's log, video and accelerometer log are written while it runs.)
void WriteOutputs(const Command& command, const Result& result);

/// Parses argv (argv[0] the program's name), runs the subcommand, prints its result; the exit
/// status: 0, or non-zero after printing why. Installs the SIGINT/SIGTERM cleanup of temporaries.
int Main(int argc, const char* const* argv);

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_COMMAND_H_
