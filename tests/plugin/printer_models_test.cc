// The printer models of issue 18 (models/corexy.xml, models/bedslinger.xml): each axis's belt
// resonance against the closed forms of models/README.md, by a generalized eigen-analysis of the
// compiled model and by the free ringing of the toolhead (or bed) with the steppers holding.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <regex>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>
#include <variant>
#include <vector>

#include "config.h"
#include "core/drive.h"
#include "core/units.h"
#include "printer_axes.h"
#include "test_model.h"

namespace mjstepper::testing {
namespace {

ModelPtr LoadShipped(const std::string& name) {
  std::ifstream file(std::string(MJSTEPPER_SOURCE_DIR "/models/") + name);
  std::stringstream text;
  text << file.rdbuf();
  std::string error;
  ModelPtr m = LoadModel(text.str(), &error);
  EXPECT_TRUE(m) << name << ": " << error;
  return m;
}

// A stepper's configuration as the plugin parses it (its motor, chip and current rounding).
DriveConfig StepperConfig(const mjModel* m, const char* actuator) {
  const int instance = m->actuator_plugin[mj_name2id(m, mjOBJ_ACTUATOR, actuator)];
  return std::get<DriveConfig>(
      plugin::ParseConfig([&](const char* key) { return mj_getPluginConfig(m, instance, key); }));
}

double HoldingStiffness(const mjModel* m, const char* actuator) {
  return Drive(StepperConfig(m, actuator)).HoldingStiffness();
}

// The model's natural frequencies at qpos0, rad/s, ascending: det(K − ω²·M) = 0 with M the joint
// space inertia (mj_fullM) and K the belts' k·c·cᵀ (c a fixed tendon's joint coefficients) plus
// each stepper's T'·gear² on its joint: the linearization the closed forms describe, built from
// the compiled model rather than from the documented numbers.
std::vector<double> ModelModes(const mjModel* m) {
  const int nv = m->nv;
  const DataPtr d(mj_makeData(m));
  mj_forward(m, d.get());
  std::vector<mjtNum> dense(nv * nv);
  mj_fullM(m, d.get(), dense.data());
  const Eigen::MatrixXd mass = Eigen::Map<Eigen::MatrixXd>(dense.data(), nv, nv);
  Eigen::MatrixXd stiffness = Eigen::MatrixXd::Zero(nv, nv);
  for (int t = 0; t < m->ntendon; ++t) {
    if (!(m->tendon_stiffness[t] > 0)) continue;  // the drawn belt paths carry no force
    Eigen::VectorXd c = Eigen::VectorXd::Zero(nv);
    for (int w = m->tendon_adr[t]; w < m->tendon_adr[t] + m->tendon_num[t]; ++w) {
      EXPECT_EQ(m->wrap_type[w], mjWRAP_JOINT);
      c(m->jnt_dofadr[m->wrap_objid[w]]) += m->wrap_prm[w];
    }
    stiffness += m->tendon_stiffness[t] * c * c.transpose();
  }
  for (int a = 0; a < m->nactuator; ++a) {
    const char* name = mj_id2name(m, mjOBJ_ACTUATOR, a);
    const double gear = m->actuator_gear[6 * a];
    stiffness(m->jnt_dofadr[m->actuator_trnid[2 * a]], m->jnt_dofadr[m->actuator_trnid[2 * a]]) +=
        HoldingStiffness(m, name) * gear * gear;
  }
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> solver(stiffness, mass,
                                                                         Eigen::EigenvaluesOnly);
  std::vector<double> omega;
  for (const double lambda : solver.eigenvalues()) omega.push_back(std::sqrt(lambda));
  return omega;  // Eigen sorts them ascending
}

// The documented T', R, L and Km are the ones the plugin sets up (motor preset, chip, current
// rounding); the tolerance 1e-4 covers only the README's rounding of the rest current to 4-6
// digits.
TEST(PrinterModels, SteppersAreTheDocumentedOnes) {
  const ModelPtr corexy = LoadShipped("corexy.xml");
  const ModelPtr bedslinger = LoadShipped("bedslinger.xml");
  ASSERT_TRUE(corexy && bedslinger);
  for (const auto& [model, actuator, axis] :
       {std::tuple{corexy.get(), "stepper_a", kCoreXYX},
        std::tuple{corexy.get(), "stepper_b", kCoreXYY},
        std::tuple{bedslinger.get(), "stepper_x", kBedslingerX},
        std::tuple{bedslinger.get(), "stepper_y", kBedslingerY}}) {
    const DriveConfig config = StepperConfig(model, actuator);
    EXPECT_NEAR(Drive(config).HoldingStiffness(), axis.holding, 1e-4 * axis.holding) << actuator;
    EXPECT_DOUBLE_EQ(config.motor.resistance, axis.resistance) << actuator;
    EXPECT_DOUBLE_EQ(config.motor.inductance, axis.inductance) << actuator;
    EXPECT_NEAR(config.motor.torque_constant, axis.torque_constant, 1e-5 * axis.torque_constant)
        << actuator;
    EXPECT_EQ(model->actuator_gear[6 * mj_name2id(model, mjOBJ_ACTUATOR, actuator)], 1.0);
  }
}

// The compiled models' eigenfrequencies are the closed forms' (README): CoreXY's four are X's and
// Y's two-mass pairs (pure X drives both rotors alike, pure Y oppositely, so the 4×4 problem splits
// into two 2×2 ones with both belts in parallel); the bed-slinger's are its two axes' pairs. The
// tolerance (1e-3, well inside the issue's 2 %) allows only for what the closed forms leave out:
// the rotor bodies' 1e-9 kg·m² (1.2e-4 of J) and the documented numbers' rounding. A wrong belt
// coefficient, a missing mass or a motor on the wrong joint moves a mode by far more.
TEST(PrinterModels, EigenfrequenciesAreTheClosedForms) {
  const ModelPtr corexy = LoadShipped("corexy.xml");
  const ModelPtr bedslinger = LoadShipped("bedslinger.xml");
  ASSERT_TRUE(corexy && bedslinger);
  ASSERT_EQ(corexy->nv, 4);
  ASSERT_EQ(bedslinger->nv, 4);
  const auto [cx1, cx2] = ClosedFormModes(kCoreXYX);
  const auto [cy1, cy2] = ClosedFormModes(kCoreXYY);
  const auto [bx1, bx2] = ClosedFormModes(kBedslingerX);
  const auto [by1, by2] = ClosedFormModes(kBedslingerY);
  for (const auto& [model, expected] :
       {std::pair{corexy.get(), std::vector<double>{cy1, cx1, cy2, cx2}},
        std::pair{bedslinger.get(), std::vector<double>{by1, bx1, bx2, by2}}}) {
    const std::vector<double> modes = ModelModes(model);
    ASSERT_EQ(modes.size(), expected.size());
    for (size_t i = 0; i < modes.size(); ++i) {
      std::printf("%s mode %zu: %.3f Hz, closed form %.3f Hz (%+.1e)\n", model->names, i,
                  modes[i] / kTwoPi, expected[i] / kTwoPi, modes[i] / expected[i] - 1);
      EXPECT_NEAR(modes[i], expected[i], 1e-3 * expected[i])
          << model->names << " mode " << i << ": " << modes[i] / kTwoPi << " Hz, closed form "
          << expected[i] / kTwoPi << " Hz";
    }
  }
  // The frequencies README quotes (Hz, 3-4 digits).
  EXPECT_NEAR(cx1 / kTwoPi, 61.2, 0.05);
  EXPECT_NEAR(cy1 / kTwoPi, 41.4, 0.05);
  EXPECT_NEAR(bx1 / kTwoPi, 70.8, 0.05);
  EXPECT_NEAR(by1 / kTwoPi, 50.4, 0.05);
}

// The frequency, rad/s, at which the DFT of x(t) − mean peaks within [low, high]: |Σ x·e^{−iωt}|²
// on a 0.25 Hz grid, then on a 0.005 Hz grid around the best point, refined by a parabola through
// the peak and its neighbours.
double DominantFrequency(const std::vector<double>& t, const std::vector<double>& x, double low,
                         double high) {
  double mean = 0;
  for (const double v : x) mean += v / static_cast<double>(x.size());
  const auto power = [&](double w) {
    double re = 0, im = 0;
    for (size_t i = 0; i < t.size(); ++i) {
      re += (x[i] - mean) * std::cos(w * t[i]);
      im -= (x[i] - mean) * std::sin(w * t[i]);
    }
    return re * re + im * im;
  };
  const auto argmax = [&](double from, double to, double step) {
    double best = from, best_power = -1;
    for (double w = from; w <= to; w += step) {
      if (const double p = power(w); p > best_power) best = w, best_power = p;
    }
    return best;
  };
  const double coarse = kTwoPi * 0.25, fine = kTwoPi * 0.005;
  const double near = argmax(low, high, coarse);
  const double peak = argmax(near - coarse, near + coarse, fine);
  const double a = power(peak - fine), b = power(peak), c = power(peak + fine);
  return peak + 0.5 * (a - c) / (a - 2 * b + c) * fine;
}

struct Ringing {
  double omega;         // rad/s, the dominant frequency of the excited coordinate
  double excited_peak;  // m, its largest excursion
  double other_peak;    // m, the other axis's largest excursion
};

// The steppers hold their rest position (ctrl = 0 microsteps) for 20 ms, then the carriage (or
// bed) on `joint` gets 20 mm/s, a tap, and rings freely for 0.5 s at the model's own timestep.
Ringing Tap(const mjModel* m, const char* joint, const char* other, double low, double high) {
  const int dof = m->jnt_dofadr[mj_name2id(m, mjOBJ_JOINT, joint)];
  const int other_dof = m->jnt_dofadr[mj_name2id(m, mjOBJ_JOINT, other)];
  const DataPtr d(mj_makeData(m));
  while (d->time < 0.02) mj_step(m, d.get());
  const double start = d->time;
  const double x0 = d->qpos[dof], y0 = d->qpos[other_dof];
  d->qvel[dof] += 0.02;  // m/s: about 50 µm of ringing, a few microsteps of the belts
  std::vector<double> t, x;
  Ringing r{0, 0, 0};
  while (d->time < start + 0.5) {
    mj_step(m, d.get());
    t.push_back(d->time);
    x.push_back(d->qpos[dof]);
    r.excited_peak = std::max(r.excited_peak, std::abs(d->qpos[dof] - x0));
    r.other_peak = std::max(r.other_peak, std::abs(d->qpos[other_dof] - y0));
  }
  r.omega = DominantFrequency(t, x, low, high);
  return r;
}

// The shipped model with every stepper's chopper drive replaced by `ideal_current` at the same
// rest current (the chip's rounding included): the ideal spring T' = Nr·Km·I the closed forms
// assume, with no windings.
ModelPtr IdealSpringVariant(const std::string& name) {
  const ModelPtr shipped = LoadShipped(name);
  std::ifstream file(std::string(MJSTEPPER_SOURCE_DIR "/models/") + name);
  std::stringstream text;
  text << file.rdbuf();
  std::string xml = text.str();
  for (int a = 0; a < shipped->nactuator; ++a) {
    const char* actuator = mj_id2name(shipped.get(), mjOBJ_ACTUATOR, a);
    const int instance = shipped->actuator_plugin[a];
    const DriveConfig config = std::get<DriveConfig>(plugin::ParseConfig(
        [&](const char* key) { return mj_getPluginConfig(shipped.get(), instance, key); }));
    const double current = Drive(config).RestCurrentMagnitude();  // A, peak
    const size_t begin = xml.find(std::string("<plugin name=\"") + actuator + "\"");
    const size_t end = xml.find("</plugin>", begin);
    std::string block = xml.substr(begin, end - begin);
    block = std::regex_replace(
        block,
        std::regex(R"re(<config key="(driver|run_current|sense_resistor|interpolate)"[^>]*/>)re"),
        "");
    block = std::regex_replace(block, std::regex(R"(value="spreadcycle")"),
                               R"(value="ideal_current"/><config key="hold_current" value=")" +
                                   std::to_string(current) + "\"");
    xml.replace(begin, end - begin, block);
  }
  std::string error;
  ModelPtr m = LoadModel(xml, &error);
  EXPECT_TRUE(m) << name << " (ideal_current): " << error;
  return m;
}

// Free vibration: tapped along one axis with both steppers holding, the toolhead (the bed for the
// bed-slinger's Y) rings at the axis's lower closed-form mode.
// - With the motors as ideal springs (`ideal_current`), to 0.5 % of the damped closed form
//   ω·√(1 − ζ²) (the belts' ζ ≈ 0.065-0.1, DampingRatio): what is left is the DFT's resolution
//   and the integrator's (ω·h)²/24 < 1e-5. This checks the closed form and the model together.
// - As shipped (SpreadCycle through real windings), to 5 % (the issue's): the chip regulates the
//   currents, but at a full-step rest one phase has a zero target and its bridge is shorted
//   (switching.h, IdleBridge), so the back-EMF drives a current through it that stiffens the
//   rotor by Km²·ω²·L/(R² + ω²·L²) (README): measured +1.6 to +3.9 % above the ideal spring. With
//   that term in the closed form (ShortedPhaseMode), to 1 %: what remains is heat (Km −0.55 % at
//   25 °C), the chopper's average current 1.6 % under its target and the ripple; measured within
//   0.5 %.
// A 10 % heavier toolhead moves the ringing by about 4.6 % (−1.8 % against the shorted-phase form):
// the 0.5 % and 1 % checks catch it, the issue's 5 % alone would not.
// On CoreXY a pure X (or Y) tap must leave the other axis still, as the two belts' forces cancel
// across it: the other axis moves less than 1 % of the tapped one.
TEST(PrinterModels, TappedToolheadRingsAtTheClosedFormFrequency) {
  const ModelPtr corexy = LoadShipped("corexy.xml");
  const ModelPtr bedslinger = LoadShipped("bedslinger.xml");
  const ModelPtr corexy_ideal = IdealSpringVariant("corexy.xml");
  const ModelPtr bedslinger_ideal = IdealSpringVariant("bedslinger.xml");
  ASSERT_TRUE(corexy && bedslinger && corexy_ideal && bedslinger_ideal);
  struct Case {
    const mjModel* model;
    const Axis& axis;
    const char* other;
    double tolerance;
    const char* drive;
  };
  for (const Case& c : {Case{corexy_ideal.get(), kCoreXYX, "y", 0.005, "ideal_current"},
                        Case{corexy_ideal.get(), kCoreXYY, "x", 0.005, "ideal_current"},
                        Case{bedslinger_ideal.get(), kBedslingerX, "y", 0.005, "ideal_current"},
                        Case{bedslinger_ideal.get(), kBedslingerY, "x", 0.005, "ideal_current"},
                        Case{corexy.get(), kCoreXYX, "y", 0.05, "spreadcycle"},
                        Case{corexy.get(), kCoreXYY, "x", 0.05, "spreadcycle"},
                        Case{bedslinger.get(), kBedslingerX, "y", 0.05, "spreadcycle"},
                        Case{bedslinger.get(), kBedslingerY, "x", 0.05, "spreadcycle"}}) {
    const double damped = std::sqrt(1 - DampingRatio(c.axis) * DampingRatio(c.axis));
    const double expected = ClosedFormModes(c.axis).first * damped;
    const Ringing r = Tap(c.model, c.axis.joint, c.other, 0.3 * expected, 2.5 * expected);
    const std::string what =
        std::string(c.model->names) + " " + c.axis.joint + " (" + c.drive + ")";
    EXPECT_NEAR(r.omega, expected, c.tolerance * expected)
        << what << ": rings at " << r.omega / kTwoPi << " Hz, closed form " << expected / kTwoPi
        << " Hz";
    EXPECT_GT(r.excited_peak, 1e-5) << what;
    EXPECT_LT(r.other_peak, 0.01 * r.excited_peak) << what;
    std::printf(
        "%s: rings at %.2f Hz (closed form %.2f Hz, %+.2f %%), peak %.1f um, other %.3f um\n",
        what.c_str(), r.omega / kTwoPi, expected / kTwoPi, 100 * (r.omega / expected - 1),
        1e6 * r.excited_peak, 1e6 * r.other_peak);
    if (std::string(c.drive) == "spreadcycle") {
      const double shorted = ShortedPhaseMode(c.axis) * damped;
      EXPECT_NEAR(r.omega, shorted, 0.01 * shorted)
          << what << ": rings at " << r.omega / kTwoPi << " Hz, with the shorted phase "
          << shorted / kTwoPi << " Hz";
      std::printf("  with the shorted phase's stiffness: %.2f Hz (%+.2f %%)\n", shorted / kTwoPi,
                  100 * (r.omega / shorted - 1));
    }
  }
}

}  // namespace
}  // namespace mjstepper::testing
