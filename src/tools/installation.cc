#include "installation.h"

#include <algorithm>
#include <filesystem>
#include <system_error>

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
#ifndef MJSTEPPER_MODELS_DIR
#define MJSTEPPER_MODELS_DIR ""
#endif

Installation& Current() {
  static Installation installation{.plugin_library = MJSTEPPER_PLUGIN_PATH,
                                   .python = MJSTEPPER_PYTHON,
                                   .plot_script = MJSTEPPER_PLOT_SCRIPT,
                                   .models_dir = MJSTEPPER_MODELS_DIR};
  return installation;
}

}  // namespace

const Installation& GetInstallation() { return Current(); }

void SetInstallation(const Installation& installation) { Current() = installation; }

namespace {

bool IsRegularFile(const std::filesystem::path& path) {
  std::error_code error;
  return std::filesystem::is_regular_file(path, error);
}

}  // namespace

std::string FindModel(const std::string& path) {
  if (IsRegularFile(path)) return path;
  const std::filesystem::path dir = Current().models_dir;
  if (dir.empty() || path.empty()) return "";
  std::filesystem::path relative(path);
  if (relative.is_absolute()) return "";
  if (auto first = relative.begin(); first != relative.end() && *first == "models") {
    relative = relative.lexically_relative("models");
  }
  if (relative.empty() || *relative.begin() == "..") return "";
  for (const std::filesystem::path& candidate :
       {dir / relative, dir / std::filesystem::path(relative).concat(".xml")}) {
    if (IsRegularFile(candidate)) return candidate.string();
  }
  return "";
}

std::vector<std::string> ExampleModels() {
  std::vector<std::string> names;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(Current().models_dir, error)) {
    if (entry.path().extension() == ".xml" && IsRegularFile(entry.path()))
      names.push_back(entry.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace mjstepper::tools
