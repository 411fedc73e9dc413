// Registers mjstepper.stepper when the shared library is loaded (mj_loadPluginLibrary, or linked).
#include <mujoco/mujoco.h>

#include <cstdio>
#include <string>

#include "stepper.h"

mjPLUGIN_LIB_INIT(mjstepper) {
  const std::string mismatch = mjstepper::plugin::VersionMismatch(mjVERSION_HEADER, mj_version());
  if (!mismatch.empty()) std::fprintf(stderr, "%s\n", mismatch.c_str());  // init fails too
  mjstepper::plugin::RegisterStepperPlugin();
}
