#include "config_overrides.h"

#include <fmt/format.h>
#include <tinyxml2.h>

#include <cstring>
#include <stdexcept>

namespace mjstepper::tools {
namespace {

using tinyxml2::XMLElement;

bool NameIs(const XMLElement* e, const std::string& name) {
  const char* n = e->Attribute("name");
  return n != nullptr && name == n;
}

// The element that holds the actuator's <config>s: its own <plugin>, or the <instance> it names.
XMLElement* ConfigHolder(XMLElement* root, const std::string& actuator) {
  for (XMLElement* section = root->FirstChildElement("actuator"); section != nullptr;
       section = section->NextSiblingElement("actuator")) {
    for (XMLElement* a = section->FirstChildElement("plugin"); a != nullptr;
         a = a->NextSiblingElement("plugin")) {
      if (!NameIs(a, actuator)) continue;
      const char* instance = a->Attribute("instance");
      if (instance == nullptr) return a;
      for (XMLElement* ext = root->FirstChildElement("extension"); ext != nullptr;
           ext = ext->NextSiblingElement("extension")) {
        for (XMLElement* p = ext->FirstChildElement("plugin"); p != nullptr;
             p = p->NextSiblingElement("plugin")) {
          for (XMLElement* i = p->FirstChildElement("instance"); i != nullptr;
               i = i->NextSiblingElement("instance")) {
            if (NameIs(i, instance)) return i;
          }
        }
      }
      throw std::runtime_error(fmt::format(
          "actuator '{}' uses instance '{}', which is not in this file", actuator, instance));
    }
  }
  throw std::runtime_error(
      fmt::format("no <plugin name=\"{}\"> in the <actuator> section of this file", actuator));
}

}  // namespace

ConfigOverride ParseOverride(const std::string& text) {
  const size_t dot = text.find('.');
  const size_t eq = text.find('=');
  if (dot == std::string::npos || eq == std::string::npos || dot == 0 || eq < dot + 2) {
    throw std::invalid_argument(
        fmt::format("--set {}: expected ACTUATOR.KEY=VALUE, e.g. shaft.damping=all", text));
  }
  return {text.substr(0, dot), text.substr(dot + 1, eq - dot - 1), text.substr(eq + 1)};
}

std::string ApplyOverrides(const std::string& path, const std::vector<ConfigOverride>& overrides) {
  tinyxml2::XMLDocument doc;
  if (doc.LoadFile(path.c_str()) != tinyxml2::XML_SUCCESS) {
    throw std::runtime_error(fmt::format("{}: {}", path, doc.ErrorStr()));
  }
  XMLElement* root = doc.FirstChildElement("mujoco");
  if (root == nullptr) throw std::runtime_error(fmt::format("{}: no <mujoco> element", path));
  for (const ConfigOverride& o : overrides) {
    XMLElement* holder = nullptr;
    try {
      holder = ConfigHolder(root, o.actuator);
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(
          fmt::format("--set {}.{}={}: {}: {}", o.actuator, o.key, o.value, path, e.what()));
    }
    XMLElement* config = holder->FirstChildElement("config");
    while (config != nullptr &&
           (config->Attribute("key") == nullptr || o.key != config->Attribute("key"))) {
      config = config->NextSiblingElement("config");
    }
    if (config == nullptr) {
      config = holder->InsertNewChildElement("config");
      config->SetAttribute("key", o.key.c_str());
    }
    config->SetAttribute("value", o.value.c_str());
  }
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return printer.CStr();
}

}  // namespace mjstepper::tools
