// `mjstepper size` (issue 20, item 4) on tests/tools/models/size_rotor.xml, a NEMA 17 turning a
// disc, against closed forms: the demand during a trapezoid's acceleration is J·A, the pull-out
// torque at rest is the holding torque √2·Km·I_rated, the margin is 1 − |τ|/T_po, a load the motor
// cannot accelerate loses steps, and the winding's temperature after N cycles is that of N cycles
// simulated.
#include "size.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "cancel.h"
#include "runner.h"
#include "stepper_model.h"
#include "sweep.h"

namespace mjstepper::tools {
namespace {

using ::testing::HasSubstr;

const std::string kRotor = MJSTEPPER_SOURCE_DIR "/tests/tools/models/size_rotor.xml";
constexpr double kInertia = 1e-4 + 8.2e-6;  // kg·m², the disc about its axis plus the armature
constexpr double kAccel = 200;              // rad/s², the model's profile_accel
constexpr double kHolding = 0.59;           // N·m, 17HS19-2004S1's datasheet: √2·Km·(2 A)

// 0 → 2 rad → 0 in the drive's trapezoid: two triangles of 2·√(2 rad/200 rad/s²) = 0.2 s (peak
// 20 rad/s), each pose held 0.1 s: a cycle of 0.6 s.
SizeOptions Rotor() {
  SizeOptions o;
  o.run.model = kRotor;
  o.run.progress = false;
  o.moves["shaft"] = "2rad";
  o.dwell = 0.1;
  o.pullout_points = 4;
  return o;
}

double Mean(const std::vector<double>& v, const std::vector<double>& t, double from, double to) {
  double sum = 0;
  int n = 0;
  for (size_t k = 0; k < v.size(); ++k) {
    if (t[k] >= from && t[k] <= to) sum += v[k], ++n;
  }
  return sum / n;
}

// Size() on a copy of the rotor model with `attributes` added to its actuator (after the
// armature) and `configs` (<config> elements) to its plugin; the copy is removed however Size()
// ends.
SizeResult SizeWithAttributes(const std::string& attributes, const std::string& configs = "") {
  std::ifstream in(kRotor);
  std::stringstream text;
  text << in.rdbuf();
  std::string xml = text.str();
  const std::string armature = R"(armature="8.2e-6")";
  const size_t at = xml.find(armature);
  if (at == std::string::npos) throw std::logic_error(kRotor + ": no " + armature);
  xml.insert(at + armature.size(), attributes);
  xml.insert(xml.find("</plugin>"), configs);
  struct Copy {
    std::filesystem::path path;
    ~Copy() {
      std::error_code ignored;
      std::filesystem::remove(path, ignored);
    }
  } copy{std::filesystem::temp_directory_path() /
         ("size_rotor_" + std::to_string(::getpid()) + ".xml")};
  std::ofstream(copy.path) << xml;
  SizeOptions o = Rotor();
  o.run.model = copy.path.string();
  return Size(o, std::cerr);
}

TEST(Size, DemandIsInertiaTimesAccelerationAndPullOutAtRestIsTheHoldingTorque) {
  const SizeResult r = Size(Rotor(), std::cerr);
  EXPECT_NEAR(r.cycle_time, 0.6, 1e-9);  // the drive's own plan: 0.2 + 0.1 + 0.2 + 0.1 s
  ASSERT_EQ(r.joints.size(), 1u);
  const SizeJoint& j = r.joints[0];
  // Over the middle of the first acceleration (0.02-0.08 s) the torque accelerates the rotor and
  // disc: J·A = 0.0216 N·m. The motor's: 3 %, the microstep ripple left in a 60 ms mean; the
  // rotor's inertia alone (8.2e-6) would be 13× less.
  // The demand is mj_inverse's J·A exactly; the motor's simulated torque (10 ms means) is it up
  // to the ripple.
  EXPECT_NEAR(Mean(j.torque, j.time, 0.02, 0.08), kInertia * kAccel, 1e-9);
  const double torque = Mean(j.motor_torque, j.time, 0.02, 0.08);
  std::printf("demand while accelerating %.5f N·m, J·A = %.5f N·m; pull-out at rest %.4f N·m\n",
              torque, kInertia * kAccel, j.pullout.front().torque);
  EXPECT_NEAR(torque / (kInertia * kAccel), 1.0, 0.03);
  // And against the motion while braking (0.12-0.18 s).
  EXPECT_NEAR(Mean(j.motor_torque, j.time, 0.12, 0.18) / (-kInertia * kAccel), 1.0, 0.03);
  EXPECT_NEAR(j.peak_speed, 20, 0.02);  // rad/s: the triangle's peak, sampled at the steps
  // The bench holds up to the peak of the sine torque, √2·Km·I (S-4 at δ = π/2), and never more
  // (issue 29 item 6: the load when the slip was counted read 2-5 % above it). Below it by at
  // most 2 %: the motor's torque is a 10 ms mean while the load rises 0.5 N·m/s (0.4 %), and the
  // PI loop's current error as the rotor leaves.
  EXPECT_LE(j.pullout.front().torque, kHolding);
  EXPECT_GT(j.pullout.front().torque, 0.98 * kHolding);
  EXPECT_NEAR(j.bench_inertia, kInertia, 1e-12);
  // The margin is the least of 1 − |τ|/T_po over the move, T_po linear in speed between points.
  double least = 1;
  for (size_t k = 0; k < j.time.size(); ++k) {
    const double s = std::abs(j.speed[k]);
    auto hi = std::find_if(j.pullout.begin(), j.pullout.end(),
                           [s](const PullOutPoint& p) { return p.speed >= s; });
    ASSERT_NE(hi, j.pullout.end());
    double pullout = hi->torque;
    if (hi != j.pullout.begin()) {
      const auto lo = hi - 1;
      pullout = lo->torque + (s - lo->speed) / (hi->speed - lo->speed) * (hi->torque - lo->torque);
    }
    least = std::min(least, 1 - std::abs(j.torque[k]) / pullout);  // within the curve here
  }
  EXPECT_DOUBLE_EQ(j.margin, least);
  EXPECT_NEAR(j.margin, 1 - std::abs(j.worst_torque) / j.worst_pullout, 1e-12);
  EXPECT_GT(j.margin, 0.5);
  EXPECT_EQ(j.lost_steps, 0);
}

// The actuator's damping is in the bench's pull-out curve (the torque left beyond it), so the
// demand leaves it out: with B = 0.01 N·m·s/rad (0.1 N·m at 10 rad/s, five times J·A) the demand
// while accelerating is still J·A.
TEST(Size, TheActuatorsDampingIsCountedInTheCurveNotTheDemand) {
  const SizeResult r = SizeWithAttributes(R"( damping="0.01")");
  const SizeJoint& j = r.joints[0];
  EXPECT_NEAR(Mean(j.torque, j.time, 0.02, 0.08), kInertia * kAccel, 1e-9);
}

// A force-limited actuator applies at most its forcerange, and so does its bench: with the range
// ±0.3 N·m the pull-out at rest is 0.3 N·m, not the motor's 0.59, plus what the load's ramp adds
// while the clamped rotor drifts to the slip the bench counts: under a net torque growing at the
// ramp's rate r the rotor covers a full step (2π/200 rad) in t = (6·J·θ/r)^(1/3) = 36 ms, in which
// the load grows by r·t = 0.016 N·m (+5 %); 10 % allowed.
TEST(Size, TheBenchKeepsTheActuatorsForceRange) {
  const SizeResult r = SizeWithAttributes(R"( forcelimited="true" forcerange="-0.3 0.3")");
  const SizeJoint& j = r.joints[0];
  std::printf("pull-out at rest with forcerange ±0.3 N·m: %.4f N·m\n", j.pullout.front().torque);
  EXPECT_GE(j.pullout.front().torque, 0.3);
  EXPECT_LT(j.pullout.front().torque, 0.33);
}

// Issue 29 item 1: a driver chip with the drive's own profile loads and is sized, here the
// TMC5160 of PAROL6 in StealthChop (and in SpreadCycle): its pull-out at rest is the holding
// torque at the current the chip regulates, √2·Km·I_run with I_run = 2 A rounded to the
// TMC5160's GLOBALSCALER step (167/256 of 3.064 A: 1.999 A), never above it; 3 % below for the
// chopper's current ripple around its target and the 10 ms mean.
TEST(Size, ADriverChipWithTheDrivesProfileIsSized) {
  for (const char* drive : {"stealthchop", "spreadcycle"}) {
    SCOPED_TRACE(drive);
    const SizeResult r = SizeWithAttributes(
        "", fmt::format(R"(<config key="driver" value="tmc5160"/><config key="drive" )"
                        R"(value="{}"/><config key="microsteps" value="32"/>)",
                        drive));
    ASSERT_EQ(r.joints.size(), 1u);
    const SizeJoint& j = r.joints[0];
    EXPECT_EQ(j.drive, drive);
    const double holding = kHolding * (167.0 / 256 * 0.325 / 0.075 / std::sqrt(2.0)) / 2.0;
    std::printf("%s: pull-out at rest %.4f N·m (holding %.4f), margin %.3f, lost %g\n", drive,
                j.pullout.front().torque, holding, j.margin, j.lost_steps);
    EXPECT_LE(j.pullout.front().torque, holding);
    EXPECT_GT(j.pullout.front().torque, 0.97 * holding);
    EXPECT_EQ(j.lost_steps, 0);
    EXPECT_GT(j.margin, 0.5);
  }
}

// Names with a comma or a quote stay one CSV field.
TEST(Size, TheTableQuotesItsNames) {
  SizeResult r;
  SizeJoint j;
  j.name = R"(wrist, "roll")";
  j.motor = "m";
  j.drive = "d";
  r.joints.push_back(j);
  const auto prefix =
      std::filesystem::temp_directory_path() / ("size_quoted_" + std::to_string(::getpid()));
  WriteSizeCsvs(prefix.string(), r);
  std::ifstream in(prefix.string() + ".csv");
  std::string header, row;
  std::getline(in, header);
  std::getline(in, row);
  EXPECT_TRUE(row.starts_with(R"("wrist, ""roll""",m,d,)")) << row;
  for (const std::string& file : SizeJointOutputs(prefix.string(), j.name)) {
    std::filesystem::remove(file);
  }
  std::filesystem::remove(prefix.string() + ".csv");
}

TEST(Size, ALoadTheMotorCannotAccelerateLosesStepsBeyondItsCurve) {
  SizeOptions o = Rotor();
  o.run.masses["disc"] = 20;  // 40 × the disc: J·A = 0.80 N·m, beyond the 0.59 N·m it holds
  const SizeResult r = Size(o, std::cerr);
  const SizeJoint& j = r.joints[0];
  std::printf("40x disc: margin %.3f, lost %+g full steps\n", j.margin, j.lost_steps);
  EXPECT_NE(j.lost_steps, 0);
  // Beyond the curve at the worst point: J·A = 0.80 N·m against the 0.59 N·m it holds at rest
  // lacks 1 − 0.59/0.80 = 26 % of the demand (measured: 23 %, where the bench's curve is a little
  // above its value at rest); asserted: more than 20 %.
  EXPECT_LT(j.margin, -0.2);
  EXPECT_GE(j.margin, -1.0);
  EXPECT_NEAR(j.margin, (j.worst_pullout - std::abs(j.worst_torque)) / std::abs(j.worst_torque),
              1e-12);
}

TEST(Size, TheWindingAfterNCyclesIsThatOfNCyclesSimulated) {
  SizeOptions o = Rotor();
  o.cycles = 5;
  const SizeResult r = Size(o, std::cerr);
  const SizeJoint& j = r.joints[0];
  ASSERT_TRUE(j.heat);
  // The same five cycles, simulated: the targets of size's cycle, repeated.
  RunOptions run;
  run.model = kRotor;
  run.progress = false;
  run.keep_traces = true;
  run.duration = 5 * r.cycle_time;
  std::string targets = "targets(2rad";
  for (int k = 0; k < 5; ++k) {
    if (k > 0) targets += fmt::format(", 2rad@{:.17g}s", k * r.cycle_time + r.pose_times[0]);
    targets += fmt::format(", 0rad@{:.17g}s", k * r.cycle_time + r.pose_times[1]);
  }
  run.ctrl["shaft"] = targets + ")";
  const RunResult five = tools::Run(run, std::cerr);
  const double simulated = five.traces[0].winding_temperature.back();  // °C
  std::printf("winding after 1 cycle %.4f °C; after 5: carried %.4f °C, simulated %.4f °C\n",
              j.temperature_cycle, j.temperature, simulated);
  EXPECT_GT(simulated - j.temperature_cycle, 1.0);  // K: the four cycles warm it measurably
  // 0.01 K of a 1.3 K rise: R(T) held over each eighth of a cycle (α·ΔT·P/C_w·T/8 ≈ 1e-4 K).
  EXPECT_NEAR(j.temperature, simulated, 0.01);
  // ia² + ib² of a current drive is I_peak² = 8 A² whatever the angle; 2 %: the PI loop's
  // tracking while it moves.
  EXPECT_NEAR(j.current_squared, 8.0, 0.16);
}

// A leg that does not move, without a dwell, still lasts a step: the targets' times rise.
TEST(Size, AStillLegWithoutDwellLastsAStep) {
  SizeOptions o = Rotor();
  o.moves["shaft"] = "0rad";
  o.dwell = 0;
  const SizeResult r = Size(o, std::cerr);
  EXPECT_NEAR(r.cycle_time, 2e-4, 1e-12);  // s: two legs of one step each
  EXPECT_EQ(r.joints[0].lost_steps, 0);
}

TEST(Size, ErrorsNameTheOptionAndValue) {
  auto error = [](SizeOptions o) {
    try {
      Size(o, std::cerr);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  SizeOptions o = Rotor();
  o.moves = {{"elbow", "1rad"}};
  EXPECT_THAT(error(o), HasSubstr("--move elbow=1rad: no stepper actuator named 'elbow'"));
  o = Rotor();
  o.moves["shaft"] = "20mm";
  EXPECT_THAT(error(o), HasSubstr("this is a hinge"));
  // models/tsui_rigid.xml: a velocity-input drive without a motion profile.
  o = Rotor();
  o.run.model = MJSTEPPER_SOURCE_DIR "/models/tsui_rigid.xml";
  EXPECT_THAT(error(o), HasSubstr("--move shaft: size moves a joint through its drive's motion "
                                  "profile, which needs input = position; set "
                                  "shaft.input=position"));
  o.run.overrides = {{"shaft", "input", "position"}};
  EXPECT_THAT(error(o), HasSubstr("give --speed shaft=… and --accel shaft=…"));
  o.speeds["shaft"] = "100rpm";
  o.accelerations["shaft"] = "-5rad/s²";
  EXPECT_THAT(error(o), HasSubstr("--accel shaft=-5rad/s²: \"-5rad/s²\": a rate must be > 0"));
  o = Rotor();
  o.moves.clear();
  EXPECT_THAT(error(o), HasSubstr("no move"));
  o = Rotor();
  o.cycles = 0;
  EXPECT_THAT(error(o), HasSubstr("--cycles 0"));
  o = Rotor();
  o.dwell = 3600;  // s, twice: 7.2e7 steps of 1e-4 s, beyond what a sizing keeps
  EXPECT_THAT(error(o), HasSubstr("size: the cycle lasts 7200.4 s, 7.2004e+07 steps"));
  o = Rotor();
  o.out = "/tmp/size_test_collision";
  o.run.log = "/tmp/size_test_collision_shaft.png";
  EXPECT_THAT(error(o), HasSubstr("'shaft' writes /tmp/size_test_collision_shaft.png, which --log "
                                  "writes too"));
}

// The bench's rotor carries the joint's inertia at the start pose: models/arm3.xml's base turns
// less inertia with the elbow folded (the forearm nearer its axis) than stretched out at qpos0.
TEST(Size, TheBenchInertiaIsTheStartPoses) {
  const StepperModel sm = LoadStepperModel(MJSTEPPER_SOURCE_DIR "/models/arm3.xml");
  const mjModel* m = sm.model.get();
  const DataPtr d(mj_makeData(m));
  const int base = sm.steppers[0].actuator, elbow = 2;  // qpos: base, shoulder, elbow
  d->qpos[elbow] = 1.5;                                 // rad
  const double stretched = ReflectedInertia(m, base), folded = ReflectedInertia(m, base, d.get());
  std::printf("base's rotor-side inertia: %.4g kg·m² stretched, %.4g folded\n", stretched, folded);
  EXPECT_LT(folded, 0.8 * stretched);
  EXPECT_EQ(ReflectedInertia(m, base, nullptr), stretched);
}

// A joint's files stay beside the prefix whatever its actuator is called.
TEST(Size, JointFilesStayBesideThePrefix) {
  EXPECT_THAT(SizeJointOutputs("out/arm", "../../etc/passwd"),
              ::testing::ElementsAre("out/arm_______etc_passwd_demand.csv",
                                     "out/arm_______etc_passwd_pullout.csv",
                                     "out/arm_______etc_passwd.png"));
  EXPECT_EQ(SizeJointOutputs("p", "j2")[2], "p_j2.png");
}

TEST(Size, JointValuesKeepTheirUnits) {
  EXPECT_THAT(ParseJointValues("--move j=", "30,60deg", JointQuantity::kPosition, false, false),
              ::testing::ElementsAre(::testing::DoubleNear(M_PI / 6, 1e-15),
                                     ::testing::DoubleNear(M_PI / 3, 1e-15)));
  EXPECT_THAT(ParseJointValues("--move j=", "10mm,0.5m", JointQuantity::kPosition, true, false),
              ::testing::ElementsAre(0.01, 0.5));
  EXPECT_DOUBLE_EQ(ParseJointValues("--speed j=", "60rpm", JointQuantity::kSpeed, false, true)[0],
                   2 * M_PI);
  auto error = [](const std::string& text, JointQuantity q, bool single) {
    try {
      ParseJointValues("--x j=", text, q, std::nullopt, single);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(error("30,abc", JointQuantity::kPosition, false),
              HasSubstr("\"abc\" is not a number"));
  EXPECT_THAT(error("30,60", JointQuantity::kPosition, false), HasSubstr("needs a unit"));
  EXPECT_THAT(error("30deg/s", JointQuantity::kPosition, false), HasSubstr("the unit must be"));
  EXPECT_THAT(error("-5deg/s", JointQuantity::kSpeed, true), HasSubstr("a rate must be > 0"));
  EXPECT_THAT(error("5,6deg/s", JointQuantity::kSpeed, true), HasSubstr("give one value"));
  EXPECT_THAT(error("10mm,1deg", JointQuantity::kPosition, false), HasSubstr("mix of"));
  EXPECT_THAT(error("nan deg", JointQuantity::kPosition, false), HasSubstr("not a number"));
  EXPECT_THAT(error("1e300deg", JointQuantity::kPosition, false), HasSubstr("beyond"));
}

// An ostream that asks the experiment under way to stop once `marker` has been written to it.
class CancelOn : public std::streambuf {
 public:
  explicit CancelOn(std::string marker) : marker_(std::move(marker)) {}
  const std::string& text() const { return text_; }

 protected:
  int overflow(int c) override {
    if (c != traits_type::eof()) Take(std::string(1, static_cast<char>(c)));
    return c;
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    Take(std::string(s, static_cast<size_t>(n)));
    return n;
  }

 private:
  void Take(const std::string& more) {
    text_ += more;
    if (text_.find(marker_) != std::string::npos) RequestCancel();
  }
  std::string marker_, text_;
};

// Issue 33: a sizing of 5 000 waypoints ran for minutes without a word. Its cycle's wall time is
// estimated before it runs, and said even without progress when over a minute: here arm6's
// 5 000 poses (about an hour of simulated time), stopped by the test once it is said.
TEST(Size, ALongCycleIsEstimatedBeforeItRuns) {
  SizeOptions o;
  o.run.model = MJSTEPPER_SOURCE_DIR "/models/arm6.xml";
  o.run.progress = false;
  o.run.allow_coarse = true;
  std::string poses = "30deg";
  for (int k = 1; k < 5000; ++k) poses += k % 2 == 0 ? ",30deg" : ",0deg";
  o.moves["j2"] = poses;
  CancelOn said("Ctrl-C stops it");
  std::ostream progress(&said);
  const auto start = std::chrono::steady_clock::now();
  {
    const CancelScope scope;
    EXPECT_THROW(Size(o, progress), Cancelled);
  }
  { const CancelScope clear; }  // (the request must not reach the tests after this one)
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 30);
  EXPECT_THAT(said.text(), HasSubstr("5000 poses"));
  EXPECT_THAT(said.text(), HasSubstr("s of wall time (Ctrl-C stops it)"));
}

// Issue 33: sweeps and runs are estimated before they start too, and a long one says so without
// progress (Python's default): 1e5 speeds of the Tsui rotor (about 1e5 s simulated), a run of
// 1e5 s; each stopped by the test once it is said.
TEST(Size, LongSweepsAndRunsAreEstimatedBeforeTheyStart) {
  SweepOptions sweep;
  sweep.model = MJSTEPPER_SOURCE_DIR "/models/tsui_rigid.xml";
  sweep.progress = false;
  for (int k = 0; k < 100000; ++k) sweep.speeds.push_back(10 + 0.001 * k);  // rad/s
  RunOptions run;
  run.model = sweep.model;
  run.duration = 1e5;
  run.progress = false;
  for (const char* what : {"sweep: 100000 runs", "run: 2000000000 steps"}) {
    CancelOn said("Ctrl-C stops it");
    std::ostream progress(&said);
    {
      const CancelScope scope;
      if (what[0] == 's') {
        EXPECT_THROW(Sweep(sweep, progress), Cancelled);
      } else {
        EXPECT_THROW(tools::Run(run, progress), Cancelled);
      }
    }
    { const CancelScope clear; }
    EXPECT_THAT(said.text(), HasSubstr(what));
  }
}
}  // namespace
}  // namespace mjstepper::tools
