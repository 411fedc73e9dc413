// Headless rendering of a MuJoCo scene: an OSMesa context (software GL, no display, no EGL, no GLX)
// made current before mjr_makeContext, MuJoCo's own offscreen framebuffer, 2D overlays drawn with
// mjr_figure / mjr_overlay, and the frame read back top-down (straight-line setup and teardown in
// the manner of MuJoCo's sample/record.cc).
#ifndef MJSTEPPER_TOOLS_OFFSCREEN_RENDERER_H_
#define MJSTEPPER_TOOLS_OFFSCREEN_RENDERER_H_

#include <mujoco/mujoco.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "render_options.h"

namespace mjstepper::tools {

class OffscreenRenderer {
 public:
  /// Throws std::runtime_error naming what failed (OSMesa context, unknown camera, size).
  OffscreenRenderer(const mjModel* m, const RendererOptions& options);
  ~OffscreenRenderer();
  OffscreenRenderer(const OffscreenRenderer&) = delete;
  OffscreenRenderer& operator=(const OffscreenRenderer&) = delete;

  int width() const { return options_.width; }
  int height() const { return options_.height; }

  /// Updates the scene from d (plugins draw their decorations here) and renders it.
  void RenderScene(mjData* d);
  /// Draws a figure into a rectangle of the frame (pixels from the bottom left).
  void DrawFigure(const mjrRect& rect, mjvFigure* figure);
  /// Draws text at one of mjtGridPos's places: two columns, lines separated by '\n'.
  void DrawText(int grid_position, const std::string& left, const std::string& right);
  /// The frame as RGB rows from the top (mjr_readPixels gives them from the bottom).
  const std::vector<std::uint8_t>& ReadPixels();

 private:
  struct Context;
  RendererOptions options_;
  const mjModel* model_;
  std::unique_ptr<Context> context_;
  std::vector<std::uint8_t> bottom_up_, top_down_;
};

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_OFFSCREEN_RENDERER_H_
