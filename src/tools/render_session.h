// Rendering a run as it goes: frames on their own clock (frame k shows simulation time
// k·playback/fps, whatever the physics timestep), the 3D scene with the plugin's load-angle gauges
// in the frame's left part, and a side panel (OverlayLayout) with every stepper's text (drive,
// commanded and actual speed, load angle, lost steps) and plots (velocity error, phase currents,
// load angle over a sliding window that ends at the frame's time), in pages the video cycles
// through when they do not all fit. Frames go to an MP4 and/or numbered PNGs.
#ifndef MJSTEPPER_TOOLS_RENDER_SESSION_H_
#define MJSTEPPER_TOOLS_RENDER_SESSION_H_

#include <mujoco/mujoco.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "offscreen_renderer.h"
#include "overlay_layout.h"
#include "render_options.h"
#include "stepper_model.h"
#include "video_writer.h"

namespace mjstepper::tools {

/// One stepper's sample at one physics step, as the runner computes it.
struct StepperSample {
  double omega_cmd = 0;                 ///< rad/s
  double velocity_error = 0;            ///< rad/s
  double current_a = 0, current_b = 0;  ///< A
  double load_angle = 0;                ///< electrical rad
  double lost_steps = 0;
  double stallguard = 0;  ///< SG_RESULT (counts), on drives with StallGuard
  bool stall = false;     ///< the drive's stall flag (its DIAG output)
};

/// A stepper's table as the overlay draws it (labels, values), its name and drive fitted to the
/// layout's column widths; a linear axis's (`rad_per_metre`, the rotor's rad per m of its
/// carriage, RadPerMetre; 0: rotary) command and speed in mm/s at the carriage (README, "Linear
/// axes").
TableText StepperTable(const StepperActuator& stepper, const StepperSample& last,
                       const OverlayLayout& layout, const FontMetrics& font,
                       double rad_per_metre = 0);

class RenderSession {
 public:
  /// Throws std::runtime_error / std::invalid_argument with a message for the user.
  RenderSession(const mjModel* m, const std::vector<StepperActuator>& steppers,
                const RenderOptions& options);
  ~RenderSession();

  /// Records the steppers' samples at time t (one per stepper, in model order), then renders every
  /// frame whose time has come by d->time − `origin` (s: the run's clock starts there, after a
  /// settled start's settling; frames and t are on the run's clock).
  void Step(double t, const std::vector<StepperSample>& samples, mjData* d, double origin = 0);
  /// Closes the video. Returns the number of frames written.
  long Finish();
  /// Where the overlays go (OverlayLayout), for this frame size and these steppers.
  const OverlayLayout& layout() const { return layout_; }
  /// The steppers with plots, in layout order (indices into the model's steppers).
  const std::vector<int>& overlaid() const { return overlay_; }

 private:
  struct History;
  void RenderFrame(double frame_time, mjData* d);

  const mjModel* model_;
  std::vector<StepperActuator> steppers_;
  RenderOptions options_;
  std::vector<int> overlay_;  // indices into steppers_
  std::vector<History> history_;
  std::vector<double> rad_per_metre_;  // per stepper (StepperTable), at construction
  std::unique_ptr<OffscreenRenderer> renderer_;
  std::optional<VideoWriter> video_;
  std::unique_ptr<mjvFigure> figure_;
  OverlayLayout layout_;
  long frame_ = 0;
};

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_RENDER_SESSION_H_
