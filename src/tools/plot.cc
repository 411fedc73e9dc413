#include "plot.h"

#include <fmt/format.h>

#include <cstdlib>
#include <stdexcept>

#include "installation.h"
#include "output_file.h"
#include "subprocess.h"

namespace mjstepper::tools {

std::string PlotProgram() {
  const char* python = std::getenv("MJSTEPPER_PYTHON");
  return FindProgram(python ? python : GetInstallation().python, "plotting",
                     "run scripts/bootstrap.sh, or set MJSTEPPER_PYTHON to a Python with "
                     "matplotlib");
}

void Plot(const std::string& kind, const std::vector<std::string>& csvs,
          const std::vector<std::string>& labels, const std::string& png, const std::string& title,
          bool versus_speed) {
  // No shell: each path and label is one argument. A path beginning with '-' is made relative
  // ("./-x") so that the script's argument parser cannot read it as an option; a label cannot be.
  std::vector<std::string> argv = {PlotProgram(), GetInstallation().plot_script, kind};
  for (const std::string& csv : csvs) argv.push_back(csv.starts_with('-') ? "./" + csv : csv);
  if (!labels.empty()) {
    argv.push_back("--labels");
    for (const std::string& label : labels) {
      if (label.starts_with('-')) {
        throw std::invalid_argument(
            fmt::format("--labels {}: a label cannot begin with '-'", label));
      }
      argv.push_back(label);
    }
  }
  if (!title.empty()) argv.insert(argv.end(), {"--title=" + title});
  if (versus_speed) argv.insert(argv.end(), {"--versus", "speed"});
  // The script draws into our exclusive temporary, seen by it as its descriptor 3.
  OutputFile out(png);
  argv.insert(argv.end(), {"--out", "/dev/fd/3"});
  if (RunProgram(argv, {.pass_fd = out.fd()}) != 0) {
    throw std::runtime_error(
        fmt::format("plotting {} failed (the plot script says why, above)", png));
  }
  out.Commit();
}

}  // namespace mjstepper::tools
