#include "identify.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <cmath>
#include <stdexcept>

#include "cancel.h"
#include "core/signals.h"
#include "core/units.h"
#include "options.h"
#include "stepper_model.h"

namespace mjstepper::tools {

std::string Identified::DampingDetent() const {
  std::string text;
  for (const DetentHarmonic& h : harmonics) {
    text +=
        fmt::format("{}{} {:.6g} {:.6g}", text.empty() ? "" : "; ", h.order, h.amplitude, h.phase);
  }
  return text;
}

Identified Identify(const IdentifyOptions& o) {
  if (o.speeds.size() < 2) {
    throw std::invalid_argument(
        "identify: give at least two speeds (Fs and B are separated by them)");
  }
  if (o.orders.empty()) throw std::invalid_argument("--orders: no harmonic to fit");
  for (size_t i = 0; i < o.orders.size(); ++i) {
    RequireInRange("--orders", Range("orders"), o.orders[i]);
    if (std::find(o.orders.begin(), o.orders.begin() + i, o.orders[i]) != o.orders.begin() + i) {
      throw std::invalid_argument(fmt::format(
          "--orders: harmonic {} is given twice; each order is fitted once", o.orders[i]));
    }
  }
  std::vector<ConfigOverride> overrides = {{o.actuator, "drive", "identification"},
                                           {o.actuator, "damping", "none"},
                                           {o.actuator, "friction_compensation", "0"}};
  overrides.insert(overrides.end(), o.overrides.begin(), o.overrides.end());
  const StepperModel sm = LoadStepperModel(o.model, overrides);
  const mjModel* m = sm.model.get();
  const StepperActuator* stepper = nullptr;
  for (const StepperActuator& s : sm.steppers) {
    if (s.name == o.actuator) stepper = &s;
  }
  const int dyno = mj_name2id(m, mjOBJ_ACTUATOR, o.dyno.c_str());
  if (stepper == nullptr || dyno < 0) {
    throw std::invalid_argument(fmt::format(
        "identify: {} needs a stepper actuator '{}' and an actuator '{}' that turns its shaft",
        o.model, o.actuator, o.dyno));
  }
  const int teeth = stepper->config.motor.rotor_teeth;
  const int counts = stepper->config.encoder_counts;
  // The encoder floors the angle (S-16); the bench's best estimate is the middle of the count.
  const double half_count = counts > 0 ? 0.5 * kTwoPi / counts : 0.0;

  const int n_harmonics = static_cast<int>(o.orders.size());
  const int n_speeds = static_cast<int>(o.speeds.size());
  const int columns = n_speeds + 2 * n_harmonics;
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(columns, columns);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(columns);
  std::vector<std::pair<Eigen::VectorXd, double>> samples;
  const double h = m->opt.timestep;
  for (int i = 0; i < n_speeds; ++i) {
    DataPtr data(mj_makeData(m));
    mjData* d = data.get();
    const long settle = std::lround(o.settle / h), total = settle + std::lround(o.measure / h);
    for (long k = 0; k < total; ++k) {
      d->ctrl[m->actuator_ctrladr[dyno]] = o.speeds[i];
      const double t = d->time;
      ThrowIfCancelled();  // (cancel.h)
      mj_step(m, d);
      if (const std::string unstable = InstabilityMessage(d, t); !unstable.empty()) {
        throw std::runtime_error(unstable);
      }
      if (k < settle) continue;
      // After mj_step, actuator_force and sensordata describe the step's start.
      static const int kThetaMeas = SignalIndex("theta_meas");
      const double theta = d->sensordata[stepper->sensor_adr + kThetaMeas] + half_count;
      const double x = teeth * theta;
      Eigen::VectorXd row = Eigen::VectorXd::Zero(columns);
      row[i] = 1.0;
      for (int j = 0; j < n_harmonics; ++j) {
        row[n_speeds + 2 * j] = std::sin(o.orders[j] * x);
        row[n_speeds + 2 * j + 1] = std::cos(o.orders[j] * x);
      }
      const double torque = d->actuator_force[m->actuator_outadr[dyno]];  // τext, N·m
      normal += row * row.transpose();
      rhs += row * torque;
      samples.emplace_back(row, torque);
    }
  }
  const Eigen::VectorXd c = normal.ldlt().solve(rhs);
  Identified out;
  for (int j = 0; j < n_harmonics; ++j) {
    const double a = c[n_speeds + 2 * j], b = c[n_speeds + 2 * j + 1];
    // K·sin(h·x + φ) = K·cos φ·sin(h·x) + K·sin φ·cos(h·x)
    out.harmonics.push_back(
        {.order = o.orders[j], .amplitude = std::hypot(a, b), .phase = std::atan2(b, a)});
  }
  // Constants c_i = Fs·sgn(ω_i) + B·ω_i: a line through them.
  double sw = 0, sww = 0, sc = 0, swc = 0;
  for (int i = 0; i < n_speeds; ++i) {
    const double w = std::abs(o.speeds[i]), ci = c[i] * (o.speeds[i] > 0 ? 1 : -1);
    sw += w;
    sww += w * w;
    sc += ci;
    swc += w * ci;
  }
  out.viscous_damping = (n_speeds * swc - sw * sc) / (n_speeds * sww - sw * sw);
  out.static_friction = (sc - out.viscous_damping * sw) / n_speeds;
  double sum_sq = 0;
  for (const auto& [row, torque] : samples) sum_sq += std::pow(torque - row.dot(c), 2);
  out.residual_rms = std::sqrt(sum_sq / std::max<size_t>(1, samples.size()));
  return out;
}

}  // namespace mjstepper::tools
