// What a run renders, and how: no MuJoCo here (the command line is parsed without it).
#ifndef MJSTEPPER_TOOLS_RENDER_OPTIONS_H_
#define MJSTEPPER_TOOLS_RENDER_OPTIONS_H_

#include <string>
#include <vector>

namespace mjstepper::tools {

struct RendererOptions {
  int width = 1280;    ///< pixels
  int height = 720;    ///< pixels
  std::string camera;  ///< a named camera of the model; empty: MuJoCo's free camera
};

struct RenderOptions {
  std::string video;         ///< MP4 path; empty: none
  std::string frames_dir;    ///< folder for frame_00000.png ...; empty: none
  RendererOptions renderer;  ///< size and camera
  double fps = 30;           ///< video frames per second
  double playback = 1.0;     ///< simulated seconds per video second (0.1: ten times slower)
  bool overlays = true;      ///< plots and text
  std::vector<std::string> overlay_steppers;  ///< whose plots; empty: every stepper
  double window = 0.25;                       ///< s of simulated time shown by the plots

  bool enabled() const { return !video.empty() || !frames_dir.empty(); }
};

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_RENDER_OPTIONS_H_
