// Where the tools find what they start or load at run time: the plugin library, the Python that
// draws plots and its script. A build tree's command uses the paths CMake gave it; the Python
// package (`pip install .`) sets its own at import (the library and script inside the package,
// the interpreter that imported it). $MJSTEPPER_PLUGIN and $MJSTEPPER_PYTHON override either.
#ifndef MJSTEPPER_TOOLS_INSTALLATION_H_
#define MJSTEPPER_TOOLS_INSTALLATION_H_

#include <string>
#include <vector>

namespace mjstepper::tools {

struct Installation {
  std::string plugin_library;  ///< libmjstepper.so
  std::string python;          ///< a Python with matplotlib
  std::string plot_script;     ///< mjstepper_plot.py
  std::string models_dir;      ///< the example models (the clone's models/, the package's copy)
};

/// The paths in force (the build's, or those given to SetInstallation).
const Installation& GetInstallation();

/// Replaces the paths; call before any tool runs (the Python package does at import).
void SetInstallation(const Installation& installation);

/// A model file named on the command line (issue 32, item 6): `path` itself when it is a regular
/// file; else the installation's example model it names, by its path in the clone
/// ("models/tsui_rigid.xml", "models/prints/square20/mzv.map"), its file name ("tsui_rigid.xml")
/// or its name ("tsui_rigid"), so the examples run outside a clone; else "".
std::string FindModel(const std::string& path);

/// The installation's example models (*.xml in models_dir), by name, sorted.
std::vector<std::string> ExampleModels();

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_INSTALLATION_H_
