// Inline MJCF for plugin tests: rotors on hinge joints driven by mjstepper.stepper.
#ifndef MJSTEPPER_TESTS_PLUGIN_TEST_MODEL_H_
#define MJSTEPPER_TESTS_PLUGIN_TEST_MODEL_H_

#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include "core/signals.h"

namespace mjstepper::testing {

// Signal offsets in a stepper sensor's sensordata, from the signal table.
inline const int kCurrentA = SignalIndex("current_a");
inline const int kCurrentB = SignalIndex("current_b");
inline const int kCurrentD = SignalIndex("current_d");
inline const int kVoltageA = SignalIndex("voltage_a");
inline const int kThetaCmd = SignalIndex("theta_cmd");
inline const int kCurrentRefA = SignalIndex("current_ref_a");
inline const int kCurrentRefB = SignalIndex("current_ref_b");
inline const int kVoltageB = SignalIndex("voltage_b");
inline const int kTorqueEm = SignalIndex("torque_em");
inline const int kTorqueDetent = SignalIndex("torque_detent");
inline const int kTorqueTotal = SignalIndex("torque_total");
inline const int kLoadAngle = SignalIndex("load_angle");
inline const int kLostSteps = SignalIndex("lost_steps");
inline const int kEnergyInput = SignalIndex("energy_input");
inline const int kEnergyCopper = SignalIndex("energy_copper");
inline const int kEnergyMechanical = SignalIndex("energy_mechanical");

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

/// `joints` rotors j1..jN (negligible body inertia), with the given actuator, extension and
/// sensor sections, timestep h and implicitfast.
inline std::string RotorModel(const std::string& actuators, const std::string& extension = "",
                              const std::string& sensors = "", int joints = 1,
                              double timestep = 5e-5, const std::string& joint_attrs = "") {
  std::string bodies;
  for (int j = 1; j <= joints; ++j) {
    bodies +=
        fmt::format(R"(<body name="r{0}"><joint name="j{0}" type="hinge" axis="0 0 1" {1}/>)"
                    R"(<inertial pos="0 0 0" mass="0.001" diaginertia="1e-9 1e-9 1e-9"/></body>)",
                    j, joint_attrs);
  }
  return fmt::format(R"(<mujoco>
  <option timestep="{}" integrator="implicitfast"/>
  <extension><plugin plugin="mjstepper.stepper">{}</plugin></extension>
  <worldbody>{}</worldbody>
  <actuator>{}</actuator>
  <sensor>{}</sensor>
</mujoco>)",
                     timestep, extension, bodies, actuators, sensors);
}

/// A Tsui actuator on joint `joint`, armature and damping from the preset, extra <config>s.
inline std::string TsuiActuator(const std::string& name, const std::string& joint,
                                const std::string& configs) {
  return fmt::format(
      R"(<plugin name="{}" joint="{}" plugin="mjstepper.stepper" armature="0.36e-4" damping="0.001">{}</plugin>)",
      name, joint, configs);
}

inline std::string Config(const std::string& key, const std::string& value) {
  return fmt::format(R"(<config key="{}" value="{}"/>)", key, value);
}

/// Loads through mj_loadXML (from an in-memory VFS), the path a C user takes.
inline ModelPtr LoadModel(const std::string& xml, std::string* error = nullptr) {
  mjVFS vfs;
  mj_defaultVFS(&vfs);
  mj_addBufferVFS(&vfs, "model.xml", xml.data(), static_cast<int>(xml.size()));
  char buffer[2048] = "";
  ModelPtr m(mj_loadXML("model.xml", &vfs, buffer, sizeof(buffer)));
  mj_deleteVFS(&vfs);
  if (error != nullptr) *error = buffer;
  return m;
}

/// A shipped model (models/NAME) with a signal sensor on actuator `actuator`, and `extra`
/// <config> elements added to that stepper.
inline std::string ShippedModelWithSignals(const std::string& name, const std::string& actuator,
                                           const std::string& extra = "") {
  std::ifstream file(std::string(MJSTEPPER_SOURCE_DIR "/models/") + name);
  std::stringstream text;
  text << file.rdbuf();
  std::string xml = text.str();
  if (!extra.empty()) {
    const size_t config = xml.find("<config key=\"motor\"");
    xml.insert(config, extra);
  }
  xml.replace(xml.rfind("</mujoco>"), 9,
              fmt::format(R"(<sensor><plugin plugin="mjstepper.stepper" objtype="actuator" )"
                          R"(objname="{}"/></sensor></mujoco>)",
                          actuator));
  return xml;
}

}  // namespace mjstepper::testing

#endif  // MJSTEPPER_TESTS_PLUGIN_TEST_MODEL_H_
