// Headless renders: the off-screen renderer, the overlays, the gauge, the video.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <malloc.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "offscreen_renderer.h"
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

RunOptions RenderRun(const std::filesystem::path& dir, bool overlays) {
  RunOptions o;
  o.model = kModel;
  o.duration = 0.1;
  o.ctrl = {{"shaft", "ramp(0rpm,200rpm,0.2s)"}};
  o.progress = false;
  o.render.video = (dir / "run.mp4").string();
  o.render.frames_dir = (dir / "frames").string();
  o.render.renderer = {.width = 320, .height = 240, .camera = "front"};
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

// The overlay's corner holds plot pixels (the velocity-error line's colour) only with overlays on.
TEST(Render, OverlayRegionHasPlotPixels) {
  std::ostringstream sink;
  const auto on = TempDir("overlay_on"), off = TempDir("overlay_off");
  tools::Run(RenderRun(on, true), sink);
  tools::Run(RenderRun(off, false), sink);
  // Frame 5 (0.1 s): the top-left 160x90 holds the first plot, line colour (242, 89, 51); the
  // tolerance 30 leaves out the rotor's red marker (230, 51, 26), which is elsewhere anyway.
  const Frame with = ReadFrameRaw(on / "run.mp4", 5, 320, 240);
  const Frame without = ReadFrameRaw(off / "run.mp4", 5, 320, 240);
  EXPECT_GT(Find(with, 242, 89, 51, 30, 0, 0, 160, 90).count, 10);
  EXPECT_EQ(Find(without, 242, 89, 51, 30, 0, 0, 160, 90).count, 0);
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

}  // namespace
}  // namespace mjstepper::tools
