#include "offscreen_renderer.h"

#include <GL/osmesa.h>
#include <dlfcn.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace mjstepper::tools {

BodyBounds BoundsOfBodies(const mjModel* m) {
  BodyBounds bounds;
  mjData* d = mj_makeData(m);
  if (d == nullptr) return bounds;
  mj_kinematics(m, d);  // geom_xpos, geom_xmat at qpos0
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_bodyid[g] == 0 || m->geom_type[g] == mjGEOM_PLANE) continue;
    // geom_aabb: the box's centre offset and half sizes in the geom's frame; in the world frame
    // its half size along axis i is sum_j |R_ij| h_j.
    const mjtNum* aabb = m->geom_aabb + 6 * g;
    const mjtNum* R = d->geom_xmat + 9 * g;
    for (int i = 0; i < 3; ++i) {
      double centre = d->geom_xpos[3 * g + i], half = 0;
      for (int j = 0; j < 3; ++j) {
        centre += R[3 * i + j] * aabb[j];
        half += std::abs(R[3 * i + j]) * aabb[3 + j];
      }
      bounds.low[i] = bounds.found ? std::min(bounds.low[i], centre - half) : centre - half;
      bounds.high[i] = bounds.found ? std::max(bounds.high[i], centre + half) : centre + half;
    }
    bounds.found = true;
  }
  mj_deleteData(d);
  return bounds;
}

void FrameBodies(const mjModel* m, const BodyBounds& bounds, double aspect, mjvCamera* camera) {
  mjv_defaultFreeCamera(m, camera);
  if (!bounds.found) return;
  for (int i = 0; i < 3; ++i) camera->lookat[i] = 0.5 * (bounds.low[i] + bounds.high[i]);
  // The free camera's axes at MuJoCo's default azimuth and elevation (as mjv_updateCamera makes
  // them): forward f, up u, right r = f × u.
  const double azimuth = camera->azimuth * mjPI / 180, elevation = camera->elevation * mjPI / 180;
  const double f[3] = {std::cos(elevation) * std::cos(azimuth),
                       std::cos(elevation) * std::sin(azimuth), std::sin(elevation)};
  const double u[3] = {-std::sin(elevation) * std::cos(azimuth),
                       -std::sin(elevation) * std::sin(azimuth), std::cos(elevation)};
  double r[3];
  mju_cross(r, f, u);
  // The vertical field of view (visual/global fovy) and the horizontal one of this aspect.
  const double tan_y = std::tan(0.5 * m->vis.global.fovy * mjPI / 180);
  const double tan_x = tan_y * aspect;
  // The nearest distance from which every corner of the box is in view: a corner at c (from the
  // box's centre) is at depth D + c·f, so it needs D >= |c·r|/tan_x − c·f and |c·u|/tan_y − c·f.
  double distance = 1e-3;  // m: a point still gets a millimetre's view
  for (int corner = 0; corner < 8; ++corner) {
    double c[3];
    for (int i = 0; i < 3; ++i) {
      c[i] = ((corner >> i) & 1 ? bounds.high[i] : bounds.low[i]) - camera->lookat[i];
    }
    distance = std::max({distance, std::abs(mju_dot3(c, r)) / tan_x - mju_dot3(c, f),
                         std::abs(mju_dot3(c, u)) / tan_y - mju_dot3(c, f)});
  }
  camera->distance = 1.1 * distance;  // 10 % to spare around the bodies
}

namespace {

// OSMesa, loaded when the first renderer is made rather than linked: the command and the Python
// package run without it, and only rendering says it is missing. Loaded RTLD_GLOBAL, so that
// MuJoCo's GL loader finds OSMesaGetProcAddress in the process, as when it was linked.
struct OsMesa {
  decltype(&OSMesaCreateContextExt) create_context = nullptr;
  decltype(&OSMesaMakeCurrent) make_current = nullptr;
  decltype(&OSMesaDestroyContext) destroy_context = nullptr;
};

const OsMesa& LoadOsMesa() {
  static const OsMesa* const loaded = []() -> const OsMesa* {
    const char* name = std::getenv("MJSTEPPER_OSMESA");  // another build of it, e.g. conda's
    void* library = dlopen(name != nullptr && name[0] != '\0' ? name : "libOSMesa.so.8",
                           RTLD_NOW | RTLD_GLOBAL);
    if (library == nullptr) return nullptr;
    static OsMesa f;
    f.create_context =
        reinterpret_cast<decltype(f.create_context)>(dlsym(library, "OSMesaCreateContextExt"));
    f.make_current =
        reinterpret_cast<decltype(f.make_current)>(dlsym(library, "OSMesaMakeCurrent"));
    f.destroy_context =
        reinterpret_cast<decltype(f.destroy_context)>(dlsym(library, "OSMesaDestroyContext"));
    if (!f.create_context || !f.make_current || !f.destroy_context) return nullptr;
    return &f;
  }();
  if (loaded == nullptr) {
    throw std::runtime_error(
        "rendering needs OSMesa (libOSMesa.so.8, Mesa's off-screen software GL), which this "
        "machine lacks or cannot load ($MJSTEPPER_OSMESA names another); install it (Debian and "
        "Ubuntu: apt-get install "
        "libosmesa6) and run again; everything but --render and --frames works without it");
  }
  return *loaded;
}

}  // namespace

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
    if (osmesa != nullptr) LoadOsMesa().destroy_context(osmesa);
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
  const OsMesa& osmesa = LoadOsMesa();
  c.osmesa = osmesa.create_context(OSMESA_RGBA, 24, 8, 0, nullptr);
  if (c.osmesa == nullptr) throw std::runtime_error("OSMesaCreateContextExt failed");
  c.window.resize(64 * 64 * 4);
  if (!osmesa.make_current(c.osmesa, c.window.data(), GL_UNSIGNED_BYTE, 64, 64)) {
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
  // Text in proportion to the frame (FontScaleFor).
  mjr_makeContext(c.sized_model, &c.render, FontScaleFor(options.width, options.height));
  c.render_made = true;
  std::array<int, 256> widths{};
  std::copy(c.render.charWidth, c.render.charWidth + 127, widths.begin());
  font_.char_height = c.render.charHeight;
  font_.width = [widths](const std::string& text) {
    int width = 0;  // pixels, as MuJoCo's mjr_overlay and mjr_figure add them
    for (unsigned char ch : text) width += widths[ch];
    return width;
  };
  mjr_setBuffer(mjFB_OFFSCREEN, &c.render);
  if (c.render.currentBuffer != mjFB_OFFSCREEN) {
    throw std::runtime_error("MuJoCo's offscreen framebuffer is not available in this GL context");
  }
  // 3. The camera: a named one, or the free camera framing the bodies (not the floor plane).
  if (camera_id < 0) {
    frame_bodies_ = true;
    FrameBodies(m, BoundsOfBodies(m), static_cast<double>(options.width) / options.height,
                &c.camera);
  } else {
    c.camera.type = mjCAMERA_FIXED;
    c.camera.fixedcamid = camera_id;
  }
  bottom_up_.resize(3 * options.width * options.height);
  top_down_.resize(bottom_up_.size());
}

OffscreenRenderer::~OffscreenRenderer() = default;

const mjvCamera& OffscreenRenderer::camera() const { return context_->camera; }

void OffscreenRenderer::RenderScene(mjData* d, const PixelRect& viewport) {
  Context& c = *context_;
  const mjrRect rect =
      viewport.width > 0 && viewport.height > 0
          ? mjrRect{viewport.left, viewport.bottom, viewport.width, viewport.height}
          : mjrRect{0, 0, options_.width, options_.height};
  if (frame_bodies_ && rect.width * options_.height != rect.height * options_.width) {
    FrameBodies(model_, BoundsOfBodies(model_), static_cast<double>(rect.width) / rect.height,
                &c.camera);
    frame_bodies_ = false;  // (framed once, for the first viewport; a user's camera stays put)
  }
  // The camera first (mjv_updateScene updates it only after the plugins' visualize callbacks).
  mjv_updateCamera(model_, d, &c.camera, &c.scene);
  mjv_updateScene(model_, d, &c.option, nullptr, &c.camera, mjCAT_ALL, &c.scene);
  mjr_render(rect, &c.scene, &c.render);
}

void OffscreenRenderer::DrawFigure(const PixelRect& rect, mjvFigure* figure) {
  mjr_figure({rect.left, rect.bottom, rect.width, rect.height}, figure, &context_->render);
}

void OffscreenRenderer::DrawTable(const PixelRect& rect, const std::string& left,
                                  const std::string& right) {
  mjr_overlay(mjFONT_NORMAL, mjGRID_TOPLEFT, {rect.left, rect.bottom, rect.width, rect.height},
              left.c_str(), right.c_str(), &context_->render);
}

void OffscreenRenderer::DrawRectangle(const PixelRect& rect, float r, float g, float b, float a) {
  mjr_rectangle({rect.left, rect.bottom, rect.width, rect.height}, r, g, b, a);
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
