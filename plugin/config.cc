#include "config.h"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <optional>
#include <sstream>

#include "core/presets.h"

namespace mjstepper::plugin {
namespace {

std::string Trim(const std::string& s) {
  const size_t begin = s.find_first_not_of(" \t\n\r");
  if (begin == std::string::npos) return "";
  const size_t end = s.find_last_not_of(" \t\n\r");
  return s.substr(begin, end - begin + 1);
}

// An error that names the attribute, quotes the value and states the rule.
struct ConfigError {
  std::string message;
};

ConfigError Bad(const char* name, const std::string& value, const std::string& rule) {
  return {fmt::format("{} = \"{}\": {}", name, value, rule)};
}

class Reader {
 public:
  explicit Reader(const AttributeReader& read) : read_(read) {}

  std::optional<std::string> Raw(const char* name) const {
    const char* value = read_(name);
    if (value == nullptr || value[0] == '\0') return std::nullopt;
    return std::string(value);
  }

  // Overwrites *out when the attribute is set; checks `valid` on the result.
  template <typename Check>
  void Number(const char* name, const char* unit, const char* rule, Check valid,
              double* out) const {
    const std::optional<std::string> raw = Raw(name);
    if (!raw) return;
    double value = 0;
    if (!ParseFiniteDouble(*raw, &value)) {
      throw Bad(name, *raw, fmt::format("not a finite number; write e.g. 1.5 (unit: {})", unit));
    }
    if (!valid(value)) throw Bad(name, *raw, fmt::format("{} ({})", rule, unit));
    *out = value;
  }

 private:
  const AttributeReader& read_;
};

std::vector<DetentHarmonic> ParseDetent(const char* name, const std::string& raw) {
  const std::string text = Trim(raw);
  if (text == "none") return {};
  const char* rule =
      "expected \"none\" or triplets \"order amplitude phase\" (-, N·m, rad) separated by "
      "';', e.g. \"4 0.006 0; 2 0.014 3.1416\"";
  std::vector<DetentHarmonic> harmonics;
  std::stringstream groups(text);
  std::string group;
  while (std::getline(groups, group, ';')) {
    std::stringstream fields(Trim(group));
    std::string field;
    std::vector<double> values;
    while (fields >> field) {
      double v = 0;
      if (!ParseFiniteDouble(field, &v)) throw Bad(name, raw, rule);
      values.push_back(v);
    }
    if (values.size() != 3) throw Bad(name, raw, rule);
    if (values[0] < 1 || values[0] != std::floor(values[0]) || values[0] > 1000) {
      throw Bad(name, raw, "harmonic order must be an integer in [1, 1000]");
    }
    if (values[1] < 0) throw Bad(name, raw, "amplitude must be >= 0 (N·m)");
    harmonics.push_back(
        {.order = static_cast<int>(values[0]), .amplitude = values[1], .phase = values[2]});
  }
  if (harmonics.empty()) throw Bad(name, raw, rule);
  return harmonics;
}

// `damping`: "none", "all", or harmonic orders "4 2 1", each of which must be in `estimates`.
std::vector<DetentHarmonic> SelectDamping(const std::string& raw,
                                          const std::vector<DetentHarmonic>& estimates) {
  const std::string text = Trim(raw);
  if (text == "none") return {};
  if (text == "all") return estimates;
  std::vector<DetentHarmonic> selected;
  std::stringstream fields(text);
  std::string field;
  while (fields >> field) {
    double order = 0;
    if (!ParseFiniteDouble(field, &order)) {
      throw Bad(kAttrDamping, raw, "expected none, all, or harmonic orders such as \"4 2 1\"");
    }
    bool found = false;
    for (const DetentHarmonic& h : estimates) {
      if (h.order == order) {
        selected.push_back(h);
        found = true;
      }
    }
    if (!found) {
      throw Bad(
          kAttrDamping, raw,
          fmt::format("harmonic {} is not in damping_detent (nor the motor's detent)", field));
    }
  }
  return selected;
}

DriveConfig Parse(const AttributeReader& read) {
  const Reader r(read);
  DriveConfig c;

  const std::string motor = r.Raw(kAttrMotor).value_or("tsui2009");
  const std::optional<Preset> preset = FindPreset(Trim(motor));
  if (!preset) {
    std::string names;
    for (const std::string& n : PresetNames()) names += (names.empty() ? "" : ", ") + n;
    throw Bad(kAttrMotor, motor, "unknown preset; known: " + names);
  }
  c.motor = preset->motor;

  if (const auto drive = r.Raw(kAttrDrive)) {
    const std::string d = Trim(*drive);
    bool known = false;
    for (DriveKind kind :
         {DriveKind::kVoltageMicrostep, DriveKind::kCurrentMicrostep, DriveKind::kIdealCurrent,
          DriveKind::kServo, DriveKind::kIdentification}) {
      if (d == DriveKindName(kind)) {
        c.kind = kind;
        known = true;
      }
    }
    if (!known) {
      throw Bad(kAttrDrive, *drive,
                "unknown drive; known: voltage_microstep, current_microstep, ideal_current, servo, "
                "identification");
    }
  }
  if (const auto input = r.Raw(kAttrInput)) {
    const std::string i = Trim(*input);
    if (i == "position") {
      c.input = InputMode::kPosition;
    } else if (i == "velocity") {
      c.input = InputMode::kVelocity;
    } else {
      throw Bad(kAttrInput, *input, "must be position (ctrl in rad) or velocity (ctrl in rad/s)");
    }
  }

  auto positive = [](double v) { return v > 0; };
  auto non_negative = [](double v) { return v >= 0; };
  double teeth = c.motor.rotor_teeth;
  r.Number(
      kAttrRotorTeeth, "-", "must be an integer in [1, 1000]",
      [](double v) { return v >= 1 && v <= 1000 && v == std::floor(v); }, &teeth);
  c.motor.rotor_teeth = static_cast<int>(teeth);
  r.Number(kAttrResistance, "Ω", "must be > 0", positive, &c.motor.resistance);
  r.Number(kAttrInductance, "H", "must be > 0", positive, &c.motor.inductance);
  r.Number(kAttrTorqueConstant, "N·m/A", "must be > 0", positive, &c.motor.torque_constant);
  if (const auto detent = r.Raw(kAttrDetent)) c.motor.detent = ParseDetent(kAttrDetent, *detent);
  r.Number(kAttrBusVoltage, "V", "must be > 0", positive, &c.bus_voltage);
  r.Number(kAttrVoltageAmplitude, "V", "must be > 0", positive, &c.voltage_amplitude);
  if (c.kind == DriveKind::kVoltageMicrostep && c.voltage_amplitude > c.bus_voltage) {
    throw Bad(kAttrVoltageAmplitude, r.Raw(kAttrVoltageAmplitude).value_or("24"),
              fmt::format("must be <= bus_voltage = {} for voltage_microstep (V)", c.bus_voltage));
  }
  r.Number(kAttrHoldCurrent, "A", "must be > 0", positive, &c.hold_current);
  r.Number(kAttrKp, "V/A", "must be >= 0", non_negative, &c.kp);
  r.Number(kAttrKi, "V/A per tick", "must be >= 0", non_negative, &c.ki_per_tick);
  r.Number(kAttrIsrPeriod, "s", "must be > 0", positive, &c.isr_period);
  r.Number(kAttrComputeDelay, "s", "must be >= 0", non_negative, &c.compute_delay);
  if (!(c.compute_delay < c.isr_period)) {
    throw Bad(kAttrComputeDelay, r.Raw(kAttrComputeDelay).value_or("25e-6"),
              fmt::format("must be < isr_period = {} (s)", c.isr_period));
  }
  if (const auto stage = r.Raw(kAttrPowerStage)) {
    const std::string p = Trim(*stage);
    if (p == "h_bridge") {
      c.power_stage = PowerStageKind::kTwoHBridges;
    } else if (p == "svpwm") {
      c.power_stage = PowerStageKind::kThreeLegSvpwm;
    } else {
      throw Bad(kAttrPowerStage, *stage, "must be h_bridge (S-13) or svpwm (S-14)");
    }
  }
  const std::vector<DetentHarmonic> estimates =
      r.Raw(kAttrDampingDetent) ? ParseDetent(kAttrDampingDetent, *r.Raw(kAttrDampingDetent))
                                : c.motor.detent;
  if (const auto damping = r.Raw(kAttrDamping)) c.damping = SelectDamping(*damping, estimates);

  double counts = preset->encoder_counts;
  r.Number(
      kAttrEncoderCounts, "counts/rev", "must be an integer in [0, 1e9] (0: ideal)",
      [](double v) { return v >= 0 && v <= 1e9 && v == std::floor(v); }, &counts);
  c.encoder_counts = static_cast<int>(counts);
  r.Number(kAttrVelocityCutoff, "Hz", "must be > 0", positive, &c.velocity_cutoff);
  r.Number(kAttrPositionPeriod, "s", "must be > 0", positive, &c.position_period);
  const double ratio = c.position_period / c.isr_period;
  if (!(ratio >= 1 && std::abs(ratio - std::round(ratio)) < 1e-9 * ratio)) {
    throw Bad(kAttrPositionPeriod, r.Raw(kAttrPositionPeriod).value_or("250e-6"),
              fmt::format("must be a whole multiple of isr_period = {} (s)", c.isr_period));
  }
  r.Number(kAttrServoKp, "N·m/rad", "must be >= 0", non_negative, &c.servo_kp);
  r.Number(kAttrServoKi, "N·m/(rad·s)", "must be >= 0", non_negative, &c.servo_ki);
  r.Number(kAttrServoKv, "N·m·s/rad", "must be >= 0", non_negative, &c.servo_kv);
  c.friction_compensation = preset->motor.static_friction;
  r.Number(kAttrFrictionCompensation, "N·m", "must be >= 0", non_negative,
           &c.friction_compensation);
  Validate(c);  // the core's own checks, as a backstop
  return c;
}

}  // namespace

const std::vector<const char*>& AttributeNames() {
  static const std::vector<const char*> names = {kAttrMotor,
                                                 kAttrDrive,
                                                 kAttrInput,
                                                 kAttrRotorTeeth,
                                                 kAttrResistance,
                                                 kAttrInductance,
                                                 kAttrTorqueConstant,
                                                 kAttrDetent,
                                                 kAttrBusVoltage,
                                                 kAttrVoltageAmplitude,
                                                 kAttrHoldCurrent,
                                                 kAttrKp,
                                                 kAttrKi,
                                                 kAttrIsrPeriod,
                                                 kAttrComputeDelay,
                                                 kAttrPowerStage,
                                                 kAttrDamping,
                                                 kAttrDampingDetent,
                                                 kAttrEncoderCounts,
                                                 kAttrVelocityCutoff,
                                                 kAttrPositionPeriod,
                                                 kAttrServoKp,
                                                 kAttrServoKi,
                                                 kAttrServoKv,
                                                 kAttrFrictionCompensation,
                                                 kAttrGauge};
  return names;
}

bool ParseFiniteDouble(const std::string& text, double* value) {
  const std::string t = Trim(text);
  if (t.empty()) return false;
  const char* begin = t.data();
  const char* end = t.data() + t.size();
  if (*begin == '+') ++begin;  // from_chars rejects a leading '+'
  const auto [ptr, ec] = std::from_chars(begin, end, *value);
  return ec == std::errc() && ptr == end && std::isfinite(*value);
}

std::variant<StepperConfig, std::string> ParseStepperConfig(const AttributeReader& read) {
  std::variant<DriveConfig, std::string> drive = ParseConfig(read);
  if (std::string* error = std::get_if<std::string>(&drive)) return *error;
  StepperConfig c{.drive = std::get<DriveConfig>(drive)};
  const Reader r(read);
  if (const auto gauge = r.Raw(kAttrGauge)) {
    const std::string g = Trim(*gauge);
    if (g != "on" && g != "off") return Bad(kAttrGauge, *gauge, "must be on or off").message;
    c.gauge = g == "on";
  }
  return c;
}

std::variant<DriveConfig, std::string> ParseConfig(const AttributeReader& read) {
  try {
    return Parse(read);
  } catch (const ConfigError& e) {
    return e.message;
  } catch (const std::exception& e) {
    return std::string(e.what());
  }
}

}  // namespace mjstepper::plugin
