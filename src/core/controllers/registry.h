// The closed set of controllers a drive can hold: one line per controller. Adding one means its
// file, a line here, and its tests; the parser, the attribute list and the README's tables follow.
#ifndef MJSTEPPER_CORE_CONTROLLERS_REGISTRY_H_
#define MJSTEPPER_CORE_CONTROLLERS_REGISTRY_H_

#include <string>
#include <variant>
#include <vector>

#include "core/controllers/constant_off_time.h"
#include "core/controllers/current_microstep.h"
#include "core/controllers/high_gain_foc.h"
#include "core/controllers/servo.h"
#include "core/controllers/spread_cycle.h"
#include "core/controllers/stealth_chop.h"
#include "core/controllers/stmms.h"
#include "core/controllers/voltage_microstep.h"

namespace mjstepper {

using Controller = std::variant<CurrentMicrostep,  // the default (index 0)
                                VoltageMicrostep, IdealCurrent, Servo, Identification, Stmms,
                                HighGainFoc, ConstantOffTime, SpreadCycle, StealthChop>;

namespace internal {
template <class V>
struct AllUnits;
template <class... C>
struct AllUnits<std::variant<C...>> {
  static constexpr bool value = (ControllerUnit<C> && ...);
};
}  // namespace internal
static_assert(internal::AllUnits<Controller>::value, "every registered controller is a unit");

/// Calls f.template operator()<C>() for each registered controller type C, in registry order.
template <class F>
void ForEachControllerType(F&& f) {
  [&]<class... C>(std::variant<C...>*) {
    (f.template operator()<C>(), ...);
  }(static_cast<Controller*>(nullptr));
}

/// The MJCF name of the controller a drive holds (`drive` attribute).
inline const char* ControllerName(const Controller& c) {
  return std::visit([](const auto& unit) { return std::decay_t<decltype(unit)>::kName; }, c);
}

/// How the controller's holding stiffness is obtained, e.g. "Nr·Km·I, T(1)".
inline const char* StiffnessFormula(const Controller& c) {
  return std::visit(
      [](const auto& unit) { return std::decay_t<decltype(unit)>::kStiffnessFormula; }, c);
}

/// Every controller's name, in registry order.
std::vector<std::string> ControllerNames();

/// The controller named `name`, built from its own attributes; throws ConfigError on bad values,
/// std::out_of_range for an unknown name.
Controller MakeController(const std::string& name, const AttributeSource& attributes,
                          const MotorParams& motor, const DriveConstants& constants);

/// The attributes `name` reads (empty for an unknown name).
std::vector<const AttributeSpec*> ControllerAttributes(const std::string& name);

/// Every controller attribute, each once, in registry order of first use.
std::vector<const AttributeSpec*> AllControllerAttributes();

/// The names of the controllers that read `attribute`.
std::vector<std::string> ControllersReading(const std::string& attribute);

/// The harmonic compensation a controller applies, or null for one that has none.
/// The drive's StallGuard (sensors/stallguard.h), or nullptr for a drive that has none (version 0
/// included).
inline const StallGuard* StallGuardOf(const Controller& c) {
  return std::visit(
      [](const auto& unit) -> const StallGuard* {
        if constexpr (requires { unit.stallguard.version; }) {
          return unit.stallguard.version > 0 ? &unit.stallguard : nullptr;
        } else {
          return nullptr;
        }
      },
      c);
}

inline const HarmonicCompensation* Damping(const Controller& c) {
  return std::visit(
      [](const auto& unit) -> const HarmonicCompensation* {
        if constexpr (requires { unit.damping.harmonics; }) {
          return &unit.damping;
        } else if constexpr (requires { unit.setpoint.damping; }) {
          return &unit.setpoint.damping;
        } else {
          return nullptr;
        }
      },
      c);
}

/// The microsteps per full step of a controller's current table (0: continuous, or none).
inline int Microsteps(const Controller& c) {
  return std::visit(
      [](const auto& unit) -> int {
        if constexpr (requires { unit.table.microsteps; }) {
          return unit.table.microsteps;
        } else if constexpr (requires { unit.setpoint.microsteps; }) {
          return unit.setpoint.microsteps;
        } else {
          return 0;
        }
      },
      c);
}

/// The damping harmonics a PI loop's setpoint carries (T(13) of `current_microstep`, T(8) of
/// `identification`; the servo's are in its held iq*): what an averaged loop's closed form
/// carries term by term (averaged_current_loop.h, at most kAveragedLoopHarmonics).
inline std::size_t LoopSetpointHarmonics(const Controller& c) {
  return std::visit(
      [](const auto& unit) -> std::size_t {
        if constexpr (requires {
                        unit.setpoint.damping.harmonics;
                        unit.loop;
                      }) {
          return unit.setpoint.damping.harmonics.size();
        } else {
          return 0;
        }
      },
      c);
}

/// Whether a controller's bridges switch (a chopper: switching.h's SwitchingUnit).
inline bool IsSwitching(const Controller& c) {
  return std::visit([](const auto& unit) { return SwitchingUnit<std::decay_t<decltype(unit)>>; },
                    c);
}

/// A voltage unit whose tick can span any time at once (StealthChop's Span): its averaged form
/// runs one span per interval between events instead of one tick per interrupt (SPEC §11).
template <class C>
concept SpanUnit = requires(const C& u, const DriveConstants& k, const typename C::Input& in,
                            const PowerStage& ps, typename C::State* st) {
  u.Span(k, in, 0.0, 1.0, ps, st);
  u.SpanTicks(k, *st);
  u.LongestSpan(k);
};

/// A voltage unit whose interrupts sample a rotating phasor of constant amplitude (K(5)): its
/// averaged form is that phasor, continuous, on the exact winding solution over any interval
/// (winding.h, AdvanceRotatingVoltage).
template <class C>
concept RotatingVoltageUnit = requires(const C& u) {
  { u.RotatingAmplitude() } -> std::same_as<double>;
};

/// A PI current loop in the commanded frame (T(9)-(13)): its averaged form is the loop's
/// continuous closed-loop response (averaged_current_loop.h).
template <class C>
concept CurrentLoopUnit = std::same_as<C, CurrentMicrostep>;

/// A PI current loop in the encoder's frame (the servo and identification, T(18)): its averaged
/// form is the same continuous closed-loop response in that frame, the setpoint's iq* held
/// between the position loop's updates (averaged_current_loop.h).
template <class C>
concept FieldOrientedUnit = requires(const C& u, const DriveConstants& k, const Sample& in,
                                     const typename C::State& st) {
  { u.LoopSetpoint() } -> std::same_as<const MicrostepSetpoint&>;
  { u.HeldIq(k, in, st) } -> std::same_as<double>;
  u.loop;
};

/// A position law feeding its voltage forward with no current feedback (Kim's STMMS, K(28)): its
/// averaged form is the law's continuous voltage, a polynomial in the rotor's frame over a step, on
/// the winding's exact solution (averaged_feed_forward.h).
template <class C>
concept FeedForwardUnit = std::same_as<C, Stmms>;

/// The same position law with current feedback at ρ (Kim's high-gain FOC, K(33)): its averaged form
/// solves the law's continuous voltage with the winding as a real 2×2 system in the rotor's frame
/// (the law reads Im of the current for ω̇; averaged_feed_forward.h, F-3).
template <class C>
concept HighGainFocUnit = std::same_as<C, HighGainFoc>;

/// An ideal source: no clock, no windings; its averaged form is itself.
template <class C>
concept IdealSourceUnit = requires {
  C::kIdealSource;
};

/// A unit with an averaged form: a chopper (averaged_bridge.h), a SpanUnit, a rotating voltage, a
/// PI current loop (in the command's frame or the encoder's), one of Kim's position laws (the
/// STMMS's feed-forward, the high-gain FOC) or an ideal source.
template <class C>
concept AveragedUnit =
    SwitchingUnit<C> || SpanUnit<C> || RotatingVoltageUnit<C> || CurrentLoopUnit<C> ||
    FieldOrientedUnit<C> || FeedForwardUnit<C> || HighGainFocUnit<C> || IdealSourceUnit<C>;

namespace internal {
template <class V>
struct EveryUnitAveraged;
template <class... C>
struct EveryUnitAveraged<std::variant<C...>> : std::bool_constant<(AveragedUnit<C> && ...)> {};
}  // namespace internal
// SPEC §11, issue 30: every drive has an averaged form (fidelity = averaged).
static_assert(internal::EveryUnitAveraged<Controller>::value,
              "a drive without an averaged form (fidelity = averaged)");

/// The speed feedback a controller uses unless the user says otherwise.
SpeedFeedback DefaultSpeedFeedback(const Controller& c);

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_CONTROLLERS_REGISTRY_H_
