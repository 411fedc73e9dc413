#include "attach.h"

#include <fmt/format.h>
#include <mujoco/mujoco.h>
#include <tinyxml2.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "config.h"
#include "core/presets.h"
#include "output_file.h"
#include "stepper.h"
#include "stepper_model.h"

namespace mjstepper::tools {
namespace {

using tinyxml2::XMLElement;

// The robot's hinge and slide joints, for messages.
std::string MovableJoints(const mjModel* m) {
  std::string names;
  for (int j = 0; j < m->njnt; ++j) {
    if (m->jnt_type[j] != mjJNT_HINGE && m->jnt_type[j] != mjJNT_SLIDE) continue;
    const char* name = mj_id2name(m, mjOBJ_JOINT, j);
    names += fmt::format("{}'{}'", names.empty() ? "" : ", ", name ? name : "");
  }
  return names.empty() ? "none" : names;
}

// The spec's XML (MuJoCo's own writer); the spec must have compiled.
std::string SaveXml(const mjSpec* spec) {
  std::vector<char> xml(1 << 20);
  char error[1024] = "";
  for (int tries = 0; tries < 8; ++tries) {
    const int needed =
        mj_saveXMLString(spec, xml.data(), static_cast<int>(xml.size()), error, sizeof(error));
    if (needed == 0) return std::string(xml.data());
    if (needed < 0) throw std::runtime_error(fmt::format("writing the MJCF: {}", error));
    xml.resize(static_cast<size_t>(needed) + 1);
  }
  throw std::runtime_error("writing the MJCF: the text kept growing");
}

}  // namespace

AttachResult Attach(const AttachOptions& o) {
  if (o.steppers.empty()) {
    throw std::invalid_argument("attach: name at least one joint with --stepper JOINT:...");
  }
  CheckOutputPath(o.out);
  LoadPluginLibrary();
  char error[1024] = "";
  SpecPtr spec(mj_parseXML(o.robot.c_str(), nullptr, error, sizeof(error)));
  if (!spec) throw std::runtime_error(fmt::format("{}: {}", o.robot, error));
  if (!o.meshdir.empty()) {  // each mesh by its base name in --meshdir (package:// URIs)
    for (mjsElement* e = mjs_firstElement(spec.get(), mjOBJ_MESH); e != nullptr;
         e = mjs_nextElement(spec.get(), e)) {
      mjsMesh* mesh = mjs_asMesh(e);
      const std::string file = mjs_getString(mesh->file);
      mjs_setString(mesh->file, std::filesystem::path(file).filename().string().c_str());
    }
    mjs_setString(spec->compiler.meshdir,
                  std::filesystem::absolute(o.meshdir).lexically_normal().string().c_str());
  }
  // The robot as it is, for its joints and its qpos0.
  ModelPtr robot;
  try {
    robot = CompileSpec(spec.get());
  } catch (const std::runtime_error& e) {
    const bool missing_file = std::string(e.what()).find("Error opening file") != std::string::npos;
    throw std::runtime_error(fmt::format(
        "{}: {}{}", o.robot, e.what(),
        missing_file && o.meshdir.empty()
            ? "; a robot whose meshes are package:// URIs (a URDF's) needs --meshdir DIR, the "
              "folder that holds them"
            : ""));
  }
  // Asset folders made absolute when the output lies elsewhere, so that it finds the robot's
  // meshes, textures and height fields.
  const std::filesystem::path base = std::filesystem::absolute(o.robot).parent_path();
  if (std::filesystem::absolute(o.out).parent_path() != base) {
    for (const auto& [dir, count] :
         {std::pair{spec->compiler.meshdir, robot->nmesh + robot->nhfield},
          std::pair{spec->compiler.texturedir, robot->ntex}}) {
      const std::string given = mjs_getString(dir);
      if (count > 0 && !std::filesystem::path(given).is_absolute()) {
        mjs_setString(dir, (base / given).lexically_normal().string().c_str());
      }
    }
  }
  // The robot's own MJCF (MuJoCo's writer), to which the steppers are added as elements. (Not
  // through MjSpec: mjs_setPluginAttributes takes a std::map across the library boundary, and the
  // wheel's libmujoco is not built with our standard library; the config overrides edit the XML
  // the same way, config_overrides.cc.)
  tinyxml2::XMLDocument doc;
  if (doc.Parse(SaveXml(spec.get()).c_str()) != tinyxml2::XML_SUCCESS) {
    throw std::runtime_error(
        fmt::format("{}: MuJoCo's MJCF of it did not parse: {}", o.robot, doc.ErrorStr()));
  }
  XMLElement* root = doc.RootElement();
  auto child = [&](XMLElement* parent, const char* name) {
    XMLElement* e = parent->FirstChildElement(name);
    return e != nullptr ? e : parent->InsertEndChild(doc.NewElement(name))->ToElement();
  };
  XMLElement* extension = child(root, "extension");
  XMLElement* declared = extension->InsertEndChild(doc.NewElement("plugin"))->ToElement();
  declared->SetAttribute("plugin", plugin::kPluginName);
  XMLElement* actuators = child(root, "actuator");
  AttachResult result;
  for (const AttachStepper& s : o.steppers) {
    const int joint = mj_name2id(robot.get(), mjOBJ_JOINT, s.joint.c_str());
    if (joint < 0 ||
        (robot->jnt_type[joint] != mjJNT_HINGE && robot->jnt_type[joint] != mjJNT_SLIDE)) {
      throw std::invalid_argument(
          fmt::format("--stepper {}: {} has no hinge or slide joint named '{}'; its joints: {}",
                      s.joint, o.robot, s.joint, MovableJoints(robot.get())));
    }
    if (std::find(result.joints.begin(), result.joints.end(), s.joint) != result.joints.end()) {
      throw std::invalid_argument(
          fmt::format("--stepper {}: joint '{}' given twice", s.joint, s.joint));
    }
    if (mj_name2id(robot.get(), mjOBJ_ACTUATOR, s.joint.c_str()) >= 0) {
      throw std::invalid_argument(
          fmt::format("--stepper {}: {} already has an actuator named '{}'; remove it or rename it",
                      s.joint, o.robot, s.joint));
    }
    // The rotor's inertia as the actuator's armature: the attribute's, else the preset's.
    double rotor_inertia = 0;  // kg·m²
    if (const auto it = s.config.find("rotor_inertia"); it != s.config.end()) {
      ParseFiniteDouble(it->second, &rotor_inertia);  // the plugin checks it
    } else {
      const auto motor = s.config.find("motor");
      const std::string name = motor == s.config.end() ? "tsui2009" : motor->second;
      const std::optional<Preset> preset = FindPreset(name);
      if (!preset) {
        throw std::invalid_argument(
            fmt::format("--stepper {}: motor = {} for joint '{}': unknown preset; known: {}",
                        s.joint, name, s.joint, fmt::join(PresetNames(), ", ")));
      }
      rotor_inertia = preset->motor.rotor_inertia;
    }
    XMLElement* a = actuators->InsertEndChild(doc.NewElement("plugin"))->ToElement();
    a->SetAttribute("name", s.joint.c_str());
    a->SetAttribute("joint", s.joint.c_str());
    a->SetAttribute("plugin", plugin::kPluginName);
    a->SetAttribute("gear", fmt::format("{:.17g}", s.gear).c_str());
    a->SetAttribute("armature", fmt::format("{:.17g}", rotor_inertia).c_str());
    // Whatever the robot's default class says of actuators: a stepper's ctrl is an angle, a speed
    // or a count, unlimited, and it has no activation (dm_control's manipulator.xml makes every
    // actuator ctrllimited by default).
    a->SetAttribute("ctrllimited", "false");
    a->SetAttribute("dyntype", "none");
    for (const auto& [key, value] : s.config) {
      XMLElement* config = a->InsertEndChild(doc.NewElement("config"))->ToElement();
      config->SetAttribute("key", key.c_str());
      config->SetAttribute("value", value.c_str());
    }
    result.joints.push_back(s.joint);
  }
  // A keyframe at qpos0, where the drives start at rest.
  XMLElement* key = child(root, "keyframe")->InsertEndChild(doc.NewElement("key"))->ToElement();
  key->SetAttribute("name", "start");
  std::string qpos;
  for (int i = 0; i < robot->nq; ++i)
    qpos += fmt::format("{}{:.17g}", i ? " " : "", robot->qpos0[i]);
  key->SetAttribute("qpos", qpos.c_str());
  XMLElement* option = child(root, "option");
  option->SetAttribute("integrator", "implicitfast");
  // Checked at a step far below any the rule could ask for, so that the plugin's load warning
  // about the robot's own (coarse) timestep does not precede the answer.
  option->SetAttribute("timestep", "1e-6");
  auto text = [&] {
    tinyxml2::XMLPrinter printer;
    doc.Print(&printer);
    return std::string(printer.CStr());
  };
  // The plugin checks every attribute as it loads (naming it and its value); then the timestep
  // the rule recommends, on the robot with its steppers at its start.
  const StepperModel sm = LoadStepperModel(o.robot, {}, text());
  const TimestepVerdict verdict = CheckTimestep(sm);  // at qpos0, as the plugin's load check
  // The rule's suggestion (its largest, rounded down to 3 digits: it passes), or the robot's own
  // timestep when nothing holds it (no mode). The plugin's load check judges the written file on
  // the same modes (contacts free in both: plugin/modes.cc, Held).
  result.timestep = std::isfinite(verdict.suggestion) && verdict.suggestion > 0
                        ? verdict.suggestion
                        : robot->opt.timestep;
  option->SetAttribute("timestep", fmt::format("{:.3g}", result.timestep).c_str());
  const std::string xml = text();
  OutputFile out(o.out);
  out.Write(xml.data(), xml.size());
  out.Commit();
  result.out = o.out;
  return result;
}

}  // namespace mjstepper::tools
