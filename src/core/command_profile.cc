#include "core/command_profile.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "core/attributes.h"  // Excerpt
#include "core/units.h"

namespace mjstepper {
namespace {

enum class Dim { kSpeed, kAngle, kTime, kAcceleration };

// Units of length (m), speed (m/s) and acceleration (m/s²) along a linear axis, in metres; the
// rotor's radians are gear times them (θ = gear·x).
struct LinearUnit {
  const char* name;
  double metres;  // per unit
  Dim dim;
};
constexpr LinearUnit kLinearUnits[] = {{"m", 1.0, Dim::kAngle},
                                       {"mm", 1e-3, Dim::kAngle},
                                       {"m/s", 1.0, Dim::kSpeed},
                                       {"mm/s", 1e-3, Dim::kSpeed},
                                       {"m/s²", 1.0, Dim::kAcceleration},
                                       {"m/s^2", 1.0, Dim::kAcceleration},
                                       {"mm/s²", 1e-3, Dim::kAcceleration},
                                       {"mm/s^2", 1e-3, Dim::kAcceleration}};

struct Quantity {
  double value = 0;  // SI
  Dim dim = Dim::kSpeed;
};

std::string Trim(std::string_view s) {
  const size_t b = s.find_first_not_of(" \t");
  if (b == std::string_view::npos) return "";
  const size_t e = s.find_last_not_of(" \t");
  return std::string(s.substr(b, e - b + 1));
}

Quantity ParseQuantity(const std::string& text, std::string_view whole,
                       std::optional<double> rad_per_metre) {
  const std::string t = Trim(text);
  double v = 0;
  const char* begin = t.data() + (!t.empty() && t[0] == '+' ? 1 : 0);
  const auto [ptr, ec] = std::from_chars(begin, t.data() + t.size(), v);
  if (ec != std::errc() || !std::isfinite(v)) {
    throw std::invalid_argument(fmt::format("profile \"{}\": \"{}\" is not a number with a unit",
                                            Excerpt(whole), Excerpt(t)));
  }
  const std::string unit = Trim(std::string_view(ptr, t.data() + t.size() - ptr));
  Quantity q;
  const auto linear = std::find_if(std::begin(kLinearUnits), std::end(kLinearUnits),
                                   [&unit](const LinearUnit& u) { return unit == u.name; });
  if (linear != std::end(kLinearUnits)) {
    if (!rad_per_metre) {
      throw std::invalid_argument(fmt::format(
          "profile \"{}\": \"{}\" is in {}, a linear unit: it needs a stepper on a slide joint "
          "or a tendon (θ = gear·x), or on a hinge whose <config> declares its carriage "
          "(pulley_teeth and belt_pitch, or lead); else give rad, deg, rpm, r/min, rad/s or "
          "rad/s²",
          Excerpt(whole), Excerpt(t), unit));
    }
    // rad, rad/s, or rad/s² (a rate: a negative gear turns the motion, not the rate)
    const double scale =
        linear->dim == Dim::kAcceleration ? std::abs(*rad_per_metre) : *rad_per_metre;
    q = {scale * (v * linear->metres), linear->dim};
  } else if (unit == "rpm" || unit == "r/min") {
    q = {RpmToRadPerSec(v), Dim::kSpeed};
  } else if (unit == "rad/s") {
    q = {v, Dim::kSpeed};
  } else if (unit == "rad/s²" || unit == "rad/s^2") {
    q = {v, Dim::kAcceleration};
  } else if (unit == "rad") {
    q = {v, Dim::kAngle};
  } else if (unit == "deg") {
    q = {v * kTwoPi / 360.0, Dim::kAngle};
  } else if (unit == "s") {
    q = {v, Dim::kTime};
  } else if (unit == "ms") {
    q = {v * 1e-3, Dim::kTime};
  } else {
    throw std::invalid_argument(fmt::format(
        "profile \"{}\": \"{}\" needs a unit: rpm, r/min, rad/s, rad/s², rad, deg, s or ms (on "
        "a slide joint, a tendon or a hinge with a declared carriage also m, mm, m/s, mm/s, m/s², "
        "mm/s²)",
        Excerpt(whole), Excerpt(t)));
  }
  const double bound = q.dim == Dim::kSpeed          ? kMaxProfileSpeed
                       : q.dim == Dim::kAngle        ? kMaxProfileAngle
                       : q.dim == Dim::kAcceleration ? kMaxProfileAcceleration
                                                     : kMaxProfileTime;
  const char* bound_unit = q.dim == Dim::kSpeed          ? "rad/s"
                           : q.dim == Dim::kAngle        ? "rad"
                           : q.dim == Dim::kAcceleration ? "rad/s²"
                                                         : "s";
  if (!(std::abs(q.value) <= bound)) {
    throw std::invalid_argument(fmt::format("profile \"{}\": \"{}\" is beyond ±{:g} {}",
                                            Excerpt(whole), Excerpt(t), bound, bound_unit));
  }
  return q;
}

// The time to change speed by `change` (rad/s) at `acceleration` (rad/s²), s.
double RampTime(double change, double acceleration, std::string_view whole) {
  if (!(acceleration > 0)) {
    throw std::invalid_argument(
        fmt::format("profile \"{}\": an acceleration must be > 0 (a rate, not a signed value)",
                    Excerpt(whole)));
  }
  const double time = std::abs(change) / acceleration;  // s
  if (!(time <= kMaxProfileTime)) {
    throw std::invalid_argument(
        fmt::format("profile \"{}\": its acceleration takes {:g} s, beyond {:g} s", Excerpt(whole),
                    time, kMaxProfileTime));
  }
  return time;
}

}  // namespace

// shaped(PROFILE, TYPE FREQUENCYHz [DAMPING]): the shaper after the last comma (it has none).
CommandProfile CommandProfile::ParseShaped(const std::string& whole, const std::string& inner,
                                           std::optional<double> rad_per_metre) {
  const size_t comma = inner.rfind(',');
  auto bad = [&](const std::string& why) {
    return std::invalid_argument(fmt::format(
        "profile \"{}\": {}; expected shaped(PROFILE, TYPE FREQUENCYHz [DAMPING]), e.g. "
        "shaped(trapezoid(200rpm, 0.2s, 0.5s, 0.2s), mzv 40Hz)",
        Excerpt(whole), why));
  };
  if (comma == std::string::npos || inner.find(')', comma) != std::string::npos) {
    throw bad("no shaper after the profile");
  }
  std::istringstream fields(inner.substr(comma + 1));
  std::string type_text, frequency_text, damping_text, extra;
  fields >> type_text >> frequency_text >> damping_text >> extra;
  if (type_text.empty() || frequency_text.empty() || !extra.empty()) {
    throw bad("the shaper is a type, a frequency and at most a damping ratio");
  }
  ShaperType type;
  try {
    type = ParseShaperType(type_text);
  } catch (const std::invalid_argument& e) {
    throw bad(e.what());
  }
  double frequency = 0;  // Hz
  const auto [ptr, ec] = std::from_chars(frequency_text.data(),
                                         frequency_text.data() + frequency_text.size(), frequency);
  std::string unit(ptr, static_cast<const char*>(frequency_text.data() + frequency_text.size()));
  for (char& c : unit) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ec != std::errc() || unit != "hz") {
    throw bad(fmt::format("\"{}\" is not a frequency in Hz", frequency_text));
  }
  double damping = kDefaultShaperDamping;
  if (!damping_text.empty()) {
    const char* end = damping_text.data() + damping_text.size();
    const auto [dptr, dec] = std::from_chars(damping_text.data(), end, damping);
    if (dec != std::errc() || dptr != end) {
      throw bad(fmt::format("\"{}\" is not a damping ratio", damping_text));
    }
  }
  CommandProfile p = Parse(inner.substr(0, comma), rad_per_metre);
  InputShaper shaper;
  try {
    shaper = MakeShaper(type, frequency, damping);
  } catch (const std::invalid_argument& e) {
    throw bad(e.what());
  }
  if (shaper.duration() > kMaxProfileTime) throw bad("the shaper is longer than 1e6 s");
  p.shaper_ = std::make_shared<const InputShaper>(p.shaper_ ? Convolve(*p.shaper_, shaper)
                                                            : std::move(shaper));
  p.text_ = whole;
  return p;
}

// targets(A0, A1@T1, A2@T2, …): A0 from t = 0 (or A0@T0), each angle from its time on.
CommandProfile CommandProfile::ParseTargets(const std::string& whole, const std::string& inner,
                                            std::optional<double> rad_per_metre) {
  auto bad = [&](const std::string& why) {
    return std::invalid_argument(fmt::format(
        "profile \"{}\": {}; expected targets(ANGLE, ANGLE@TIME, …), times rising from 0, e.g. "
        "targets(0deg, 90deg@0.5s, 0deg@2s)",
        Excerpt(whole), why));
  };
  std::vector<Target> targets;
  size_t start = 0;
  while (true) {
    const size_t comma = inner.find(',', start);
    const std::string item = inner.substr(start, comma - start);
    const size_t at = item.find('@');
    Target target;
    const Quantity angle = ParseQuantity(item.substr(0, at), whole, rad_per_metre);
    if (angle.dim != Dim::kAngle) throw bad(fmt::format("\"{}\" is not an angle", Trim(item)));
    target.angle = angle.value;
    if (at != std::string::npos) {
      const Quantity time = ParseQuantity(item.substr(at + 1), whole, rad_per_metre);
      if (time.dim != Dim::kTime || !(time.value >= 0)) {
        throw bad(fmt::format("\"{}\": the time after @ must be >= 0 s", Trim(item)));
      }
      target.time = time.value;
    } else if (!targets.empty()) {
      throw bad(fmt::format("\"{}\" has no @TIME (only the first target may omit it)", Trim(item)));
    }
    if (!targets.empty() && !(target.time > targets.back().time)) {
      throw bad(fmt::format("\"{}\": times must rise", Trim(item)));
    }
    if (targets.size() >= kMaxTargets) throw bad(fmt::format("more than {} targets", kMaxTargets));
    targets.push_back(target);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  CommandProfile p;
  p.text_ = whole;
  p.kind_ = Kind::kTargets;
  p.targets_ = std::make_shared<const std::vector<Target>>(std::move(targets));
  return p;
}

CommandProfile CommandProfile::Parse(std::string_view text, std::optional<double> rad_per_metre) {
  if (text.size() > kMaxProfileText) {  // before any work, or any copy (issue 33)
    throw std::invalid_argument(
        fmt::format("profile \"{}\": longer than {} characters", Excerpt(text), kMaxProfileText));
  }
  const std::string whole(text);
  const size_t open = whole.find('(');
  const size_t close = whole.rfind(')');
  if (open == std::string::npos || close == std::string::npos || close < open ||
      !Trim(whole.substr(close + 1)).empty()) {
    throw std::invalid_argument(
        fmt::format("profile \"{}\": expected constant(…), ramp(…, …, …), trapezoid(…, …, …, …), "
                    "targets(…), steps(FILE) or shaped(PROFILE, SHAPER)",
                    Excerpt(whole)));
  }
  const std::string name = Trim(whole.substr(0, open));
  if (name == "shaped") {
    // Bounded before the recursion: every "shaped" followed by "(" (spaces between allowed).
    size_t nested = 0;
    for (size_t at = whole.find("shaped"); at != std::string::npos;
         at = whole.find("shaped", at + 6)) {
      const size_t next = whole.find_first_not_of(" \t", at + 6);
      if (next != std::string::npos && whole[next] == '(') ++nested;
    }
    if (nested > kMaxNestedShapers) {
      throw std::invalid_argument(fmt::format(
          "profile \"{}…\": {} shaped(…) nested, at most {} (each is a shaper in series)",
          Excerpt(whole), nested, kMaxNestedShapers));
    }
    return ParseShaped(whole, whole.substr(open + 1, close - open - 1), rad_per_metre);
  }
  if (name == "steps") {  // a file of step times, not quantities
    CommandProfile p;
    p.text_ = whole;
    p.kind_ = Kind::kStepList;
    p.steps_ = std::make_shared<const StepTimes>(
        StepTimes::Read(Trim(whole.substr(open + 1, close - open - 1))));
    return p;
  }
  std::string inner = whole.substr(open + 1, close - open - 1);
  if (name == "targets") return ParseTargets(whole, inner, rad_per_metre);
  std::vector<Quantity> args;
  size_t start = 0;
  while (true) {
    const size_t comma = inner.find(',', start);
    args.push_back(ParseQuantity(inner.substr(start, comma - start), whole, rad_per_metre));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  auto bad = [&](const char* expected) {
    return std::invalid_argument(
        fmt::format("profile \"{}\": expected {}", Excerpt(whole), expected));
  };
  CommandProfile p;
  p.text_ = whole;
  if (name == "constant") {
    if (args.size() != 1 || (args[0].dim != Dim::kSpeed && args[0].dim != Dim::kAngle))
      throw bad("constant(speed) or constant(angle)");
    p.kind_ = args[0].dim == Dim::kSpeed ? Kind::kConstantSpeed : Kind::kAngleHold;
    p.a_ = args[0].value;
  } else if (name == "ramp") {
    // A speed ramp may give its acceleration instead of its duration: T = |to − from|/a.
    if (args.size() == 3 && args[0].dim == Dim::kSpeed && args[1].dim == Dim::kSpeed &&
        args[2].dim == Dim::kAcceleration) {
      args[2] = {RampTime(args[1].value - args[0].value, args[2].value, whole), Dim::kTime};
    }
    if (args.size() != 3 || args[0].dim != args[1].dim || args[0].dim == Dim::kTime ||
        args[0].dim == Dim::kAcceleration || args[2].dim != Dim::kTime || !(args[2].value > 0)) {
      throw bad(
          "ramp(from, to, duration > 0), from and to both speeds or both angles (a speed ramp "
          "may give its acceleration instead of its duration)");
    }
    p.kind_ = args[0].dim == Dim::kSpeed ? Kind::kSpeedRamp : Kind::kAngleRamp;
    if (p.kind_ == Kind::kAngleRamp &&
        !(std::abs(args[1].value - args[0].value) / args[2].value <= kMaxProfileSpeed)) {
      throw bad("an angle ramp no faster than 1e4 rad/s");
    }
    p.a_ = args[0].value;
    p.b_ = args[1].value;
    p.t1_ = args[2].value;
  } else if (name == "trapezoid") {
    // Its acceleration and deceleration may be rates instead of times: T = |peak|/a.
    for (size_t k : {size_t{1}, size_t{3}}) {
      if (args.size() == 4 && args[0].dim == Dim::kSpeed && args[k].dim == Dim::kAcceleration) {
        args[k] = {RampTime(args[0].value, args[k].value, whole), Dim::kTime};
      }
    }
    if (args.size() != 4 || args[0].dim != Dim::kSpeed || args[1].dim != Dim::kTime ||
        args[2].dim != Dim::kTime || args[3].dim != Dim::kTime || !(args[1].value >= 0) ||
        !(args[2].value >= 0) || !(args[3].value >= 0)) {
      throw bad(
          "trapezoid(peak speed, accel time, cruise time, decel time), times >= 0 (accel and "
          "decel may be accelerations instead)");
    }
    p.kind_ = Kind::kTrapezoid;
    p.a_ = args[0].value;
    p.t1_ = args[1].value;
    p.t2_ = args[2].value;
    p.t3_ = args[3].value;
  } else {
    throw bad(
        "constant(…), ramp(…, …, …), trapezoid(…, …, …, …), targets(…), steps(FILE) or "
        "shaped(PROFILE, SHAPER)");
  }
  return p;
}

double CommandProfile::Speed(double t, double step_angle) const {
  if (!shaper_) return RawSpeed(t, step_angle);
  double speed = 0;  // rad/s, Σ A_i·speed(t − T_i)
  for (size_t i = 0; i < shaper_->times.size(); ++i) {
    speed += shaper_->amplitudes[i] * RawSpeed(t - shaper_->times[i], step_angle);
  }
  return speed;
}

double CommandProfile::Angle(double t, double step_angle) const {
  if (kind_ == Kind::kStepList) return StepCount(t) * step_angle;
  if (!shaper_) return RawAngle(t, step_angle);
  double angle = 0, at_zero = 0;  // rad, Σ A_i·angle(t − T_i) and its value at t = 0
  for (size_t i = 0; i < shaper_->times.size(); ++i) {
    angle += shaper_->amplitudes[i] * RawAngle(t - shaper_->times[i], step_angle);
    if (!absolute_angle()) at_zero += shaper_->amplitudes[i] * RawAngle(-shaper_->times[i], 0);
  }
  return angle - at_zero;
}

double CommandProfile::StepCount(double t) const {
  if (!shaper_) return steps_->Count(t);
  double count = 0;  // Σ A_i·count(t − T_i); counts before t = 0 are 0
  for (size_t i = 0; i < shaper_->times.size(); ++i) {
    count += shaper_->amplitudes[i] * steps_->Count(t - shaper_->times[i]);
  }
  return std::round(count);
}

double CommandProfile::RawSpeed(double t, double step_angle) const {
  switch (kind_) {
    case Kind::kStepList:
      return steps_->Rate(t) * step_angle;
    case Kind::kConstantSpeed:
      return a_;
    case Kind::kAngleHold:
    case Kind::kTargets:
      return 0.0;
    case Kind::kSpeedRamp:
      return t <= 0 ? a_ : t >= t1_ ? b_ : a_ + (b_ - a_) * t / t1_;
    case Kind::kAngleRamp:
      return t >= 0 && t < t1_ ? (b_ - a_) / t1_ : 0.0;
    case Kind::kTrapezoid: {
      if (t <= 0) return 0.0;
      if (t < t1_) return a_ * t / t1_;
      if (t < t1_ + t2_) return a_;
      if (t < t1_ + t2_ + t3_) return a_ * (t1_ + t2_ + t3_ - t) / t3_;
      return 0.0;
    }
  }
  return 0.0;
}

double CommandProfile::RawAngle(double t, double step_angle) const {
  switch (kind_) {
    case Kind::kStepList:
      return steps_->Count(t) * step_angle;
    case Kind::kConstantSpeed:
      return a_ * t;
    case Kind::kAngleHold:
      return a_;
    case Kind::kTargets: {  // the last target whose time has come (the first before it)
      const auto next =
          std::upper_bound(targets_->begin(), targets_->end(), t,
                           [](double time, const Target& x) { return time < x.time; });
      return next == targets_->begin() ? next->angle : std::prev(next)->angle;
    }
    case Kind::kSpeedRamp: {
      if (t <= 0) return a_ * t;
      const double tr = std::min(t, t1_);
      return a_ * tr + 0.5 * (b_ - a_) * tr * tr / t1_ + b_ * (t - tr);
    }
    case Kind::kAngleRamp:
      return a_ + (b_ - a_) * std::clamp(t / t1_, 0.0, 1.0);
    case Kind::kTrapezoid: {
      if (t <= 0) return 0.0;
      const double ta = std::min(t, t1_);
      double angle = 0.5 * a_ * ta * ta / std::max(t1_, 1e-300);
      if (t <= t1_) return angle;
      angle += a_ * (std::min(t, t1_ + t2_) - t1_);
      if (t <= t1_ + t2_) return angle;
      const double td = std::min(t, t1_ + t2_ + t3_) - (t1_ + t2_);
      return angle + a_ * td - 0.5 * a_ * td * td / std::max(t3_, 1e-300);
    }
  }
  return 0.0;
}

std::optional<StepTimes> CommandProfile::PulseTimes() const {
  if (kind_ != Kind::kStepList) return std::nullopt;
  if (!shaper_) return *steps_;
  const std::size_t n = shaper_->times.size();
  if (steps_->size() > kMaxStepTimes / std::max<std::size_t>(n, 1)) return std::nullopt;
  // Each step j of the list, delayed by each impulse i, moves the shaped sum by A_i·dir_j at
  // t_j + T_i; the shaped count is the sum rounded (StepCount), so a pulse is emitted wherever
  // the rounded sum changes, as many as it changes by.
  struct Event {
    double time, weight;
  };
  std::vector<Event> events;
  events.reserve(steps_->size() * n);
  double previous = 0;
  for (std::size_t j = 0; j < steps_->size(); ++j) {
    const double count = steps_->CountAt(j);
    for (std::size_t i = 0; i < n; ++i) {
      events.push_back(
          {steps_->TimeAt(j) + shaper_->times[i], shaper_->amplitudes[i] * (count - previous)});
    }
    previous = count;
  }
  std::stable_sort(events.begin(), events.end(),
                   [](const Event& a, const Event& b) { return a.time < b.time; });
  std::vector<double> times, directions;
  double sum = 0, rounded = 0;
  for (std::size_t k = 0; k < events.size();) {
    const double t = events[k].time;
    for (; k < events.size() && events[k].time == t; ++k) sum += events[k].weight;
    const double now = std::round(sum);
    for (; rounded != now && times.size() < kMaxStepTimes; rounded += now > rounded ? 1 : -1) {
      times.push_back(t);
      directions.push_back(now > rounded ? 1 : -1);
    }
  }
  if (times.empty() || times.size() >= kMaxStepTimes) return std::nullopt;
  return StepTimes::FromSteps(times, directions, text_);
}

double CommandProfile::ControlForStep(double t, double h, InputMode input, double theta_start,
                                      double step_angle) const {
  if (input == InputMode::kVelocity) return (Angle(t + h) - Angle(t)) / h;
  if (kind_ == Kind::kStepList) {  // the count of the start angle, plus the list's count
    const double start = step_angle > 0 ? std::round(theta_start / step_angle) : 0.0;
    return input == InputMode::kSteps ? start + StepCount(t + h)
                                      : theta_start + Angle(t + 0.5 * h, step_angle);
  }
  if (input == InputMode::kSteps) {
    const double angle = (absolute_angle() ? 0.0 : theta_start) + Angle(t + h);  // rad
    return step_angle > 0 ? std::round(angle / step_angle) : 0.0;
  }
  return (absolute_angle() ? 0.0 : theta_start) + Angle(t + 0.5 * h);
}

}  // namespace mjstepper
