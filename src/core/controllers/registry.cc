#include "core/controllers/registry.h"

#include <algorithm>
#include <stdexcept>
#include <string_view>

namespace mjstepper {

std::vector<std::string> ControllerNames() {
  std::vector<std::string> names;
  ForEachControllerType([&]<class C>() { names.emplace_back(C::kName); });
  return names;
}

Controller MakeController(const std::string& name, const AttributeSource& attributes,
                          const MotorParams& motor, const DriveConstants& constants) {
  std::optional<Controller> made;
  ForEachControllerType([&]<class C>() {
    if (!made && name == C::kName) made = C::FromAttributes(attributes, motor, constants);
  });
  if (!made) throw std::out_of_range("unknown controller " + name);
  return *made;
}

std::vector<const AttributeSpec*> ControllerAttributes(const std::string& name) {
  std::vector<const AttributeSpec*> list;
  ForEachControllerType([&]<class C>() {
    if (name == C::kName) list = C::Attributes();
  });
  return list;
}

std::vector<const AttributeSpec*> AllControllerAttributes() {
  std::vector<const AttributeSpec*> all;
  ForEachControllerType([&]<class C>() {
    for (const AttributeSpec* spec : C::Attributes()) {
      if (std::find(all.begin(), all.end(), spec) == all.end()) all.push_back(spec);
    }
  });
  return all;
}

std::vector<std::string> ControllersReading(const std::string& attribute) {
  std::vector<std::string> names;
  ForEachControllerType([&]<class C>() {
    for (const AttributeSpec* spec : C::Attributes()) {
      if (attribute == spec->name) names.emplace_back(C::kName);
    }
  });
  return names;
}

SpeedFeedback DefaultSpeedFeedback(const Controller& c) {
  return std::visit(
      [](const auto& unit) { return std::decay_t<decltype(unit)>::kDefaultSpeedFeedback; }, c);
}

}  // namespace mjstepper
