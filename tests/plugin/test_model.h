// Inline MJCF for plugin tests: rotors on hinge joints driven by mjstepper.stepper.
#ifndef MJSTEPPER_TESTS_PLUGIN_TEST_MODEL_H_
#define MJSTEPPER_TESTS_PLUGIN_TEST_MODEL_H_

#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "config.h"
#include "core/drive.h"
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
inline const int kOmega = SignalIndex("omega");

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

/// The 17HS19 bench rotor of the STEP/DIR tests: a hinge damped by `damping` (N·m·s/rad) with a
/// 1e-5 kg·m² body, a stepper "m1" with the rotor's 8.2e-6 kg·m² armature and `configs`, and its
/// signal sensor, at timestep h.
inline std::string BenchRotorModel(const std::string& configs, double damping, double timestep) {
  return fmt::format(R"(<mujoco>
  <option timestep="{}" integrator="implicitfast"/>
  <extension><plugin plugin="mjstepper.stepper"/></extension>
  <worldbody><body><joint name="j1" type="hinge" axis="0 0 1" damping="{}"/>
    <inertial pos="0 0 0" mass="0.1" diaginertia="1e-5 1e-5 1e-5"/></body></worldbody>
  <actuator><plugin name="m1" joint="j1" plugin="mjstepper.stepper" armature="8.2e-6">{}</plugin>
  </actuator>
  <sensor><plugin name="s" plugin="mjstepper.stepper" objtype="actuator" objname="m1"/></sensor>
</mujoco>)",
                     timestep, damping, configs);
}

/// A Tsui actuator on joint `joint`, armature and damping from the preset, extra <config>s.
inline std::string TsuiActuator(const std::string& name, const std::string& joint,
                                const std::string& configs) {
  return fmt::format(
      R"(<plugin name="{}" joint="{}" plugin="mjstepper.stepper" armature="0.36e-4" damping="0.001">{}</plugin>)",
      name, joint, configs);
}

/// The drive a stepper's <config> makes, from key/value pairs (the plugin's own parser); throws
/// std::invalid_argument with the parser's message when they do not parse.
inline Drive DriveFromConfig(const std::map<std::string, std::string>& kv) {
  const auto parsed = plugin::ParseConfig([&](const char* key) -> const char* {
    const auto it = kv.find(key);
    return it == kv.end() ? nullptr : it->second.c_str();
  });
  if (const std::string* error = std::get_if<std::string>(&parsed)) {
    throw std::invalid_argument(*error);
  }
  return Drive(std::get<DriveConfig>(parsed));
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

/// A shipped model's text (models/NAME).
inline std::string ShippedModel(const std::string& name) {
  std::ifstream file(std::string(MJSTEPPER_SOURCE_DIR "/models/") + name);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

/// A shipped model (models/NAME) with a signal sensor on actuator `actuator`, and `extra`
/// <config> elements added to that stepper.
inline std::string ShippedModelWithSignals(const std::string& name, const std::string& actuator,
                                           const std::string& extra = "") {
  std::string xml = ShippedModel(name);
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

/// models/tsui_coupling.xml's two-mass set-up (loads_test.cc, coupling_test.cc).
namespace two_mass {

// models/tsui_coupling.xml without its detent (whose torque would move the rest position off the
// command and ring the slow mode by itself): rotor J_r (armature), coupling spring k, load J_l;
// the motor holds the rotor with T' = Nr·Km·I.
constexpr double kRotorInertia = 0.36e-4;    // kg·m²
constexpr double kLoadInertia = 0.72e-4;     // kg·m²
constexpr double kCoupling = 50;             // N·m/rad
constexpr double kHolding = 50 * 0.3 * 1.9;  // Nr·Km·I, N·m/rad

// The two-mass eigenfrequencies, rad/s: det(K − ω²·M) = 0 with K = [[T' + k, −k], [−k, k]],
// M = diag(J_r, J_l): J_r·J_l·ω⁴ − (J_r·k + J_l·(T' + k))·ω² + T'·k = 0.
inline std::pair<double, double> TwoMassFrequencies() {
  const double a = kRotorInertia * kLoadInertia;
  const double b = -(kRotorInertia * kCoupling + kLoadInertia * (kHolding + kCoupling));
  const double c = kHolding * kCoupling;
  const double root = std::sqrt(b * b - 4 * a * c);
  return {std::sqrt((-b - root) / (2 * a)), std::sqrt((-b + root) / (2 * a))};
}

// Angular frequency, rad/s, from the zero crossings of x(t) about its equilibrium 0 (the
// oscillations decay, so the mean of a window is not the equilibrium).
inline double ZeroCrossingFrequency(const std::vector<double>& t, const std::vector<double>& x) {
  std::vector<double> crossings;
  for (size_t i = 0; i + 1 < x.size(); ++i) {
    if ((x[i] > 0) != (x[i + 1] > 0)) {
      crossings.push_back(t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i]));
    }
  }
  if (crossings.size() < 2) return 0;
  return std::numbers::pi * (crossings.size() - 1) / (crossings.back() - crossings.front());
}

}  // namespace two_mass

}  // namespace mjstepper::testing

#endif  // MJSTEPPER_TESTS_PLUGIN_TEST_MODEL_H_
