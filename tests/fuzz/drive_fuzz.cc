// libFuzzer target over the drive core's Advance (core/drive.h) under any time, timestep, rotor
// angle, command and stored state (issue 16: a NaN or huge time, or a bad timestep, once made
// mj_step loop for ever). Built by tests/fuzz/run.sh with clang, -fsanitize=fuzzer,address,
// undefined; the core and the config parser only, no MuJoCo.
//
// One input is decoded (FuzzedDataProvider) into
//   - a drive: a few <config> attributes as config_fuzz draws them (fuzz_common.h); if the parser
//     refuses them, the default drive (so that every input reaches Advance);
//   - up to kMaxSteps steps, each from a start time and a step length drawn from the whole double
//     range (typical values, multiples and fractions of isr_period, lengths near the drive's
//     kMaxTicksPerAdvance bound, 0, denormals, negatives, 1e300, NaN, ±inf, any bit pattern), the
//     next step starting where the last ended or anywhere else; a rotor angle and a command drawn
//     the same way; and now and then stored doubles overwritten with any bit pattern, as a user
//     writing plugin_state could.
// Properties (a violation traps, so libFuzzer reports it with the input; run.sh's -timeout=1
// makes an input that runs over 1 s a failure too):
//   1. Advance returns, with no crash and no sanitizer report;
//   2. bad input is reported: a time not finite or running backwards is kBadTime and leaves the
//      state as it was; a rotor angle or command not finite or beyond kMaxCommand is kBadInput
//      and leaves it as it was; a step of more than kMaxTicksPerAdvance periods is kEventBound;
//      a valid time and input is never called bad, nor kOk at a coarse time (Drive::CoarseTime);
//   3. whenever the times and inputs were valid, the state after Advance is finite (every stored
//      double), whatever the state before; and while no stored double was overwritten, the
//      torque and the signals are finite too.
#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "config.h"
#include "core/drive.h"
#include "core/signals.h"
#include "fuzz_common.h"

const char* const mjstepper::fuzz::kTargetName = "drive_fuzz";

namespace {

using mjstepper::AdvanceStatus;
using mjstepper::Drive;
using mjstepper::DriveCoreState;
using mjstepper::DriveState;
using mjstepper::kMaxCommand;
using mjstepper::kMaxTicksPerAdvance;
using mjstepper::fuzz::AllFinite;
using mjstepper::fuzz::ConsumeAttributes;
using mjstepper::fuzz::ConsumeNumber;
using mjstepper::fuzz::Describe;
using mjstepper::fuzz::Fail;
using mjstepper::fuzz::NonFinite;
using mjstepper::plugin::AttributeNames;
using mjstepper::plugin::ParseStepperConfig;
using mjstepper::plugin::StepperConfig;

constexpr int kMaxSteps = 6;
constexpr double kTickBudget = 20000;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A double from the whole range, with the special values often.
double ConsumeAnyDouble(FuzzedDataProvider& in) {
  constexpr double kSpecial[] = {
      0.0,   -0.0,   kNaN,    kInf, -kInf, 5e-324, -5e-324,      2.2e-308,
      1e300, -1e300, 1.7e308, 1e13, 1.7e9, 1e10,   1.0000001e10, 9007199254740992.0};
  switch (in.ConsumeIntegralInRange<int>(0, 3)) {
    case 0:
      return in.PickValueInArray(kSpecial);
    case 1:
      return ConsumeNumber(in);
    case 2: {
      uint64_t bits = in.ConsumeIntegral<uint64_t>();
      double x;
      std::memcpy(&x, &bits, sizeof x);
      return x;
    }
    default:
      return in.ConsumeFloatingPointInRange<double>(-1e3, 1e3);
  }
}

// A time, s: mostly what simulations see (0 to days, Unix times, huge), else any double.
double ConsumeTime(FuzzedDataProvider& in) {
  switch (in.ConsumeIntegralInRange<int>(0, 4)) {
    case 0:
      return 0.0;
    case 1:
      return in.ConsumeFloatingPointInRange<double>(0.0, 10.0);
    case 2:
      return in.ConsumeFloatingPointInRange<double>(0.0, 1.0) *
             std::pow(10.0, in.ConsumeIntegralInRange<int>(3, 16));
    default:
      return ConsumeAnyDouble(in);
  }
}

// A step length, s, given the drive's period T: multiples and fractions of T, lengths at the
// event bound (at most once per input: such a step runs 1e5 interrupts, ~0.1 s under the
// sanitizers), else any double.
double ConsumeStep(FuzzedDataProvider& in, double period, bool* long_step_drawn) {
  switch (in.ConsumeIntegralInRange<int>(0, 5)) {
    case 0:
      return period * in.ConsumeIntegralInRange<int>(1, 100);
    case 1:
      return period / in.ConsumeIntegralInRange<int>(1, 64);
    case 2:
      return in.PickValueInArray({50e-6, 1e-3, 1e-6, 2e-3});
    case 3:  // just inside or outside the bound of one Advance
      if (*long_step_drawn || in.ConsumeIntegralInRange<int>(0, 7) != 0) return period;
      *long_step_drawn = true;
      return period * kMaxTicksPerAdvance * in.PickValueInArray({0.999, 1.0, 1.001, 2.0});
    default:
      return ConsumeAnyDouble(in);
  }
}

std::string Hex(double x) {
  char text[64];
  std::snprintf(text, sizeof text, "%a", x);
  return text;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider in(data, size);
  const std::map<std::string, std::string> attributes = ConsumeAttributes(in, AttributeNames());
  auto read = [&](const char* name) -> const char* {
    const auto it = attributes.find(name);
    return it == attributes.end() ? nullptr : it->second.c_str();
  };
  std::variant<StepperConfig, std::string> parsed = ParseStepperConfig(read);
  if (!std::holds_alternative<StepperConfig>(parsed)) {
    parsed = ParseStepperConfig([](const char*) -> const char* { return nullptr; });
  }
  const Drive drive(std::get<StepperConfig>(parsed).drive);
  const double period = drive.config().isr_period;  // s
  const int stored = drive.layout().controller + drive.layout().profile;
  const int total = drive.layout().total();

  std::string log = Describe(attributes) + "\n";
  double t = ConsumeTime(in);
  double theta = in.ConsumeFloatingPointInRange<double>(-100.0, 100.0);  // rad
  DriveState state =
      drive.Rest(std::isfinite(t) ? t : 0.0, theta, drive.CommandFrom(0.0, nullptr, theta));
  bool pristine = true;  // no stored double overwritten: the state is the drive's own
  bool long_step_drawn = false;
  double tick_budget = kTickBudget;
  const int steps = in.ConsumeIntegralInRange<int>(1, kMaxSteps);
  for (int step = 0; step < steps && in.remaining_bytes() > 0; ++step) {
    // The stored form, as the plugin keeps it, now and then with doubles overwritten.
    std::array<double, sizeof(DriveState) / sizeof(double)> values{};
    drive.Store(state, values.data());
    if (in.ConsumeIntegralInRange<int>(0, 3) == 0) {
      const int writes = in.ConsumeIntegralInRange<int>(1, total);
      for (int w = 0; w < writes; ++w) {
        const int i = in.ConsumeIntegralInRange<int>(0, total - 1);
        values[i] = ConsumeAnyDouble(in);
        log += "  stored[" + std::to_string(i) + "] = " + Hex(values[i]) + "\n";
      }
      pristine = false;
    }
    state = drive.Load(values.data());
    const DriveState before = state;

    const double t0 = in.ConsumeIntegralInRange<int>(0, 3) == 0 ? ConsumeTime(in) : t;
    const bool long_before = long_step_drawn;
    double t1 = in.ConsumeIntegralInRange<int>(0, 7) == 0
                    ? ConsumeTime(in)
                    : t0 + ConsumeStep(in, period, &long_step_drawn);
    // Besides the one step at the bound (ConsumeStep), at most kTickBudget interrupts an input,
    // so that inputs stay fast: a step that would pass it becomes one period long.
    const double ticks = (t1 - t0) / period;
    if (long_step_drawn == long_before && ticks > 0 && ticks <= kMaxTicksPerAdvance) {
      if (ticks > tick_budget) t1 = t0 + period;
      tick_budget -= std::min(ticks, tick_budget);
    }
    const double theta1 = in.ConsumeBool()
                              ? theta + in.ConsumeFloatingPointInRange<double>(-1.0, 1.0)
                              : ConsumeAnyDouble(in);
    const double command = in.ConsumeBool() ? in.ConsumeFloatingPointInRange<double>(-100.0, 100.0)
                                            : ConsumeAnyDouble(in);
    log += "  Advance(" + Hex(t0) + ", " + Hex(t1) + ", " + Hex(theta1) + ", " + Hex(command) + ")";
    const AdvanceStatus status = drive.Advance(&state, t0, t1, theta1, command);
    log += " -> " + std::to_string(static_cast<int>(status)) + "\n";

    // Property 2.
    const bool time_ok = std::isfinite(t0) && std::isfinite(t1) && t1 >= t0;
    const bool input_ok = std::abs(theta1) <= kMaxCommand && std::abs(command) <= kMaxCommand;
    const bool unchanged =
        std::memcmp(static_cast<const void*>(static_cast<const DriveCoreState*>(&before)),
                    static_cast<const void*>(static_cast<const DriveCoreState*>(&state)),
                    sizeof(DriveCoreState)) == 0 &&
        std::memcmp(before.unit.data(), state.unit.data(), stored * sizeof(double)) == 0;
    if (!time_ok) {
      if (status != AdvanceStatus::kBadTime) Fail("a bad time not reported as kBadTime", log);
      if (!unchanged) Fail("a bad time changed the state", log);
      continue;
    }
    if (!input_ok) {
      if (status != AdvanceStatus::kBadInput) Fail("a bad input not reported as kBadInput", log);
      if (!unchanged) Fail("a bad input changed the state", log);
      continue;
    }
    if (t1 - t0 > kMaxTicksPerAdvance * period && status != AdvanceStatus::kEventBound) {
      Fail("a step beyond kMaxTicksPerAdvance periods not reported as kEventBound", log);
    }
    const bool coarse = drive.CoarseTime(t0) || drive.CoarseTime(t1);
    // (A stored double that is not finite but is overwritten before it is read, say pending_a
    // while nothing is pending, is harmless: kOk. One that is read makes the result not finite,
    // which the drive finds and reports as kBadState; property 3 checks that it did.)
    if (status == AdvanceStatus::kOk && coarse) Fail("kOk for a coarse time", log);
    if (status == AdvanceStatus::kBadTime || status == AdvanceStatus::kBadInput) {
      Fail("a valid time and input reported as bad", log);
    }
    // Property 3.
    if (!AllFinite(reinterpret_cast<const double*>(static_cast<const DriveCoreState*>(&state)),
                   sizeof(DriveCoreState) / sizeof(double)) ||
        !AllFinite(state.unit.data(), stored)) {
      Fail("non-finite state after a valid Advance", log + NonFinite(state, stored));
    }
    if (pristine) {
      if (!std::isfinite(drive.Torque(state, theta1))) Fail("non-finite torque", log);
      const auto signals = mjstepper::SignalValues(drive.Signals(state, theta1));
      if (!AllFinite(signals.data(), static_cast<int>(signals.size()))) {
        Fail("non-finite signal", log);
      }
    }
    t = t1;
    theta = theta1;
  }
  // MJSTEPPER_FUZZ_LOG=1: the input's attributes and steps on stderr (to read a slow input).
  if (std::getenv("MJSTEPPER_FUZZ_LOG") != nullptr) std::fprintf(stderr, "%s", log.c_str());
  return 0;
}
