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

#include "overlay_layout.h"
#include "render_options.h"

namespace mjstepper::tools {

/// The box (world frame, at qpos0) around the geoms of every body but the world, planes left out:
/// what a default view should show. found is false when there are no such geoms.
struct BodyBounds {
  bool found = false;
  double low[3] = {0, 0, 0}, high[3] = {0, 0, 0};  ///< m
};
BodyBounds BoundsOfBodies(const mjModel* m);
/// Points the free camera at the bodies' box (MuJoCo's default azimuth and elevation) from the
/// nearest distance at which all of the box is in a view of this aspect (width/height), 10 % to
/// spare. Without bodies, MuJoCo's default free camera (the whole model's extent).
void FrameBodies(const mjModel* m, const BodyBounds& bounds, double aspect, mjvCamera* camera);

class OffscreenRenderer {
 public:
  /// Throws std::runtime_error naming what failed (OSMesa context, unknown camera, size).
  OffscreenRenderer(const mjModel* m, const RendererOptions& options);
  ~OffscreenRenderer();
  OffscreenRenderer(const OffscreenRenderer&) = delete;
  OffscreenRenderer& operator=(const OffscreenRenderer&) = delete;

  int width() const { return options_.width; }
  int height() const { return options_.height; }

  /// Updates the scene from d (plugins draw their decorations here) and renders it into the
  /// viewport (pixels from the bottom left; empty: the whole frame). The camera is updated first,
  /// so that plugins see this frame's viewpoint in mjvScene::camera (the gauges face it).
  void RenderScene(mjData* d, const PixelRect& viewport = {});
  /// Draws a figure into a rectangle of the frame (pixels from the bottom left).
  void DrawFigure(const PixelRect& rect, mjvFigure* figure);
  /// Draws a two-column table at the top left of a rectangle (mjr_overlay's padding included).
  void DrawTable(const PixelRect& rect, const std::string& left, const std::string& right);
  /// Fills a rectangle with a colour (alpha 1: opaque).
  void DrawRectangle(const PixelRect& rect, float r, float g, float b, float a);
  /// The overlay font of this frame size (MuJoCo's normal font at FontScaleFor's scale).
  const FontMetrics& font() const { return font_; }
  /// The camera the scene is drawn with (a named one, or the free camera framing the bodies).
  const mjvCamera& camera() const;
  /// The frame as RGB rows from the top (mjr_readPixels gives them from the bottom).
  const std::vector<std::uint8_t>& ReadPixels();

 private:
  struct Context;
  RendererOptions options_;
  const mjModel* model_;
  std::unique_ptr<Context> context_;
  FontMetrics font_;
  bool frame_bodies_ = false;  // the free camera frames the bodies' box, for the viewport's aspect
  std::vector<std::uint8_t> bottom_up_, top_down_;
};

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_OFFSCREEN_RENDERER_H_
