// Where the tools find what they start or load at run time: the plugin library, the Python that
// draws plots and its script. A build tree's command uses the paths CMake gave it; the Python
// package (`pip install .`) sets its own at import (the library and script inside the package,
// the interpreter that imported it). $MJSTEPPER_PLUGIN and $MJSTEPPER_PYTHON override either.
#ifndef MJSTEPPER_TOOLS_INSTALLATION_H_
#define MJSTEPPER_TOOLS_INSTALLATION_H_

#include <string>

namespace mjstepper::tools {

struct Installation {
  std::string plugin_library;  ///< libmjstepper.so
  std::string python;          ///< a Python with matplotlib
  std::string plot_script;     ///< mjstepper_plot.py
};

/// The paths in force (the build's, or those given to SetInstallation).
const Installation& GetInstallation();

/// Replaces the paths; call before any tool runs (the Python package does at import).
void SetInstallation(const Installation& installation);

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_INSTALLATION_H_
