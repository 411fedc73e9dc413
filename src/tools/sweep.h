// Runs over a list of speeds, spread over worker threads, one mjData each:
// - `mjstepper sweep`, the resonance map of a stepper: each run ramps to its speed, settles, then
//   measures the velocity error ω − ωcmd: RMS, peak-to-peak and dominant frequency;
// - `mjstepper pullout`, the datasheet's pull-out torque curve: each run ramps to its speed,
//   settles, then loads the rotor with a torque rising against the motion until the first slip.
#ifndef MJSTEPPER_TOOLS_SWEEP_H_
#define MJSTEPPER_TOOLS_SWEEP_H_

#include <cmath>
#include <iosfwd>
#include <string>
#include <vector>

#include "config_overrides.h"
#include "options.h"  // ParseSpeedList

namespace mjstepper::tools {

struct SweepOptions {
  std::string model;           ///< MJCF path
  std::string actuator;        ///< the stepper swept; empty: the model's only one
  std::vector<double> speeds;  ///< rad/s
  /// The speeds are m/s at the stepper's carriage (mm/s, m/s; a linear axis, README "Linear
  /// axes"), converted with its rad per metre (RadPerMetre) once the model is loaded.
  bool speeds_at_carriage = false;
  double acceleration = 209.44;           ///< rad/s² of the ramp to each speed (2000 r/min/s)
  double settle = 0.4;                    ///< s after the ramp before measuring
  double measure = 0.5;                   ///< s measured
  int threads = 0;                        ///< 0: one per core
  std::vector<ConfigOverride> overrides;  ///< e.g. shaft.damping=all
  bool allow_coarse = false;  ///< run although a stepper mode's ω·h > 0.2 (ApplyTimestepRule)
  bool progress = true;
};

struct SweepPoint {
  double speed = 0;               ///< rad/s, commanded
  double rms_error = 0;           ///< rad/s, RMS of ω − ωcmd over the measured window
  double peak_to_peak_error = 0;  ///< rad/s
  double dominant_frequency = 0;  ///< Hz, of the velocity error, searched in [5, 1000] Hz
  double lost_steps = 0;          ///< full steps slipped by the end
  double carriage_speed = NAN;    ///< m/s, commanded, at a linear axis's carriage; NaN: rotary
};

struct PullOutOptions {
  std::string model;  ///< MJCF path
  /// The MJCF text itself, read in place of the file `model` (which then only names it), e.g.
  /// `mjstepper size`'s bench; no overrides with it.
  std::string model_text;
  std::string actuator;        ///< the stepper; empty: the model's only one
  std::vector<double> speeds;  ///< rad/s
  /// The speeds are m/s at the stepper's carriage (mm/s, m/s; a linear axis, README "Linear
  /// axes"), converted with its rad per metre (RadPerMetre) once the model is loaded.
  bool speeds_at_carriage = false;
  double acceleration = 209.44;           ///< rad/s² of the ramp to each speed (2000 r/min/s)
  double settle = 0.3;                    ///< s at speed before the load starts
  double rate = 0.5;                      ///< N·m/s, rotor side: how fast the load torque rises
  double max_torque = 5;                  ///< N·m: a run that holds this much ends there
  int threads = 0;                        ///< 0: one per core
  std::vector<ConfigOverride> overrides;  ///< e.g. shaft.bus_voltage=24
  bool allow_coarse = false;  ///< run although a stepper mode's ω·h > 0.2 (ApplyTimestepRule)
  /// false for `size`'s bench, whose timestep is the sized model's, judged there on the model
  bool judge_timestep = true;
  bool progress = true;
};

/// The motor's torque that caps a pull-out point is its mean over this window, s (RunPullOut):
/// the electrical cycle at 10 rad/s for Nr = 50 is 12.6 ms, the microstep ripple's much shorter.
inline constexpr double kPullOutWindow = 0.01;

struct PullOutPoint {
  double speed = 0;   ///< rad/s, commanded
  double torque = 0;  ///< N·m, rotor side: the load last held before the first slip (RunPullOut)
  bool slipped_unloaded = false;  ///< it slipped before the load started (torque 0)
  bool held_max = false;          ///< it held max_torque without slipping
  double carriage_speed = NAN;    ///< m/s, commanded, at a linear axis's carriage; NaN: rotary
  double force = NAN;             ///< N, `torque` at that carriage; NaN: rotary
};

/// `mjstepper map`: the sweep repeated over values of one load parameter, on all cores.
struct MapOptions {
  SweepOptions sweep;          ///< model, stepper, speeds, timing, threads
  std::string parameter;       ///< "stiffness:JOINT" (N·m/rad or N/m) or "mass:BODY" (kg)
  std::vector<double> values;  ///< of the parameter
};

struct MapPoint {
  double value = 0;  ///< of the parameter
  SweepPoint point;
};

/// Throws std::invalid_argument naming a bad parameter or value.
std::vector<MapPoint> Map(const MapOptions& options, std::ostream& progress);

/// Throws std::runtime_error / std::invalid_argument with a message for the user.
std::vector<SweepPoint> Sweep(const SweepOptions& options, std::ostream& progress);

/// Throws std::runtime_error / std::invalid_argument with a message for the user. The load is a
/// generalised force on the stepper's joint (gear·τ), on top of the model's own friction and
/// damping: the curve is the torque left for a load.
std::vector<PullOutPoint> PullOut(const PullOutOptions& options, std::ostream& progress);

/// CSVs with a header naming units, written to path.tmp and renamed.
void WritePullOutCsv(const std::string& path, const std::vector<PullOutPoint>& points);
void WriteSweepCsv(const std::string& path, const std::vector<SweepPoint>& points);
/// The points of a CSV written by WriteSweepCsv (`mjstepper sweep`); throws naming the file.
std::vector<SweepPoint> ReadSweepCsv(const std::string& path);
void WriteMapCsv(const std::string& path, const std::string& parameter,
                 const std::vector<MapPoint>& points);

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_SWEEP_H_
