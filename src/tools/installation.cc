#include "installation.h"

namespace mjstepper::tools {
namespace {

// A build tree's paths (CMakeLists.txt); the package build defines none and sets them at import.
#ifndef MJSTEPPER_PLUGIN_PATH
#define MJSTEPPER_PLUGIN_PATH ""
#endif
#ifndef MJSTEPPER_PYTHON
#define MJSTEPPER_PYTHON ""
#endif
#ifndef MJSTEPPER_PLOT_SCRIPT
#define MJSTEPPER_PLOT_SCRIPT ""
#endif

Installation& Current() {
  static Installation installation{.plugin_library = MJSTEPPER_PLUGIN_PATH,
                                   .python = MJSTEPPER_PYTHON,
                                   .plot_script = MJSTEPPER_PLOT_SCRIPT};
  return installation;
}

}  // namespace

const Installation& GetInstallation() { return Current(); }

void SetInstallation(const Installation& installation) { Current() = installation; }

}  // namespace mjstepper::tools
