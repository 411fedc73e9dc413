// `mjstepper attach` (issue 29, item 2) on tests/tools/models/two_link.urdf: steppers onto a
// robot's named joints, their rotor inertia as armature, the timestep the rule recommends, a
// keyframe at qpos0; errors name the joint and the fix.
#include "attach.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "core/presets.h"
#include "stepper_model.h"

namespace mjstepper::tools {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

const std::string kRobot = MJSTEPPER_SOURCE_DIR "/tests/tools/models/two_link.urdf";

std::string OutPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          (name + "_" + std::to_string(::getpid()) + ".xml"))
      .string();
}

AttachOptions TwoSteppers(const std::string& out) {
  AttachOptions o;
  o.robot = kRobot;
  o.out = out;
  o.steppers = {ParseAttachStepper("yaw:motor=17hs19_2004s1,gear=10"),
                ParseAttachStepper("pitch:motor=17hs16_2004s1,driver=tmc5160,drive=stealthchop,"
                                   "gear=20,run_current=1.6,ihold=24,microsteps=32")};
  return o;
}

TEST(Attach, StepperOnEachNamedJointAtTheRulesTimestep) {
  const std::string out = OutPath("attach");
  const AttachResult r = Attach(TwoSteppers(out));
  EXPECT_THAT(r.joints, ::testing::ElementsAre("yaw", "pitch"));
  const StepperModel sm = LoadStepperModel(out);
  std::filesystem::remove(out);
  const mjModel* m = sm.model.get();
  ASSERT_EQ(sm.steppers.size(), 2u);
  for (const StepperActuator& s : sm.steppers) {
    const int joint = m->actuator_trnid[2 * s.actuator];
    EXPECT_STREQ(mj_id2name(m, mjOBJ_JOINT, joint), s.name.c_str());
    const std::string motor = s.name == "yaw" ? "17hs19_2004s1" : "17hs16_2004s1";
    EXPECT_EQ(m->actuator_armature[s.actuator], FindPreset(motor)->motor.rotor_inertia) << s.name;
    EXPECT_EQ(Gear(m, s), s.name == "yaw" ? 10 : 20);
  }
  EXPECT_STREQ(ControllerName(sm.steppers[1].config.controller), "stealthchop");
  EXPECT_EQ(Microsteps(sm.steppers[1].config.controller), 32);
  EXPECT_EQ(m->opt.integrator, mjINT_IMPLICITFAST);
  // The rule's timestep: its suggestion (the largest that passes every mode, rounded down to 3
  // digits), on the written file's own modes.
  EXPECT_EQ(m->opt.timestep, r.timestep);
  const TimestepVerdict verdict = CheckTimestep(sm);
  EXPECT_TRUE(verdict.failed.empty()) << verdict.Message("attach");
  EXPECT_EQ(m->opt.timestep, verdict.suggestion);
  // The keyframe at qpos0.
  const int key = mj_name2id(m, mjOBJ_KEY, "start");
  ASSERT_GE(key, 0);
  for (int i = 0; i < m->nq; ++i) EXPECT_EQ(m->key_qpos[key * m->nq + i], m->qpos0[i]);
}

TEST(Attach, ErrorsNameTheJointAndTheFix) {
  const std::string out = OutPath("attach_bad");
  AttachOptions o = TwoSteppers(out);
  o.steppers[0].joint = "elbow";
  try {
    Attach(o);
    ADD_FAILURE() << "an unknown joint was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("'elbow'"), HasSubstr("'yaw', 'pitch'")));
  }
  o = TwoSteppers(out);
  o.steppers[1].config["ihold"] = "40";
  try {
    Attach(o);
    ADD_FAILURE() << "ihold 40 was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("'pitch'"), HasSubstr("ihold"), HasSubstr("40")));
  }
  EXPECT_FALSE(std::filesystem::exists(out));  // nothing half-written
  for (const char* bad : {"yaw", "yaw:gear", ":motor=x", "yaw:gear=0", "yaw:gear=nan"}) {
    EXPECT_THROW(ParseAttachStepper(bad), std::invalid_argument) << bad;
  }
  // An MJCF robot whose joint already has an actuator of that name.
  o = TwoSteppers(out);
  Attach(o);
  o.robot = out;
  o.out = OutPath("attach_again");
  try {
    Attach(o);
    ADD_FAILURE() << "a second actuator named 'yaw' was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("already has an actuator named 'yaw'")));
  }
  std::filesystem::remove(out);
}

// A URDF's package:// mesh: refused without --meshdir, saying so; with it, the written model finds
// the mesh from another folder (its meshdir made absolute).
TEST(Attach, PackageMeshesNeedTheirFolder) {
  AttachOptions o;
  o.robot = MJSTEPPER_SOURCE_DIR "/tests/tools/models/mesh_link.urdf";
  o.out = OutPath("attach_mesh");
  o.steppers = {ParseAttachStepper("hinge:motor=17hs19_2004s1")};
  try {
    Attach(o);
    ADD_FAILURE() << "a package:// mesh was found without --meshdir";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("tetra.obj"), HasSubstr("--meshdir")));
  }
  o.meshdir = MJSTEPPER_SOURCE_DIR "/tests/tools/models/meshes";
  Attach(o);
  const StepperModel sm = LoadStepperModel(o.out);  // in the temporary folder
  std::filesystem::remove(o.out);
  EXPECT_EQ(sm.model->nmesh, 1);
  EXPECT_EQ(sm.steppers.size(), 1u);
}

}  // namespace
}  // namespace mjstepper::tools
