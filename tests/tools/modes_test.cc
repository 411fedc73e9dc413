// The model's modes (plugin/modes.h) and the one timestep rule as info, run and the plugin's load
// warning apply it (issue 19): the coupling's and the belt's resonant speeds against the two-mass
// closed forms; an equality constraint held; every failing mode named; the printed suggestion
// passes; a model without steppers runs; the plugin warns with the same numbers run refuses with.
#include "modes.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/drive.h"
#include "core/units.h"
#include "runner.h"
#include "stepper_model.h"

namespace mjstepper::tools {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

const std::string kSource = MJSTEPPER_SOURCE_DIR;

std::filesystem::path TempDir() {
  const auto dir =
      std::filesystem::temp_directory_path() / ("mjstepper_modes_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

RunOptions Options(const std::string& model, double duration) {
  RunOptions options;
  options.model = model;
  options.duration = duration;  // s
  options.progress = false;
  return options;
}

// A shipped model with its timestep replaced, written to a temporary file.
std::string WithTimestep(const std::string& model, const std::string& timestep) {
  std::string xml = ReadText(kSource + "/models/" + model + ".xml");
  const size_t at = xml.find("timestep=\"5e-5\"");
  if (at == std::string::npos) throw std::runtime_error(model + ": no timestep=\"5e-5\"");
  xml.replace(at, 15, "timestep=\"" + timestep + "\"");
  const auto path = TempDir() / (model + "_" + timestep + ".xml");
  std::ofstream(path) << xml;
  return path.string();
}

// The two ω² of rotor J1 held by k1 (to ground) and load J2 on k2 (to the rotor): the roots of
// J1·J2·ω⁴ − (J1·k2 + J2·(k1 + k2))·ω² + k1·k2 = 0, in Hz, slow first.
std::vector<double> TwoMassHz(double j1, double j2, double k1, double k2) {
  const double a = j1 * j2, b = -(j1 * k2 + j2 * (k1 + k2)), c = k1 * k2;
  const double root = std::sqrt(b * b - 4 * a * c);
  // The small root as c/(a·big) avoids the cancellation of −b − root.
  const double big = (-b + root) / (2 * a);
  return {std::sqrt(c / (a * big)) / kTwoPi, std::sqrt(big) / kTwoPi};
}

// 1e-9 relative: the symmetric eigensolver is accurate to about ε·cond ≈ 1e-13 here; a mode of the
// wrong inertia or stiffness (e.g. the rigid 81.8 Hz, or M[dof,dof] alone) is off by percents.
constexpr double kTolerance = 1e-9;

void ExpectSpeeds(const std::string& model, double j1, double j2, double k2) {
  const StepperModel sm = LoadStepperModel(kSource + "/models/" + model + ".xml");
  ASSERT_EQ(sm.steppers.size(), 1u);
  const DriveConfig& c = sm.steppers[0].config;
  const double k1 = Drive(c).HoldingStiffness();  // T', N·m/rad
  const std::vector<double> expected = TwoMassHz(j1, j2, k1, k2);
  const std::vector<plugin::Mode> modes = plugin::ComputeModes(sm.model.get(), ModalSteppers(sm));
  ASSERT_EQ(modes.size(), 2u);
  for (int k = 0; k < 2; ++k) {
    EXPECT_NEAR(modes[k].omega / kTwoPi, expected[k], kTolerance * expected[k]) << model << k;
  }
  // Both modes move the rotor: both give resonant speeds, for every detent order of the motor.
  const std::vector<ResonantSpeed> speeds = ResonantSpeeds(modes, 0, c);
  const std::vector<int> orders = ExcitationOrders(c);
  ASSERT_EQ(speeds.size(), 2 * orders.size()) << model;
  for (const ResonantSpeed& s : speeds) {
    const double n = 60.0 * expected[s.mode] / (s.order * c.motor.rotor_teeth);  // SPEC §2-3
    EXPECT_NEAR(s.speed, n, kTolerance * n) << model << " mode " << s.mode << " h " << s.order;
  }
  for (const ResonantSpeed& s : speeds) {
    std::printf("%s: mode %d %.4f Hz (closed form %.4f), %.0f %% in T', h = %d: %.3f r/min\n",
                model.c_str(), s.mode + 1, s.frequency, expected[s.mode], 100 * s.participation,
                s.order, s.speed);
  }
}

// The coupling (models/tsui_coupling.xml): rotor J1 = armature 0.36e-4 + the rotor body's 1e-9
// kg·m², load J2 = 0.72e-4 kg·m², coupling k2 = 50 N·m/rad, k1 = T'. Its slow mode (72.2 Hz) is the
// one the rotor slipped at in the issue (h = 1: 86.7 r/min), which info did not list.
TEST(Modes, CouplingSpeedsMatchTheTwoMassClosedForm) {
  ExpectSpeeds("tsui_coupling", 0.36e-4 + 1e-9, 0.72e-4, 50);
}

// The belt axis (models/belt_axis.xml): J1 = 0.36e-4 + 1e-9 kg·m², the carriage m·r² with m = 0.5
// kg, r = 6.366 mm, the belt k·r² with k = 2e4 N/m.
TEST(Modes, BeltSpeedsMatchTheTwoMassClosedForm) {
  const double r = 0.006366;
  ExpectSpeeds("belt_axis", 0.36e-4 + 1e-9, 0.5 * r * r, 2e4 * r * r);
}

// An equality constraint active at qpos0 is held: a follower joint tied to the rotor's (joint
// equality q2 = q1) with its own spring k leaves one mode, ω² = (T' + k)/(J1 + J2), where the
// unconstrained model would have two.
TEST(Modes, EqualityConstraintsAreHeld) {
  const std::string xml = R"(<mujoco><option timestep="5e-5"/>
  <extension><plugin plugin="mjstepper.stepper"/></extension>
  <worldbody>
    <body name="rotor"><joint name="shaft" type="hinge" axis="0 0 1"/>
      <inertial pos="0 0 0" mass="0.001" diaginertia="1e-9 1e-9 1e-9"/></body>
    <body name="follower" pos="0.1 0 0"><joint name="follower" type="hinge" axis="0 0 1"
        stiffness="10"/>
      <inertial pos="0 0 0" mass="0.1" diaginertia="2e-5 2e-5 2e-5"/></body>
  </worldbody>
  <equality><joint joint1="follower" joint2="shaft"/></equality>
  <actuator><plugin name="shaft" joint="shaft" plugin="mjstepper.stepper" armature="0.36e-4">
    <config key="motor" value="tsui2009"/><config key="input" value="velocity"/></plugin>
  </actuator></mujoco>)";
  const auto path = TempDir() / "equality.xml";
  std::ofstream(path) << xml;
  const StepperModel sm = LoadStepperModel(path.string());
  const double k1 = Drive(sm.steppers[0].config).HoldingStiffness();
  const std::vector<plugin::Mode> modes = plugin::ComputeModes(sm.model.get(), ModalSteppers(sm));
  ASSERT_EQ(modes.size(), 1u);
  const double expected = std::sqrt((k1 + 10) / (0.36e-4 + 1e-9 + 2e-5));
  EXPECT_NEAR(modes[0].omega, expected, kTolerance * expected);
  EXPECT_NEAR(modes[0].participation[0], k1 / (k1 + 10), 1e-9);  // energies split as stiffnesses
}

// Loads `path` with MuJoCo's warnings (the plugin's load check among them) kept in `warnings`.
StepperModel LoadCapturingWarnings(const std::string& path, std::vector<std::string>* warnings) {
  LoadPluginLibrary();
  static std::vector<std::string>* captured = nullptr;
  captured = warnings;
  void (*previous)(const char*) = mju_user_warning;
  mju_user_warning = [](const char* message) { captured->push_back(message); };
  StepperModel sm = LoadStepperModel(path);
  mju_user_warning = previous;
  return sm;
}

// At 1 ms the coupling fails both of its modes: run refuses once, naming both (the fast one,
// mostly the coupling's, and the slow one), their ω·h, and one suggestion; the plugin's load
// warning says the same in one line (Summary: the count, the fastest and the suggestion).
TEST(Modes, RunNamesEveryFailingModeAndThePluginAgrees) {
  const std::string path = WithTimestep("tsui_coupling", "1e-3");
  std::vector<std::string> warnings;
  const StepperModel sm = LoadCapturingWarnings(path, &warnings);
  const TimestepVerdict verdict = CheckTimestep(sm);
  ASSERT_EQ(verdict.failed.size(), 2u);
  ASSERT_FALSE(warnings.empty());
  for (const std::string& w : warnings) EXPECT_EQ(w, verdict.Summary("mjstepper"));

  RunOptions options = Options(path, 0.01);
  std::ostringstream progress;
  try {
    tools::Run(options, progress);
    ADD_FAILURE() << "a 1 ms step ran";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), verdict.Message(path) + ", or pass --allow-coarse");
    EXPECT_THAT(e.what(),
                AllOf(HasSubstr("too coarse for 2 mode(s)"),
                      HasSubstr("\n  mode 2 (joint 'coupling' 74 %, stepper 'shaft' 26 %): 263.4 "
                                "Hz, ω·h = 1.66 > 0.2"),
                      HasSubstr("\n  mode 1 (stepper 'shaft' 74 %, joint 'coupling' 26 %): 75.1 "
                                "Hz, ω·h = 0.472 > 0.2"),
                      HasSubstr("use timestep <= 0.00012 s")));
  }
  options.allow_coarse = true;
  EXPECT_NO_THROW(tools::Run(options, progress));
  EXPECT_THAT(progress.str(), HasSubstr("warning: " + verdict.Message(path)));
}

// A contact active at qpos0 is not held (plugin/modes.cc, Held): MuJoCo's compiler makes the
// first mjData, whose plugin init runs the load check, with contacts disabled, so holding them
// made the tools and the load warning judge different modes (PAROL6's base mesh touches link 1).
// Here a fast rotor's box rests in a world box; a slow rotor is free. At a step between the two
// modes' limits the fast mode fails in both, with the same message.
TEST(Modes, ContactsAtTheStartAreFreeAndThePluginAgrees) {
  const std::string xml = R"(<mujoco><option timestep="2e-4" integrator="implicitfast"/>
  <extension><plugin plugin="mjstepper.stepper"/></extension>
  <worldbody>
    <geom name="stop" type="box" size="0.05 0.05 0.01" pos="0 0 -0.01"/>
    <body name="fast"><joint name="fast" type="hinge" axis="0 0 1"/>
      <geom type="box" size="0.02 0.02 0.01" pos="0 0 0.005" mass="0.001"/></body>
    <body name="slow" pos="1 0 0"><joint name="slow" type="hinge" axis="0 0 1"/>
      <inertial pos="0 0 0" mass="1" diaginertia="1e-3 1e-3 1e-3"/></body>
  </worldbody>
  <actuator>
    <plugin name="fast" joint="fast" plugin="mjstepper.stepper" armature="8.2e-6">
      <config key="motor" value="17hs19_2004s1"/></plugin>
    <plugin name="slow" joint="slow" plugin="mjstepper.stepper" armature="8.2e-6">
      <config key="motor" value="17hs19_2004s1"/></plugin>
  </actuator></mujoco>)";
  const auto path = TempDir() / "contact.xml";
  std::ofstream(path) << xml;
  std::vector<std::string> warnings;
  const StepperModel sm = LoadCapturingWarnings(path.string(), &warnings);
  // The contact is there at qpos0 (the tools' data), and the fast rotor keeps its mode.
  const DataPtr d(mj_makeData(sm.model.get()));
  mj_forward(sm.model.get(), d.get());
  ASSERT_GT(d->ncon, 0);
  const TimestepVerdict verdict = CheckTimestep(sm);
  ASSERT_EQ(plugin::ComputeModes(sm.model.get(), ModalSteppers(sm)).size(), 2u);
  ASSERT_EQ(verdict.failed.size(), 1u) << verdict.Message("contact");
  EXPECT_THAT(verdict.Message("mjstepper", "; "), HasSubstr("stepper 'fast' 100 %"));
  ASSERT_FALSE(warnings.empty());
  for (const std::string& w : warnings) EXPECT_EQ(w, verdict.Summary("mjstepper"));
}

// The suggestion, as printed, passes: run accepts exactly it, and refuses the next 3-figure step.
TEST(Modes, PrintedSuggestionRuns) {
  const StepperModel coarse = LoadStepperModel(WithTimestep("tsui_coupling", "1e-3"));
  const TimestepVerdict verdict = CheckTimestep(coarse);
  const std::string printed = fmt::format("{:.3g}", verdict.suggestion);
  EXPECT_EQ(printed, "0.00012");
  const std::string at = WithTimestep("tsui_coupling", printed);
  EXPECT_TRUE(CheckTimestep(LoadStepperModel(at)).failed.empty());
  std::ostringstream progress;
  EXPECT_NO_THROW(tools::Run(Options(at, 0.002), progress));
  EXPECT_EQ(progress.str(), "");
  const std::string above = WithTimestep("tsui_coupling", "0.000121");
  EXPECT_THROW(tools::Run(Options(above, 0.002), progress), std::invalid_argument);
}

// Issue 20, item 2: the rule's limit comes from the measured fidelity of the coupling in use
// (core/coupling.h, MaxOmegaTimesStep; docs/coupling.md): ω·h <= 0.2 with the consistent coupling,
// 0.15 with the explicit one, whose velocity ripple is off by 1.3 % at 0.2. The same model asks for
// a step 0.75 times as long when its stepper is explicit, and info prints the limit in use.
TEST(Modes, TheRuleFollowsTheCouplingInUse) {
  const std::string path = WithTimestep("tsui_coupling", "1e-3");
  const TimestepVerdict consistent = CheckTimestep(LoadStepperModel(path));
  const TimestepVerdict explicit_ =
      CheckTimestep(LoadStepperModel(path, {ParseOverride("shaft.coupling=explicit")}));
  EXPECT_EQ(consistent.max_omega_h, 0.2);
  EXPECT_EQ(explicit_.max_omega_h, 0.15);
  EXPECT_NEAR(explicit_.largest_timestep / consistent.largest_timestep, 0.75, 1e-12);
  EXPECT_THAT(explicit_.Message(path), HasSubstr("ω·h <= 0.15"));
}

// A model without steppers (the issue: dm_control's manipulator, refused for its fingertip spring
// "because of the steppers' holding stiffness") runs; its too-fast spring is named as a
// non-stepper mode, in a warning.
TEST(Modes, ModelWithoutSteppersRunsWithItsStiffSpring) {
  const std::string xml = R"(<mujoco><option timestep="2e-3"/>
  <worldbody><body name="finger"><joint name="tip" type="hinge" axis="0 0 1" stiffness="1e3"/>
    <inertial pos="0 0 0" mass="0.01" diaginertia="1e-6 1e-6 1e-6"/></body></worldbody>
  </mujoco>)";
  const auto path = TempDir() / "finger.xml";
  std::ofstream(path) << xml;
  std::ostringstream progress;
  RunResult r;
  ASSERT_NO_THROW(r = tools::Run(Options(path.string(), 0.01), progress));
  EXPECT_EQ(r.steps, 5);
  EXPECT_THAT(progress.str(), AllOf(HasSubstr("non-stepper mode 1 (joint 'tip' 100 %): 5032.9 Hz"),
                                    HasSubstr("not refused"), Not(HasSubstr("holding stiffness"))));
}

}  // namespace
}  // namespace mjstepper::tools
