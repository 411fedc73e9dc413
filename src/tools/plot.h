// PNG plots of the tools' CSVs, drawn by src/tools/python/mjstepper_plot.py (matplotlib, installed
// into the project's venv by scripts/bootstrap.sh) in a child process started without a shell
// (subprocess.h), drawing into an OutputFile (output_file.h).
#ifndef MJSTEPPER_TOOLS_PLOT_H_
#define MJSTEPPER_TOOLS_PLOT_H_

#include <string>
#include <vector>

namespace mjstepper::tools {

/// The Python that plots ($MJSTEPPER_PYTHON, else the build's venv); throws naming it when it is
/// missing, so that a command can fail before its run rather than after.
std::string PlotProgram();

/// Plots a runner log (kind "log") or sweeps (kind "sweep", one label per CSV) into `png`.
/// Throws std::runtime_error naming `png` when the plotter fails (the script says why on stderr).
/// `versus_speed` (logs only): velocity errors against commanded speed instead of time.
void Plot(const std::string& kind, const std::vector<std::string>& csvs,
          const std::vector<std::string>& labels, const std::string& png,
          const std::string& title = "", bool versus_speed = false);

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_PLOT_H_
