// Issue 29, item 4: the gear train's efficiency (src/core/transmission.h) against the power
// balance. A Tsui rotor turns a joint through gear 10 at a constant 20 rad/s (rotor side):
//   forward:  a viscous load B on the joint; the load takes B·q̇² = η_f·τ·ω, so the motor's mean
//             torque is B·q̇/(gear·η_f): 1/η_f times the lossless one;
//   backward: a constant torque T on the joint drives it along the motion, the motor brakes; the
//             motor receives η_b of the load's power, its mean torque −η_b·(T − B·q̇)/gear.
// At rest (within the 1 rad/s band) the train passes the torque unchanged: a held load sits at
// the same load angle whatever the efficiency.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "test_model.h"

namespace mjstepper::testing {
namespace {

constexpr double kGear = 10;
constexpr double kSpeed = 20;           // rad/s at the rotor
constexpr double kJointDamping = 0.05;  // N·m·s/rad at the joint: 0.1 N·m at 2 rad/s

// One Tsui rotor without its detent (whose ripple reverses the torque, and with it the power's
// direction, within each cycle) on a joint (its own inertia 1e-4 kg·m²), gear 10, velocity input;
// `configs` added.
std::string Model(const std::string& configs) {
  const std::string actuator = fmt::format(
      R"(<plugin name="m1" joint="j1" plugin="mjstepper.stepper" gear="{}" armature="0.36e-4">)"
      R"({}{}</plugin>)",
      kGear, Config("input", "velocity") + Config("detent", "none"), configs);
  return fmt::format(R"(<mujoco>
  <option timestep="5e-5" integrator="implicitfast"/>
  <extension><plugin plugin="mjstepper.stepper"/></extension>
  <worldbody><body><joint name="j1" type="hinge" axis="0 0 1" damping="{}"/>
    <inertial pos="0 0 0" mass="1" diaginertia="1e-4 1e-4 1e-4"/></body></worldbody>
  <actuator>{}</actuator>
  <sensor><plugin plugin="mjstepper.stepper" objtype="actuator" objname="m1"/></sensor>
</mujoco>)",
                     kJointDamping, actuator);
}

// The motor's mean torque (N·m) over 0.2-0.4 s at kSpeed, with `applied` N·m on the joint.
double MeanMotorTorque(const std::string& configs, double applied) {
  std::string error;
  const ModelPtr m = LoadModel(Model(configs), &error);
  if (!m) {
    ADD_FAILURE() << error;
    return 0;
  }
  const DataPtr d(mj_makeData(m.get()));
  double sum = 0;
  int n = 0;
  while (d->time < 0.4) {
    d->ctrl[0] = kSpeed * std::min(1.0, d->time / 0.05);
    d->qfrc_applied[0] = applied;
    mj_step(m.get(), d.get());
    if (d->time > 0.2) {
      sum += d->sensordata[kTorqueTotal];
      ++n;
    }
  }
  EXPECT_NEAR(d->qvel[0], kSpeed / kGear, 0.05 * kSpeed / kGear);  // synchronous
  EXPECT_EQ(d->sensordata[kLostSteps], 0);
  return sum / n;
}

TEST(Transmission, ForwardTheMotorSuppliesTheLossBackwardTheTrainTakesIt) {
  // Forward: the joint's damping (and the actuator's: none here) is the load.
  const double lossless = MeanMotorTorque("", 0);
  const double lossy = MeanMotorTorque(Config("efficiency", "0.8"), 0);
  const double load = kJointDamping * kSpeed / kGear / kGear;  // N·m at the rotor, B·q̇/gear
  std::printf("forward: lossless %.5f N·m (B·q̇/gear = %.5f), η_f 0.8: %.5f (ratio %.4f)\n",
              lossless, load, lossy, lossy / lossless);
  // The lossless torque is the load; 1 %: what rings on from the ramp, in the mean.
  EXPECT_NEAR(lossless / load, 1.0, 0.01);
  EXPECT_NEAR(lossy / lossless, 1 / 0.8, 0.005);
  // Backward: 0.5 N·m at the joint along the motion against 0.1 N·m of damping: the motor brakes
  // with −(0.5 − 0.1)/gear = −0.04 N·m lossless, −η_b of it through the train.
  const double braking = MeanMotorTorque("", 0.5);
  const double braking_lossy =
      MeanMotorTorque(Config("efficiency", "0.8") + Config("backdrive_efficiency", "0.7"), 0.5);
  std::printf("backward: lossless %.5f N·m (expected %.5f), η_b 0.7: %.5f (ratio %.4f)\n", braking,
              -(0.5 - kJointDamping * kSpeed / kGear) / kGear, braking_lossy,
              braking_lossy / braking);
  EXPECT_NEAR(braking / (-(0.5 - kJointDamping * kSpeed / kGear) / kGear), 1.0, 0.01);
  EXPECT_NEAR(braking_lossy / braking, 0.7, 0.005);
}

// At rest the train passes the torque: a held 0.2 N·m (joint side) sits at one load angle.
TEST(Transmission, AHeldLoadIsTheSameWhateverTheEfficiency) {
  double angle[2] = {0, 0};
  for (int lossy = 0; lossy < 2; ++lossy) {
    std::string error;
    const ModelPtr m = LoadModel(Model(lossy ? Config("efficiency", "0.5") : ""), &error);
    ASSERT_TRUE(m) << error;
    const DataPtr d(mj_makeData(m.get()));
    while (d->time < 0.5) {
      d->ctrl[0] = 0;
      d->qfrc_applied[0] = 0.2 * std::min(1.0, d->time / 0.2);
      mj_step(m.get(), d.get());
    }
    angle[lossy] = d->sensordata[kLoadAngle];
  }
  EXPECT_NEAR(angle[1], angle[0], 1e-3 * std::abs(angle[0]));
  EXPECT_GT(std::abs(angle[0]), 0.01);
}

TEST(Transmission, EfficiencyOutsideItsRangeFailsLoad) {
  for (const char* bad : {"0", "1.2", "-0.5", "nan"}) {
    std::string error;
    EXPECT_FALSE(LoadModel(Model(Config("efficiency", bad)), &error)) << bad;
    EXPECT_THAT(error,
                ::testing::AllOf(::testing::HasSubstr("efficiency"), ::testing::HasSubstr(bad)));
  }
}

}  // namespace
}  // namespace mjstepper::testing
