#include "offscreen_renderer.h"

#include <GL/osmesa.h>
#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>

namespace mjstepper::tools {

// Owns what it has made, and frees exactly that, on destruction and when the renderer's
// constructor throws halfway (OSMesaMakeCurrent failing, no offscreen framebuffer): neither the GL
// context nor MuJoCo's scene and GL objects leak. (A bad camera or size throws before any is made.)
struct OffscreenRenderer::Context {
  OSMesaContext osmesa = nullptr;
  std::vector<unsigned char> window;  // OSMesa's own (small) colour buffer; we render offscreen
  mjModel* sized_model = nullptr;     // a copy whose offwidth/offheight fit the requested frame
  mjvScene scene;
  mjvCamera camera;
  mjvOption option;
  mjrContext render;
  bool scene_made = false;
  bool render_made = false;

  Context() {
    mjv_defaultScene(&scene);
    mjv_defaultCamera(&camera);
    mjv_defaultOption(&option);
    mjr_defaultContext(&render);
  }
  ~Context() {
    if (render_made) mjr_freeContext(&render);  // needs its GL context, still current here
    if (scene_made) mjv_freeScene(&scene);
    if (sized_model != nullptr) mj_deleteModel(sized_model);
    if (osmesa != nullptr) OSMesaDestroyContext(osmesa);
  }
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
};

OffscreenRenderer::OffscreenRenderer(const mjModel* m, const RendererOptions& options)
    : options_(options), model_(m) {
  // What can be checked without GL is checked first.
  if (options.width < 16 || options.height < 16 || options.width > 8192 || options.height > 8192) {
    throw std::runtime_error(fmt::format("render size {}x{}: each side must be in [16, 8192]",
                                         options.width, options.height));
  }
  const int camera_id =
      options.camera.empty() ? -1 : mj_name2id(m, mjOBJ_CAMERA, options.camera.c_str());
  if (!options.camera.empty() && camera_id < 0) {
    throw std::runtime_error(
        fmt::format("--camera {}: the model has no camera of that name", options.camera));
  }
  context_ = std::make_unique<Context>();
  Context& c = *context_;
  // 1. A software GL context, made current before MuJoCo creates its GL objects.
  c.osmesa = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 0, nullptr);
  if (c.osmesa == nullptr) throw std::runtime_error("OSMesaCreateContextExt failed");
  c.window.resize(64 * 64 * 4);
  if (!OSMesaMakeCurrent(c.osmesa, c.window.data(), GL_UNSIGNED_BYTE, 64, 64)) {
    throw std::runtime_error("OSMesaMakeCurrent failed");
  }
  // 2. MuJoCo's offscreen framebuffer is sized from the model's visual/global: use a copy sized to
  //    the frame, so that any model renders at any size.
  c.sized_model = mj_copyModel(nullptr, m);
  c.sized_model->vis.global.offwidth = options.width;
  c.sized_model->vis.global.offheight = options.height;
  // Software GL: 4× multisampling and a 4096² shadow map cost most of a frame; 2× and 1024² look
  // the same at video sizes and render about three times faster.
  c.sized_model->vis.quality.offsamples = std::min(c.sized_model->vis.quality.offsamples, 0);
  c.sized_model->vis.quality.shadowsize = std::min(c.sized_model->vis.quality.shadowsize, 1024);
  mjv_makeScene(m, &c.scene, 2000);
  c.scene_made = true;
  // Text in proportion to the frame: 50 % below 640 pixels wide, 100 % to 1600, 150 % above.
  const int font = options.width < 640    ? mjFONTSCALE_50
                   : options.width < 1600 ? mjFONTSCALE_100
                                          : mjFONTSCALE_150;
  mjr_makeContext(c.sized_model, &c.render, font);
  c.render_made = true;
  mjr_setBuffer(mjFB_OFFSCREEN, &c.render);
  if (c.render.currentBuffer != mjFB_OFFSCREEN) {
    throw std::runtime_error("MuJoCo's offscreen framebuffer is not available in this GL context");
  }
  // 3. The camera: a named one, or the free camera looking at the whole model.
  if (camera_id < 0) {
    mjv_defaultFreeCamera(m, &c.camera);
  } else {
    c.camera.type = mjCAMERA_FIXED;
    c.camera.fixedcamid = camera_id;
  }
  bottom_up_.resize(3 * options.width * options.height);
  top_down_.resize(bottom_up_.size());
}

OffscreenRenderer::~OffscreenRenderer() = default;

void OffscreenRenderer::RenderScene(mjData* d) {
  Context& c = *context_;
  mjv_updateScene(model_, d, &c.option, nullptr, &c.camera, mjCAT_ALL, &c.scene);
  mjr_render({0, 0, options_.width, options_.height}, &c.scene, &c.render);
}

void OffscreenRenderer::DrawFigure(const mjrRect& rect, mjvFigure* figure) {
  mjr_figure(rect, figure, &context_->render);
}

void OffscreenRenderer::DrawText(int grid_position, const std::string& left,
                                 const std::string& right) {
  mjr_overlay(mjFONT_NORMAL, grid_position, {0, 0, options_.width, options_.height}, left.c_str(),
              right.c_str(), &context_->render);
}

const std::vector<std::uint8_t>& OffscreenRenderer::ReadPixels() {
  const int w = options_.width, h = options_.height;
  mjr_readPixels(bottom_up_.data(), nullptr, {0, 0, w, h}, &context_->render);
  for (int y = 0; y < h; ++y) {
    std::memcpy(&top_down_[3 * w * y], &bottom_up_[3 * w * (h - 1 - y)], 3 * w);
  }
  return top_down_;
}

}  // namespace mjstepper::tools
