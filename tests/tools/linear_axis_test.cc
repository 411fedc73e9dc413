// Issue 32, item 3: a belt pulley or lead screw declared once on a rotary joint (pulley_teeth and
// belt_pitch, or lead), after which profiles, sweep, pullout, map, size and the log speak mm, mm/s
// and N at the carriage. On models/belt_axis.xml: the Tsui rotor with a GT2 20-tooth pulley (40 mm
// per turn, r = 6.3662 mm) on a compliant belt (a fixed tendon x − r·θ) to a 0.5 kg carriage.
#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/units.h"
#include "options.h"
#include "runner.h"
#include "size.h"
#include "stepper_model.h"
#include "sweep.h"

namespace mjstepper::tools {
namespace {

using ::testing::HasSubstr;

const std::string kBelt = MJSTEPPER_SOURCE_DIR "/models/belt_axis.xml";
const std::string kRotary = MJSTEPPER_SOURCE_DIR "/models/tsui_rigid.xml";
constexpr double kTravel = 20 * 0.002;                        // m per turn: 20 teeth × GT2's 2 mm
constexpr double kRadius = kTravel / (2 * std::numbers::pi);  // m per rad
constexpr double kRadPerMetre = 1 / kRadius;                  // the rotor's, gear 1

std::string Message(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(LinearAxis, SpeedListsTakeMillimetresPerSecondOnlyWhereACarriageCanBe) {
  bool at_carriage = false;
  EXPECT_EQ(ParseSpeedList("50,100mm/s", "--speeds", &at_carriage),
            (std::vector<double>{0.05, 0.1}));
  EXPECT_TRUE(at_carriage);
  EXPECT_EQ(ParseSpeedList("0.2m/s", "--speeds", &at_carriage), (std::vector<double>{0.2}));
  EXPECT_TRUE(at_carriage);
  // r/min as RpmToRadPerSec rounds them, bit for bit (v·(2π/60) moved a SpreadCycle pull-out
  // point of the drivers study, which is chaotic in the last bit of its speed).
  for (const double rpm : {60.0, 90.0, 330.0}) {
    EXPECT_EQ(ParseSpeedList(fmt::format("{:g}rpm", rpm), "--speeds", &at_carriage)[0],
              RpmToRadPerSec(rpm));
    EXPECT_FALSE(at_carriage);
  }
  // identify's speeds are the rotor's.
  EXPECT_THAT(Message([] { ParseSpeedList("50mm/s", "--speeds"); }), HasSubstr("rotor's"));
}

TEST(LinearAxis, TheDeclarationIsCheckedAgainstTheModel) {
  // Declared once, read by the tools: 40 mm per turn.
  const StepperModel belt = LoadStepperModel(kBelt);
  EXPECT_DOUBLE_EQ(belt.steppers[0].config.transmission.TravelPerRevolution(), kTravel);
  EXPECT_NEAR(*RadPerMetre(belt.model.get(), belt.steppers[0]), kRadPerMetre, 1e-9);
  // A lead screw declares the same.
  const StepperModel screw = LoadStepperModel(kRotary, {{"shaft", "lead", "0.008"}});
  EXPECT_NEAR(*RadPerMetre(screw.model.get(), screw.steppers[0]), 2 * std::numbers::pi / 0.008,
              1e-9);
  // The belt's tendon winds the hinge at 6.3662 mm per rad: a 16-tooth pulley does not fit it.
  std::string error = Message([] { LoadStepperModel(kBelt, {{"shaft", "pulley_teeth", "16"}}); });
  EXPECT_THAT(error, HasSubstr("pulley_teeth = 16, belt_pitch = 0.002 m (32 mm per turn)"));
  EXPECT_THAT(error, HasSubstr("tendon 'belt' winds joint 'shaft' at 6.366 mm per rad"));
  // Declared twice, or a pitch without its pulley.
  EXPECT_THAT(Message([] {
                LoadStepperModel(kBelt, {{"shaft", "lead", "0.04"}});
              }),
              HasSubstr("lead = \"0.04\": the carriage is declared twice"));
  EXPECT_THAT(Message([] {
                LoadStepperModel(kRotary, {{"shaft", "belt_pitch", "0.003"}});
              }),
              HasSubstr("belt_pitch = \"0.003\": a belt's pitch needs its pulley"));
  // On a slide joint the gear already gives rad per metre.
  const std::string cable = MJSTEPPER_SOURCE_DIR "/models/cable_axis.xml";
  EXPECT_THAT(Message([&] {
                LoadStepperModel(cable, {{"capstan", "lead", "0.008"}});
              }),
              HasSubstr("this stepper drives tendon 'cable'"));
}

TEST(LinearAxis, TheCarriageIsTheBeltsFarEndOrThePulleysTravel) {
  // Belt: x − r·θ is the tendon, so the carriage is the slide joint x, whatever the stretch.
  const StepperModel belt = LoadStepperModel(kBelt);
  const mjModel* m = belt.model.get();
  DataPtr d(mj_makeData(m));
  const int x = m->jnt_qposadr[mj_name2id(m, mjOBJ_JOINT, "carriage")];
  const int theta = m->jnt_qposadr[mj_name2id(m, mjOBJ_JOINT, "shaft")];
  d->qpos[x] = 0.1234;
  d->qpos[theta] = 17.0;  // the belt stretched by 0.1234 − 0.108 m
  d->qvel[m->jnt_dofadr[mj_name2id(m, mjOBJ_JOINT, "carriage")]] = 0.25;
  d->qvel[m->jnt_dofadr[mj_name2id(m, mjOBJ_JOINT, "shaft")]] = -3.0;
  mj_forward(m, d.get());
  const std::optional<Carriage> c = CarriageOf(m, belt.steppers[0]);
  ASSERT_TRUE(c.has_value());
  EXPECT_NEAR(c->Position(d.get(), belt.steppers[0]), 0.1234, 1e-12);
  EXPECT_NEAR(c->Speed(d.get(), belt.steppers[0]), 0.25, 1e-12);
  EXPECT_NEAR(c->Force(0.1), 0.1 * kRadPerMetre, 1e-9);
  // No belt in the model: the pulley's travel r·θ.
  const StepperModel rotary = LoadStepperModel(kRotary, {{"shaft", "pulley_teeth", "20"}});
  DataPtr e(mj_makeData(rotary.model.get()));
  e->qpos[0] = 2.0;
  mj_forward(rotary.model.get(), e.get());
  const std::optional<Carriage> r = CarriageOf(rotary.model.get(), rotary.steppers[0]);
  ASSERT_TRUE(r.has_value());
  EXPECT_NEAR(r->Position(e.get(), rotary.steppers[0]), 2.0 * kRadius, 1e-12);
  EXPECT_FALSE(CarriageOf(rotary.model.get(), LoadStepperModel(kRotary).steppers[0]));
}

// A CSV's columns by name.
std::map<std::string, std::vector<double>> ReadColumns(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> names;
  std::stringstream header(line);
  for (std::string name; std::getline(header, name, ',');) names.push_back(name);
  std::map<std::string, std::vector<double>> columns;
  while (std::getline(in, line)) {
    std::stringstream row(line);
    std::string field;
    for (const std::string& name : names) {
      std::getline(row, field, ',');
      columns[name].push_back(std::stod(field));
    }
  }
  return columns;
}

TEST(LinearAxis, ARunTakesMillimetresAndLogsTheCarriage) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / fmt::format("mjstepper_linear_{}", getpid());
  std::filesystem::create_directories(dir);
  std::ostringstream quiet;
  RunOptions o;
  o.model = kBelt;
  o.duration = 0.6;
  o.progress = false;
  // 100 mm/s on 40 mm per turn is 2.5 rev/s: 150 r/min at the rotor (to the rounding of the
  // two conversions).
  o.ctrl["shaft"] = "constant(150rpm)";
  const RunResult rotor = tools::Run(o, quiet);
  o.ctrl["shaft"] = "constant(100mm/s)";
  o.log = (dir / "belt.csv").string();
  const RunResult carriage = tools::Run(o, quiet);
  EXPECT_NEAR(carriage.steppers[0].final_speed, rotor.steppers[0].final_speed, 1e-9);
  EXPECT_FALSE(std::isnan(rotor.steppers[0].carriage_speed));  // a linear axis, whatever unit

  auto c = ReadColumns(o.log);
  const std::vector<double>& t = c["time[s]"];
  const std::vector<double>& position = c["shaft:carriage_position[mm]"];
  const std::vector<double>& speed = c["shaft:carriage_speed[mm/s]"];
  const std::vector<double>& force = c["shaft:carriage_force[N]"];
  const std::vector<double>& torque = c["shaft:torque_total[N·m]"];
  const std::vector<double>& theta = c["shaft:theta[rad]"];
  ASSERT_EQ(position.size(), t.size());
  ASSERT_EQ(force.size(), t.size());
  // Over the last 0.2 s the carriage moves at the commanded 100 mm/s (its mean speed from its
  // positions, 1 %: the 31 Hz belt mode rings a little over the window), a belt's stretch behind
  // the pulley's travel r·θ (under 1 mm: the friction's 1 N and the carriage's ringing on
  // k = 2e4 N/m are 0.05-0.5 mm).
  const size_t a = t.size() * 2 / 3, b = t.size() - 1;
  EXPECT_NEAR((position[b] - position[a]) / (t[b] - t[a]), 100, 1.0);
  double mean_speed = 0;
  for (size_t k = a; k <= b; ++k) mean_speed += speed[k] / (b - a + 1);
  EXPECT_NEAR(mean_speed, 100, 1.0);
  EXPECT_NEAR(position[b], 1e3 * kRadius * theta[b], 1.0);
  EXPECT_GT(std::abs(position[b] - 1e3 * kRadius * theta[b]), 1e-6);  // the belt's own end
  for (size_t k = 0; k < t.size(); k += 997) {
    EXPECT_NEAR(force[k], torque[k] * kRadPerMetre, 1e-9 * (1 + std::abs(force[k])));
  }
  std::filesystem::remove_all(dir);
}

TEST(LinearAxis, SweepsAndPullOutsSpeakMillimetresAndNewtons) {
  std::ostringstream quiet;
  SweepOptions o;
  o.model = kBelt;
  o.settle = 0.1;
  o.measure = 0.1;
  o.progress = false;
  o.speeds = {RpmToRadPerSec(75), RpmToRadPerSec(150)};
  const std::vector<SweepPoint> rotor = Sweep(o, quiet);
  o.speeds = {0.05, 0.1};  // m/s: 50 and 100 mm/s are 75 and 150 r/min
  o.speeds_at_carriage = true;
  const std::vector<SweepPoint> carriage = Sweep(o, quiet);
  ASSERT_EQ(carriage.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_NEAR(carriage[i].speed, rotor[i].speed, 1e-12);
    EXPECT_NEAR(carriage[i].peak_to_peak_error, rotor[i].peak_to_peak_error, 1e-9);
    EXPECT_NEAR(carriage[i].carriage_speed, o.speeds[i], 1e-12);
    EXPECT_NEAR(rotor[i].carriage_speed, o.speeds[i], 1e-12);  // given at the rotor, shown too
  }
  // A rotary stepper has no carriage: the message names what to declare.
  o.model = kRotary;
  EXPECT_THAT(Message([&] { Sweep(o, quiet); }), HasSubstr("declare its pulley (pulley_teeth"));
  o.speeds_at_carriage = false;
  o.speeds = {1.0};
  EXPECT_TRUE(std::isnan(Sweep(o, quiet)[0].carriage_speed));

  PullOutOptions p;
  p.model = kBelt;
  p.speeds = {0.1};
  p.speeds_at_carriage = true;
  p.max_torque = 1;
  p.rate = 2;
  p.progress = false;
  const PullOutPoint point = PullOut(p, quiet)[0];
  EXPECT_NEAR(point.speed, 0.1 * kRadPerMetre, 1e-12);
  EXPECT_NEAR(point.carriage_speed, 0.1, 1e-12);
  EXPECT_NEAR(point.force, point.torque * kRadPerMetre, 1e-9);
  EXPECT_GT(point.force, 10);  // tsui2009 holds about 0.53 N·m at 150 r/min: 83 N on this pulley
}

TEST(LinearAxis, SizeMovesTheCarriageInMillimetres) {
  std::ostringstream quiet;
  SizeOptions o;
  o.run.model = kBelt;
  o.run.progress = false;
  o.run.overrides = {{"shaft", "input", "position"}};
  o.moves["shaft"] = "60mm";
  o.speeds["shaft"] = "100mm/s";
  o.accelerations["shaft"] = "2000mm/s²";
  o.dwell = 0.05;
  o.pullout_points = 3;
  const SizeResult mm = Size(o, quiet);
  // The same move in the joint's own unit: 60 mm is 60/6.3662 rad of the pulley.
  o.moves["shaft"] = fmt::format("{:.17g}rad", 0.06 / kRadius);
  o.speeds["shaft"] = fmt::format("{:.17g}rad/s", 0.1 / kRadius);
  o.accelerations["shaft"] = fmt::format("{:.17g}rad/s²", 2.0 / kRadius);
  const SizeResult rad = Size(o, quiet);
  ASSERT_EQ(mm.joints.size(), 1u);
  EXPECT_NEAR(mm.cycle_time, rad.cycle_time, 1e-12);
  EXPECT_NEAR(mm.joints[0].margin, rad.joints[0].margin, 1e-9);
  const SizeJoint& j = mm.joints[0];
  EXPECT_NEAR(j.rad_per_metre, kRadPerMetre, 1e-9);
  // The carriage beyond the compliant belt is on no plan: the demand is the motor's own torque.
  // (Inverse dynamics with the carriage held at its start pose reads the belt stretched by the
  // whole move, k·60 mm = 1200 N.) Its top speed is the move's 100 mm/s (within the belt mode's
  // ringing, 10 %), its peak force far below that stretch: the carriage's m·a = 1 N, the friction
  // 1 N, the rotor's J·a/r² = 1.8 N, and the microstep ripple of a 10 ms mean (20 N at most).
  EXPECT_FALSE(j.inverse_dynamics);
  EXPECT_NEAR(j.peak_speed / j.rad_per_metre, 0.1, 0.01);
  EXPECT_LT(j.peak_torque * j.rad_per_metre, 20);
  std::ostringstream table;
  PrintSizeTable(mm, table);
  EXPECT_THAT(table.str(), HasSubstr("at the carriage: top"));
  // A hinge without a carriage refuses millimetres, saying how to declare one.
  o.run.model = kRotary;
  o.moves["shaft"] = "60mm";
  EXPECT_THAT(Message([&] { Size(o, quiet); }), HasSubstr("declare its carriage"));
}

}  // namespace
}  // namespace mjstepper::tools
