// Headless renders: the off-screen renderer, the overlays, the gauge, the video.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <malloc.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "offscreen_renderer.h"
#include "overlay_layout.h"
#include "render_session.h"
#include "runner.h"
#include "stepper_model.h"

namespace mjstepper::tools {
namespace {

const std::string kModel = MJSTEPPER_SOURCE_DIR "/models/tsui_rigid.xml";

std::filesystem::path TempDir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("mjstepper_render_" + std::to_string(::getpid())) / name;
  std::filesystem::create_directories(dir);
  return dir;
}

struct Frame {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
  const std::uint8_t* At(int x, int y) const { return &rgb[3 * (y * width + x)]; }
};

// Renders the state of d (after mj_forward) with the given camera, no overlays.
Frame RenderOnce(const mjModel* m, mjData* d, const std::string& camera, int w = 320, int h = 240) {
  OffscreenRenderer renderer(m, {.width = w, .height = h, .camera = camera});
  renderer.RenderScene(d);
  return {w, h, renderer.ReadPixels()};
}

// Centroid (x, y) of the pixels close to a colour, and how many there are.
struct Blob {
  double x = 0, y = 0;
  long count = 0;
};
Blob Find(const Frame& f, int r, int g, int b, int tolerance, int x0 = 0, int y0 = 0, int x1 = -1,
          int y1 = -1) {
  if (x1 < 0) x1 = f.width;
  if (y1 < 0) y1 = f.height;
  Blob blob;
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) {
      const std::uint8_t* p = f.At(x, y);
      if (std::abs(p[0] - r) <= tolerance && std::abs(p[1] - g) <= tolerance &&
          std::abs(p[2] - b) <= tolerance) {
        blob.x += x;
        blob.y += y;
        ++blob.count;
      }
    }
  }
  if (blob.count > 0) {
    blob.x /= blob.count;
    blob.y /= blob.count;
  }
  return blob;
}

TEST(Render, FrameIsNotBlank) {
  const StepperModel sm = LoadStepperModel(kModel);
  DataPtr d(mj_makeData(sm.model.get()));
  mj_forward(sm.model.get(), d.get());
  const Frame f = RenderOnce(sm.model.get(), d.get(), "front");
  // Not one flat colour: many distinct colours, and a fifth of the frame or more differs from its
  // most common colour (the background) — the stator and rotor fill about a third of it.
  std::vector<int> count(1 << 15, 0);
  for (size_t i = 0; i < f.rgb.size(); i += 3) {
    ++count[(f.rgb[i] >> 3) << 10 | (f.rgb[i + 1] >> 3) << 5 | (f.rgb[i + 2] >> 3)];
  }
  const int distinct = std::count_if(count.begin(), count.end(), [](int c) { return c > 0; });
  const int background = *std::max_element(count.begin(), count.end());
  EXPECT_GT(distinct, 30);
  EXPECT_GT(f.width * f.height - background, f.width * f.height / 5);
}

// The rotor's marker (red box on the hub, rgba 0.9 0.2 0.1) moves in the frame when the rotor turns
// a quarter turn; it does not when it does not.
TEST(Render, RotorMarkerMovesWhenTheRotorTurns) {
  const StepperModel sm = LoadStepperModel(kModel);
  const mjModel* m = sm.model.get();
  DataPtr d(mj_makeData(m));
  mj_forward(m, d.get());
  const Blob a = Find(RenderOnce(m, d.get(), "front"), 230, 51, 26, 60);
  const Blob same = Find(RenderOnce(m, d.get(), "front"), 230, 51, 26, 60);
  d->qpos[0] = 1.5708;
  mj_forward(m, d.get());
  const Blob b = Find(RenderOnce(m, d.get(), "front"), 230, 51, 26, 60);
  ASSERT_GT(a.count, 20);
  ASSERT_GT(b.count, 20);
  EXPECT_EQ(a.x, same.x);
  EXPECT_GT(std::hypot(a.x - b.x, a.y - b.y), 10.0);  // pixels, in a 320x240 frame
}

// A model with no camera renders with MuJoCo's free camera.
TEST(Render, ModelWithoutCameraUsesTheFreeCamera) {
  const char* xml = R"(<mujoco><extension><plugin plugin="mjstepper.stepper"/></extension>
    <worldbody><light pos="0 0 1"/><body><joint name="j" type="hinge" axis="0 0 1"/>
    <geom type="box" size="0.05 0.01 0.01" rgba="0.9 0.2 0.1 1"/></body></worldbody>
    <actuator><plugin name="m" joint="j" plugin="mjstepper.stepper" armature="1e-4"/></actuator>
    </mujoco>)";
  const auto path = TempDir("nocam") / "nocam.xml";
  std::ofstream(path) << xml;
  const StepperModel sm = LoadStepperModel(path.string());
  ASSERT_EQ(sm.model->ncam, 0);
  DataPtr d(mj_makeData(sm.model.get()));
  mj_forward(sm.model.get(), d.get());
  EXPECT_GT(Find(RenderOnce(sm.model.get(), d.get(), ""), 230, 51, 26, 60).count, 50);
  EXPECT_THROW(RenderOnce(sm.model.get(), d.get(), "nope"), std::runtime_error);
}

// A renderer whose constructor throws (here: an unknown camera) keeps nothing: it leaked its GL
// context and MuJoCo's 2000-geom scene, about 2 MB a time (LeakSanitizer found it); and a renderer
// made and destroyed frees all it made (its Context, which also frees a half-made renderer).
// Measured on the heap (glibc's mallinfo2; under ASan it reads nothing, and LeakSanitizer checks
// instead): 20 of each may not grow it by even 1 MB.
TEST(Render, FailedConstructionLeaksNothing) {
  const StepperModel sm = LoadStepperModel(kModel);
  {  // one good renderer first, so that Mesa's one-time allocations are not counted
    OffscreenRenderer warm(sm.model.get(), {.width = 64, .height = 64, .camera = ""});
  }
  size_t before = mallinfo2().uordblks;
  for (int k = 0; k < 20; ++k) {
    EXPECT_THROW(OffscreenRenderer(sm.model.get(), {.width = 64, .height = 64, .camera = "nope"}),
                 std::runtime_error);
  }
  size_t after = mallinfo2().uordblks;
  EXPECT_LT(after, before + (1 << 20)) << "failed: heap grew by " << (after - before) << " bytes";
  before = mallinfo2().uordblks;
  for (int k = 0; k < 20; ++k) {
    OffscreenRenderer renderer(sm.model.get(), {.width = 64, .height = 64, .camera = ""});
  }
  after = mallinfo2().uordblks;
  EXPECT_LT(after, before + (1 << 20)) << "made: heap grew by " << (after - before) << " bytes";
}

RunOptions RenderRun(const std::filesystem::path& dir, bool overlays, int width = 320,
                     int height = 240) {
  RunOptions o;
  o.model = kModel;
  o.duration = 0.1;
  o.ctrl = {{"shaft", "ramp(0rpm,200rpm,0.2s)"}};
  o.progress = false;
  o.render.video = (dir / "run.mp4").string();
  o.render.frames_dir = (dir / "frames").string();
  o.render.renderer = {.width = width, .height = height, .camera = "front"};
  o.render.fps = 50;  // frame k at k·0.02 s: 6 frames for 0.1 s
  o.render.overlays = overlays;
  return o;
}

Frame ReadFrameRaw(const std::filesystem::path& mp4, int frame, int w, int h) {
  const std::string command = "ffmpeg -loglevel error -i '" + mp4.string() +
                              "' -vf 'select=eq(n\\," + std::to_string(frame) +
                              ")' -frames:v 1 -f rawvideo -pix_fmt rgb24 -";
  FILE* pipe = popen(command.c_str(), "r");
  Frame f{w, h, std::vector<std::uint8_t>(3 * w * h)};
  const size_t got = std::fread(f.rgb.data(), 1, f.rgb.size(), pipe);
  pclose(pipe);
  EXPECT_EQ(got, f.rgb.size());
  return f;
}

// The MP4 decodes (ffprobe) with the expected frame count and size; the PNG frames match it.
TEST(Render, Mp4DecodesWithExpectedFramesAndSize) {
  const auto dir = TempDir("mp4");
  std::ostringstream sink;
  const RunResult r = tools::Run(RenderRun(dir, true), sink);
  EXPECT_EQ(r.frames, 6);
  FILE* pipe = popen(("ffprobe -v error -count_frames -select_streams v:0 -show_entries "
                      "stream=nb_read_frames,width,height -of csv=p=0 '" +
                      (dir / "run.mp4").string() + "'")
                         .c_str(),
                     "r");
  char buffer[256] = "";
  ASSERT_NE(std::fgets(buffer, sizeof(buffer), pipe), nullptr);
  pclose(pipe);
  EXPECT_EQ(std::string(buffer), "320,240,6\n");
  EXPECT_TRUE(std::filesystem::exists(dir / "frames" / "frame_00005.png"));
  EXPECT_FALSE(std::filesystem::exists(dir / "run.mp4.tmp.mp4"));
}

// The first plot's rectangle (the layout's) holds plot pixels (the velocity-error line's colour)
// only with overlays on.
TEST(Render, OverlayRegionHasPlotPixels) {
  std::ostringstream sink;
  const auto on = TempDir("overlay_on"), off = TempDir("overlay_off");
  tools::Run(RenderRun(on, true, 640, 480), sink);
  tools::Run(RenderRun(off, false, 640, 480), sink);
  const StepperModel sm = LoadStepperModel(kModel);
  OffscreenRenderer renderer(sm.model.get(), {.width = 640, .height = 480, .camera = "front"});
  const PixelRect plot = LayOutOverlay(640, 480, 1, renderer.font()).pages.at(0).at(0).plots[0];
  // Frame 5 (0.1 s): the line colour (242, 89, 51); the tolerance 30 leaves out the rotor's red
  // marker (230, 51, 26), which is not there anyway.
  const Frame with = ReadFrameRaw(on / "run.mp4", 5, 640, 480);
  const Frame without = ReadFrameRaw(off / "run.mp4", 5, 640, 480);
  const int y0 = 480 - plot.top(), y1 = 480 - plot.bottom;  // rows from the top
  EXPECT_GT(Find(with, 242, 89, 51, 30, plot.left, y0, plot.right(), y1).count, 10);
  EXPECT_EQ(Find(without, 242, 89, 51, 30, plot.left, y0, plot.right(), y1).count, 0);
}

// Rendering is deterministic: the same run twice gives byte-identical PNG frames.
TEST(Render, IdenticalRunsGiveIdenticalFrames) {
  std::ostringstream sink;
  const auto a = TempDir("same_a"), b = TempDir("same_b");
  tools::Run(RenderRun(a, true), sink);
  tools::Run(RenderRun(b, true), sink);
  for (int k = 0; k < 6; ++k) {
    const std::string name = "frame_0000" + std::to_string(k) + ".png";
    std::ifstream fa(a / "frames" / name, std::ios::binary),
        fb(b / "frames" / name, std::ios::binary);
    const std::string da((std::istreambuf_iterator<char>(fa)), {});
    const std::string db((std::istreambuf_iterator<char>(fb)), {});
    ASSERT_FALSE(da.empty());
    EXPECT_EQ(da, db) << name;
  }
}

// ---- Layout, gauge side and default camera (issue 19, item 5)
// ---------------------------------------

const std::string kArm4 = MJSTEPPER_SOURCE_DIR "/tests/tools/models/arm4.xml";

// The layout of the 4-stepper arm at w×h, with the renderer's own font at that size: the panel
// takes at most a third of the width; on every page no rectangle overlaps another and each lies in
// the panel; every stepper has its table and three plots on exactly one page; each text fits its
// box (the table of a stepper at its widest values, measured in the font's own glyph widths), each
// plot is as wide as its title and at least kMinPlotLines lines high.
void ExpectLegibleLayout(int w, int h) {
  const StepperModel sm = LoadStepperModel(kArm4);
  ASSERT_EQ(sm.steppers.size(), 4u);
  OffscreenRenderer renderer(sm.model.get(), {.width = w, .height = h, .camera = ""});
  const FontMetrics& font = renderer.font();
  ASSERT_GT(font.char_height, 0);
  const OverlayLayout layout = LayOutOverlay(w, h, 4, font);
  EXPECT_TRUE(layout.legible);
  EXPECT_LE(layout.panel.width, w / 3);
  EXPECT_TRUE(Inside(layout.panel, layout.frame));
  EXPECT_TRUE(Inside(layout.scene, layout.frame));
  EXPECT_FALSE(Overlaps(layout.panel, layout.scene));
  EXPECT_TRUE(Inside(layout.time, layout.scene));
  EXPECT_TRUE(Inside(layout.header, layout.scene));
  EXPECT_FALSE(Overlaps(layout.header, layout.time));
  const PixelRect header_text = TableSize(HeaderTemplate(), font);
  EXPECT_LE(header_text.width, layout.header.width);
  EXPECT_LE(header_text.height, layout.header.height);
  const PixelRect time_text = TableSize(TimeTemplate(), font);
  EXPECT_LE(time_text.width, layout.time.width);
  EXPECT_LE(time_text.height, layout.time.height);
  std::vector<int> seen(4, 0);
  // The widest values a table shows (a long name and drive are cut to fit, marked "~").
  StepperActuator wide = sm.steppers[1];
  wide.name = "a_stepper_with_a_very_long_name";
  const StepperSample extreme{
      .omega_cmd = -900, .velocity_error = -30, .load_angle = -3.14159, .lost_steps = -12345};
  for (const std::vector<StepperSlot>& page : layout.pages) {
    ASSERT_LE(static_cast<int>(page.size()), layout.steppers_per_page);
    std::vector<PixelRect> rects;
    for (const StepperSlot& slot : page) {
      ASSERT_GE(slot.stepper, 0);
      ASSERT_LT(slot.stepper, 4);
      ++seen[slot.stepper];
      rects.push_back(slot.table);
      for (const StepperSlot* s : {&slot}) {
        for (int p = 0; p < 3; ++p) rects.push_back(s->plots[p]);
      }
      for (const StepperActuator& stepper : {sm.steppers[slot.stepper], wide}) {
        const TableText table = StepperTable(stepper, extreme, layout, font);
        const PixelRect size = TableSize(table, font);
        EXPECT_LE(size.width, slot.table.width) << stepper.name;
        EXPECT_LE(size.height, slot.table.height) << stepper.name;
      }
      for (int p = 0; p < 3; ++p) {
        // mjr_figure centres its title and cuts it at the plot's edges: 2 px to spare each side.
        EXPECT_LE(font.width(kPlotTitles[p]) + 4, slot.plots[p].width) << kPlotTitles[p];
        EXPECT_GE(slot.plots[p].height, kMinPlotLines * font.char_height) << kPlotTitles[p];
      }
    }
    for (size_t i = 0; i < rects.size(); ++i) {
      EXPECT_TRUE(Inside(rects[i], layout.panel)) << "rectangle " << i;
      for (size_t j = i + 1; j < rects.size(); ++j) {
        EXPECT_FALSE(Overlaps(rects[i], rects[j])) << "rectangles " << i << " and " << j;
      }
    }
  }
  EXPECT_THAT(seen, ::testing::Each(1));
  // Issue 32, item 4: the printers' and the study's names are shown whole (the label column cut
  // them to "steppe~" and "undam~").
  for (const char* name : {"stepper_a", "stepper_b", "undamped", "shoulder"}) {
    StepperActuator named = sm.steppers[0];
    named.name = name;
    const TableText table = StepperTable(named, extreme, layout, font);
    EXPECT_THAT(table.values, ::testing::Contains(std::string(name))) << w << "x" << h;
  }
}

TEST(RenderLayout, FourSteppersAt640x480) { ExpectLegibleLayout(640, 480); }
TEST(RenderLayout, FourSteppersAt1920x1080) { ExpectLegibleLayout(1920, 1080); }

// A 1080p frame holds all four steppers' blocks at once; 640x480 pages them, and the page shown
// turns every page_seconds of video, back to the first after the last.
TEST(RenderLayout, PagesOnlyWhenTheyDoNotFit) {
  const FontMetrics font{18, [](const std::string& s) { return 8 * static_cast<int>(s.size()); }};
  EXPECT_EQ(LayOutOverlay(1920, 1080, 4, font).pages.size(), 1u);
  const OverlayLayout small = LayOutOverlay(640, 480, 4, font);
  ASSERT_EQ(small.pages.size(), 4u);
  EXPECT_EQ(small.PageAt(0), 0);
  EXPECT_EQ(small.PageAt(small.page_seconds * 1.01), 1);
  EXPECT_EQ(small.PageAt(small.page_seconds * 4.01), 0);
}

// A run of the 4-stepper arm at 640x480: every stepper's phase-current plot appears (the ib line's
// colour, (77, 179, 255), inside the plot's rectangle) on the page the video shows at its frame,
// and the four pages all come round.
TEST(RenderLayout, EveryStepperGetsItsPlotsInTheVideo) {
  const auto dir = TempDir("arm4");
  RunOptions o;
  o.model = kArm4;
  o.ctrl = {{"base", "constant(5rad)"},
            {"shoulder", "constant(-8rad)"},
            {"elbow", "constant(6rad)"},
            {"wrist", "constant(10rad)"}};
  o.progress = false;
  // The layout, not the start: from the aligned rotors every phase current moves from the first
  // frame on (settled, a holding drive's currents draw flat lines on a plot's edge).
  o.start = StartMode::kAligned;
  o.render.video = (dir / "run.mp4").string();
  o.render.renderer = {.width = 640, .height = 480, .camera = ""};
  o.render.fps = 2;          // a page every 3 s of video: every 6 frames
  o.render.playback = 0.02;  // 0.01 s of simulation a frame
  o.duration = 0.235;        // 24 frames: four pages
  std::ostringstream sink;
  const RunResult r = tools::Run(o, sink);
  ASSERT_EQ(r.frames, 24);
  // The run's session, as Run makes it (no output of its own): its steppers and its layout.
  const StepperModel sm = LoadStepperModel(kArm4);
  RenderOptions session_options = o.render;
  session_options.video.clear();
  const RenderSession session(sm.model.get(), sm.steppers, session_options);
  EXPECT_THAT(session.overlaid(), ::testing::ElementsAre(0, 1, 2, 3));
  const OverlayLayout& layout = session.layout();
  ASSERT_EQ(layout.pages.size(), 4u);
  std::vector<int> shown(4, 0);
  for (int k = 1; k < 24; k += 6) {  // one frame of each page (frame 0 has no history yet)
    const Frame f = ReadFrameRaw(dir / "run.mp4", k, 640, 480);
    for (const StepperSlot& slot : layout.pages[layout.PageAt(k / o.render.fps)]) {
      const int stepper = session.overlaid()[slot.stepper];
      const PixelRect& plot = slot.plots[1];
      // Tolerance 40: the MP4's chroma subsampling blurs a 1-pixel line's colour.
      const long count =
          Find(f, 77, 179, 255, 40, plot.left, 480 - plot.top(), plot.right(), 480 - plot.bottom)
              .count;
      EXPECT_GT(count, 20) << "stepper " << stepper << " at frame " << k;
      if (count > 20) ++shown[stepper];
    }
  }
  EXPECT_THAT(shown, ::testing::Each(1));
}

// A rotor on a hinge along z, no stator, a camera above and one below, the gauge on.
const char* kGaugeModel =
    R"(<mujoco><option timestep="1e-4"/><extension><plugin plugin="mjstepper.stepper"/></extension>
  <worldbody><light pos="0 0 1" dir="0 0 -1"/><light pos="0 0 -1" dir="0 0 1"/>
  <camera name="top" pos="0 0 0.2" xyaxes="1 0 0 0 1 0"/>
  <camera name="bottom" pos="0 0 -0.2" xyaxes="1 0 0 0 -1 0"/>
  <body name="rotor"><joint name="shaft" type="hinge" axis="0 0 1"/>
  <geom type="cylinder" size="0.02 0.004" rgba="0.7 0.7 0.75 1" mass="0.1"/></body></worldbody>
  <actuator><plugin name="shaft" joint="shaft" plugin="mjstepper.stepper" armature="0.36e-4"/>
  </actuator></mujoco>)";

StepperModel LoadGaugeModel() {
  const auto path = TempDir("gauge") / "gauge.xml";
  std::ofstream(path) << kGaugeModel;
  return LoadStepperModel(path.string());
}

// Geometry: seen from above (elevation -60°) or below (+60°), both gauge arrows start on the
// camera's side of the rotor's hub (beyond its 4 mm half height along the axis).
TEST(RenderGauge, ArrowsOnTheCameraSideOfTheRotor) {
  const StepperModel sm = LoadGaugeModel();
  const mjModel* m = sm.model.get();
  DataPtr d(mj_makeData(m));
  mj_forward(m, d.get());
  for (const double elevation : {-60.0, 60.0}) {
    mjvScene scene;
    mjv_defaultScene(&scene);
    mjv_makeScene(m, &scene, 100);
    mjvOption option;
    mjv_defaultOption(&option);
    mjvCamera camera;
    mjv_defaultFreeCamera(m, &camera);
    camera.lookat[0] = camera.lookat[1] = camera.lookat[2] = 0;
    camera.distance = 0.3;
    camera.elevation = elevation;
    // This frame's camera first, as the renderer does (mjv_updateScene updates it after plugins).
    mjv_updateCamera(m, d.get(), &camera, &scene);
    mjv_updateScene(m, d.get(), &option, nullptr, &camera, mjCAT_ALL, &scene);
    const double side = scene.camera[0].pos[2] > 0 ? 1 : -1;  // camera above: +1
    int arrows = 0;
    for (int g = 0; g < scene.ngeom; ++g) {
      const mjvGeom& geom = scene.geoms[g];
      if (geom.type != mjGEOM_ARROW || geom.category != mjCAT_DECOR) continue;
      ++arrows;
      EXPECT_GT(side * geom.pos[2], 0.004) << "elevation " << elevation;
    }
    EXPECT_EQ(arrows, 2);
    mjv_freeScene(&scene);
  }
}

// Pixels: the green command arrow shows as fully from below as from above (the renderer hands the
// plugin this frame's camera); drawn on the far side, the hub would hide its inner half.
TEST(RenderGauge, ArrowAsVisibleFromBelowAsFromAbove) {
  const StepperModel sm = LoadGaugeModel();
  const mjModel* m = sm.model.get();
  DataPtr d(mj_makeData(m));
  mj_forward(m, d.get());
  const long above = Find(RenderOnce(m, d.get(), "top"), 26, 217, 64, 50).count;
  const long below = Find(RenderOnce(m, d.get(), "bottom"), 26, 217, 64, 50).count;
  ASSERT_GT(above, 100);
  // Mirror views of the same arrows: equal but for shading; the far side shows about half.
  EXPECT_GT(below, 0.8 * above);
}

// Where a world point lands in a w×h frame drawn from `scene`'s camera, as mjr_render draws it
// (without stereo, from the average of the two eyes, which sit ipd/2 either side of the camera):
// x and y from −1 to 1 across the frame, and the depth along the view (> 0: in front).
struct FrameProjection {
  FrameProjection(const mjModel* m, const mjvScene& scene, int w, int h) {
    const mjvGLCamera& c = scene.camera[0];
    for (int i = 0; i < 3; ++i) {
      eye[i] = 0.5 * (scene.camera[0].pos[i] + scene.camera[1].pos[i]);
      forward[i] = c.forward[i];
      up[i] = c.up[i];
    }
    mju_cross(right, forward, up);
    tan_y = std::tan(0.5 * m->vis.global.fovy * mjPI / 180);
    tan_x = tan_y * w / h;
  }
  struct Point {
    double x, y, depth;
  };
  Point operator()(const double p[3]) const {
    double v[3];
    mju_sub3(v, p, eye);
    const double depth = mju_dot3(v, forward);
    return {mju_dot3(v, right) / depth / tan_x, mju_dot3(v, up) / depth / tan_y, depth};
  }
  double eye[3], forward[3], up[3], right[3], tan_x, tan_y;
};

// The default free camera frames the bodies, not the 4 m floor: the box around the arm's geoms,
// projected, spans at least 80 % of the frame's width or height, and lies wholly inside it.
TEST(RenderCamera, DefaultCameraFramesTheBodies) {
  const StepperModel sm = LoadStepperModel(kArm4);
  const mjModel* m = sm.model.get();
  DataPtr d(mj_makeData(m));
  mj_forward(m, d.get());
  const int w = 640, h = 480;
  OffscreenRenderer renderer(m, {.width = w, .height = h, .camera = ""});
  mjvCamera camera = renderer.camera();
  mjvScene scene;
  mjv_defaultScene(&scene);
  mjv_makeScene(m, &scene, 10);
  mjv_updateCamera(m, d.get(), &camera, &scene);
  const FrameProjection frame(m, scene, w, h);
  const BodyBounds bounds = BoundsOfBodies(m);
  ASSERT_TRUE(bounds.found);
  // The floor (z = 0, 4 m wide) is left out; the pedestal (a world geom) too: the box starts at
  // the turret's bottom, z = 0.2 m.
  EXPECT_NEAR(bounds.low[2], 0.2, 1e-9);
  double x_low = 1e9, x_high = -1e9, y_low = 1e9, y_high = -1e9;
  for (int corner = 0; corner < 8; ++corner) {
    double c[3];
    for (int i = 0; i < 3; ++i) c[i] = (corner >> i) & 1 ? bounds.high[i] : bounds.low[i];
    const FrameProjection::Point p = frame(c);
    ASSERT_GT(p.depth, 0);
    x_low = std::min(x_low, p.x), x_high = std::max(x_high, p.x);
    y_low = std::min(y_low, p.y), y_high = std::max(y_high, p.y);
  }
  EXPECT_GE(x_low, -1);
  EXPECT_LE(x_high, 1);
  EXPECT_GE(y_low, -1);
  EXPECT_LE(y_high, 1);
  // FrameBodies leaves 10 % around the box (so about 0.9); MuJoCo's own default (the model's
  // extent, floor included) spans 0.55 of this frame's width.
  EXPECT_GE(std::max(x_high - x_low, y_high - y_low) / 2, 0.8)
      << "x " << x_low << ".." << x_high << ", y " << y_low << ".." << y_high;
  mjv_freeScene(&scene);
}

// Issue 32, item 4: a stepper on a slide (a carriage on a rail, the rail a world geom) draws its
// gauge on the carriage's face towards the camera, within the frame the default camera gives the
// carriage: every arrow's start and tip project inside it. (Drawn along the slide beyond the
// carriage's end, as a hinge's is along its axis, the dial left the frame.)
TEST(RenderGauge, ASlidesGaugeStaysInTheFrame) {
  const auto path = TempDir("slide_gauge") / "slide.xml";
  std::ofstream(path) << R"(<mujoco><option timestep="5e-5"/>
  <extension><plugin plugin="mjstepper.stepper"/></extension>
  <worldbody><light pos="0 -0.5 1" dir="0 0.5 -1"/>
  <geom type="box" size="0.4 0.01 0.005"/>
  <body name="carriage" pos="0 0 0.02"><joint name="x" type="slide" axis="1 0 0"/>
  <geom type="box" size="0.03 0.025 0.012" mass="0.5"/></body></worldbody>
  <actuator><plugin name="x" joint="x" gear="157.08" plugin="mjstepper.stepper"
    armature="0.36e-4"/></actuator></mujoco>)";
  const StepperModel sm = LoadStepperModel(path.string());
  const mjModel* m = sm.model.get();
  DataPtr d(mj_makeData(m));
  mj_forward(m, d.get());
  const int w = 640, h = 480;
  OffscreenRenderer renderer(m, {.width = w, .height = h, .camera = ""});
  mjvCamera camera = renderer.camera();
  mjvScene scene;
  mjv_defaultScene(&scene);
  mjv_makeScene(m, &scene, 100);
  mjvOption option;
  mjv_defaultOption(&option);
  mjv_updateCamera(m, d.get(), &camera, &scene);
  mjv_updateScene(m, d.get(), &option, nullptr, &camera, mjCAT_ALL, &scene);
  const FrameProjection frame(m, scene, w, h);
  int arrows = 0;
  for (int g = 0; g < scene.ngeom; ++g) {
    const mjvGeom& geom = scene.geoms[g];
    if (geom.type != mjGEOM_ARROW || geom.category != mjCAT_DECOR) continue;
    ++arrows;
    for (const double reach : {0.0, 1.0}) {  // the arrow's start and tip (its z axis, size[2])
      double end[3];
      for (int i = 0; i < 3; ++i) end[i] = geom.pos[i] + reach * geom.mat[3 * i + 2] * geom.size[2];
      const FrameProjection::Point p = frame(end);
      ASSERT_GT(p.depth, 0);
      EXPECT_LE(std::abs(p.x), 1) << "arrow " << arrows;
      EXPECT_LE(std::abs(p.y), 1) << "arrow " << arrows;
    }
  }
  EXPECT_EQ(arrows, 2);
  mjv_freeScene(&scene);
}

}  // namespace
}  // namespace mjstepper::tools

namespace mjstepper::tools {
namespace {

// Issue 32, item 4: a drive with StallGuard shows SG_RESULT and the stall flag in its table (a
// homing video could not show the detection); a drive without it shows its detent damping there.
TEST(RenderLayout, AStallGuardDriveShowsItsResultAndStallFlag) {
  const std::string model = MJSTEPPER_SOURCE_DIR "/models/tsui_rigid.xml";
  const StepperModel plain = LoadStepperModel(model);
  const StepperModel sensing = LoadStepperModel(model, {{"shaft", "driver", "tmc2209"},
                                                        {"shaft", "drive", "stealthchop"},
                                                        {"shaft", "sgthrs", "40"}});
  OffscreenRenderer renderer(plain.model.get(), {.width = 640, .height = 480, .camera = ""});
  const OverlayLayout layout = LayOutOverlay(640, 480, 1, renderer.font());
  const StepperSample stalled{.stallguard = 37, .stall = true};
  TableText table = StepperTable(sensing.steppers[0], stalled, layout, renderer.font());
  EXPECT_EQ(table.labels[2], "stall");
  EXPECT_EQ(table.values[2], "SG 37 STALL");
  EXPECT_LE(TableSize(table, renderer.font()).width, layout.pages[0][0].table.width);
  table = StepperTable(sensing.steppers[0], {.stallguard = 300}, layout, renderer.font());
  EXPECT_EQ(table.values[2], "SG 300");
  table = StepperTable(plain.steppers[0], stalled, layout, renderer.font());
  EXPECT_EQ(table.labels[2], "damping");
  EXPECT_EQ(table.values[2], "none");
}

// Issue 32, item 3: a linear axis's table gives its command and speed in mm/s at the carriage
// (models/belt_axis.xml: 40 mm per turn, 150 r/min is 100 mm/s), and still fits its rectangle.
TEST(RenderLayout, ALinearAxisShowsMillimetresPerSecond) {
  const StepperModel belt = LoadStepperModel(MJSTEPPER_SOURCE_DIR "/models/belt_axis.xml");
  OffscreenRenderer renderer(belt.model.get(), {.width = 640, .height = 480, .camera = ""});
  const OverlayLayout layout = LayOutOverlay(640, 480, 1, renderer.font());
  const double rad_per_metre = *RadPerMetre(belt.model.get(), belt.steppers[0]);
  const StepperSample moving{.omega_cmd = RpmToRadPerSec(150), .velocity_error = -0.0157};
  TableText table = StepperTable(belt.steppers[0], moving, layout, renderer.font(), rad_per_metre);
  EXPECT_EQ(table.values[3], "100.0 mm/s");
  EXPECT_EQ(table.values[4], "99.9 mm/s");
  const StepperSample fastest{.omega_cmd = -1000};  // rad/s: −9 549 r/min, −6.4 m/s
  table = StepperTable(belt.steppers[0], fastest, layout, renderer.font(), rad_per_metre);
  EXPECT_LE(TableSize(table, renderer.font()).width, layout.pages[0][0].table.width);
  table = StepperTable(belt.steppers[0], moving, layout, renderer.font());  // a rotary one
  EXPECT_EQ(table.values[3], "150.0 r/min");
}

// Issue 32, item 4: the plots' y ticks are fixed point with two significant digits (MuJoCo's
// "%.2g" printed 150 r/min as "1.5e+02"), never wider than the layout allows; time ticks say "s".
TEST(RenderLayout, TickLabelsAreFixedPointWithTwoDigitsAndFit) {
  for (double m : {0.001, 0.003, 0.02, 0.5, 2.0, 20.0, 150.0, 2500.0, 99999.0}) {
    for (double v : {m, -m}) {
      char text[64];
      std::snprintf(text, sizeof(text), TickFormat(m), v);
      EXPECT_EQ(std::string(text).find('e'), std::string::npos) << m << ": " << text;
      EXPECT_LE(std::strlen(text), std::strlen(kWidestTick)) << text;
      EXPECT_NEAR(std::strtod(text, nullptr) / v, 1.0, 0.05) << text;  // two digits: 5 %
    }
  }
  char time[16];
  std::snprintf(time, sizeof(time), kTimeTickFormat, 0.25);
  EXPECT_STREQ(time, "0.25s");
}

}  // namespace
}  // namespace mjstepper::tools
