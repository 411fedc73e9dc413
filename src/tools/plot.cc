#include "plot.h"

#include <fmt/format.h>

#include <cstdlib>
#include <stdexcept>

namespace mjstepper::tools {
namespace {

// Single-quoted for /bin/sh: every ' becomes '\''.
std::string Quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') {
      out.append("'\\''");
    } else {
      out.push_back(c);
    }
  }
  out.push_back('\'');
  return out;
}

}  // namespace

void Plot(const std::string& kind, const std::vector<std::string>& csvs,
          const std::vector<std::string>& labels, const std::string& png, const std::string& title,
          bool versus_speed) {
  const char* python = std::getenv("MJSTEPPER_PYTHON");
  std::string command = fmt::format("{} {} {}", Quote(python ? python : MJSTEPPER_PYTHON),
                                    Quote(MJSTEPPER_PLOT_SCRIPT), kind);
  for (const std::string& csv : csvs) command += fmt::format(" {}", Quote(csv));
  if (!labels.empty()) {
    command += " --labels";
    for (const std::string& label : labels) command += fmt::format(" {}", Quote(label));
  }
  command += fmt::format(" --out {}", Quote(png));
  if (!title.empty()) command += fmt::format(" --title {}", Quote(title));
  if (versus_speed) command += " --versus speed";
  if (std::system(command.c_str()) != 0) {
    throw std::runtime_error(
        fmt::format("plotting {} failed (the plot script says why, above)", png));
  }
}

}  // namespace mjstepper::tools
