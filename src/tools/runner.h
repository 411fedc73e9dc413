// `mjstepper run`: step a model with command profiles on its steppers, log every signal to CSV.
#ifndef MJSTEPPER_TOOLS_RUNNER_H_
#define MJSTEPPER_TOOLS_RUNNER_H_

#include <cmath>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "config_overrides.h"
#include "render_options.h"

namespace mjstepper::tools {

/// How a run starts (SPEC §12, "Starting state").
enum class StartMode {
  /// A powered-up arm: when gravity loads a stepper at the start pose, the drives first hold their
  /// start commands for kSettleTime while gravity is ramped in (a half cosine over kSettleRamp,
  /// then held), so that each rotor sits at the load angle that holds its load when the measured
  /// motion starts; then the run's own clock starts (the log's time and the profiles' from there).
  /// Without such a load there is nothing to settle and the run starts at once.
  kSettled,
  /// Gravity at full strength at t = 0 on rotors at their aligned angle: the rotor overshoots to
  /// up to twice the static load angle (an arm dropped onto its motors).
  kAligned,
};

/// The settling phase of StartMode::kSettled, s: the ramp, then the hold. The ramp is slow
/// against the arms' modes (15-300 Hz: at least 4.5 periods of the slowest), so that it loads the
/// rotors quasi-statically; the hold lets what rings decay.
inline constexpr double kSettleRamp = 0.3;
inline constexpr double kSettleTime = 0.5;

struct RunOptions {
  std::string model;                        ///< MJCF path
  double duration = 1.0;                    ///< s of simulated time
  std::map<std::string, std::string> ctrl;  ///< actuator name → profile text
  /// A Klipper map file (core/klipper_steps.h): its dump's step commands drive the actuators it
  /// names, each as the step list of a --ctrl steps(FILE); empty for none.
  std::string klipper;
  std::string log;                        ///< CSV path; empty for none
  int log_every = 1;                      ///< log one row every N steps
  bool progress = true;                   ///< progress line on stderr for runs over ~2 s
  std::vector<ConfigOverride> overrides;  ///< e.g. shaft.damping=all
  std::map<std::string, double> loads;    ///< load actuator name → τl, N·m (SetLoadTorque)
  bool allow_coarse = false;              ///< run although a stepper mode's ω·h > 0.2
  bool judge_timestep = true;             ///< false when the caller judged the model already (size)
  std::string keyframe;                   ///< start from this keyframe; empty: qpos0
  StartMode start = StartMode::kSettled;  ///< settle under gravity first, or start aligned
  std::map<std::string, double> masses;   ///< body name → mass, kg (SetBodyMass)
  bool keep_traces = false;               ///< fill RunResult::traces (for studies and tests)
  RenderOptions render;                   ///< video and frames; off unless a path is given
  /// A virtual ADXL345 on the MuJoCo accelerometer sensor `accelerometer`, logged in Klipper's raw
  /// format (resonance.h) to `accel_log`; empty: none.
  std::string accel_log;
  std::string accelerometer = "toolhead_accel";
};

/// Per-step records of one stepper, at each step's start.
struct StepperTrace {
  std::vector<double> time;                 ///< s
  std::vector<double> omega_cmd;            ///< rad/s
  std::vector<double> velocity_error;       ///< rad/s, ω − ωcmd
  std::vector<double> current_a;            ///< A
  std::vector<double> load_angle;           ///< electrical rad
  std::vector<double> torque;               ///< N·m, τm + τdet (torque_total)
  std::vector<double> energy_copper;        ///< J, since the start
  std::vector<double> resistance;           ///< Ω, R(T_w)
  std::vector<double> winding_temperature;  ///< °C
  std::vector<double> housing_temperature;  ///< °C
};

struct StepperSummary {
  std::string name;
  std::string profile;
  double final_speed = 0;         ///< rad/s
  double rms_velocity_error = 0;  ///< rad/s, ω − ωcmd over the run
  double max_velocity_error = 0;  ///< rad/s, max |ω − ωcmd|
  double max_load_angle = 0;      ///< electrical rad, max |δ|
  double lost_steps = 0;          ///< full steps slipped at the end
  /// A linear axis's carriage at the last step's start (README, "Linear axes"): m/s and m; NaN
  /// on a rotary one.
  double carriage_speed = NAN, carriage_position = NAN;
};

struct RunResult {
  long steps = 0;
  double sim_time = 0;     ///< s
  double settle_time = 0;  ///< s the drives settled under gravity before the motion (kSettled)
  double wall_time = 0;    ///< s
  std::vector<StepperSummary> steppers;
  std::vector<StepperTrace> traces;  ///< one per stepper when RunOptions::keep_traces
  long frames = 0;                   ///< frames rendered
};

/// Throws std::runtime_error or std::invalid_argument with a message for the user.
RunResult Run(const RunOptions& options, std::ostream& progress);

void PrintSummary(const RunResult& result, const std::string& log, std::ostream& out);

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_RUNNER_H_
