// Frames per second of the headless renderer on models/tsui_rigid.xml at 640x480: with and
// without overlays, MP4 encoding included (ffmpeg runs on the other core); then the 4-stepper arm
// of the render tests with overlays (the paged side panel). The physics-only time of each run is
// measured too and subtracted. Usage: bench_render [frames].
#include <fmt/format.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "runner.h"

using mjstepper::tools::RunOptions;

namespace {

double WallSeconds(const RunOptions& o) {
  std::ostringstream sink;
  const auto start = std::chrono::steady_clock::now();
  mjstepper::tools::Run(o, sink);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::atoi(argv[1]) : 300;
  RunOptions o;
  o.model = MJSTEPPER_SOURCE_DIR "/models/tsui_rigid.xml";
  o.ctrl = {{"shaft", "ramp(0rpm,200rpm,0.8s)"}};
  o.progress = false;
  o.render.fps = 30;
  o.render.playback = 0.1;  // 300 frames = 1 s simulated
  o.duration = (frames - 1) * o.render.playback / o.render.fps;
  const double physics = WallSeconds(o);
  const auto video = std::filesystem::temp_directory_path() / "mjstepper_bench_render.mp4";
  o.render.video = video.string();
  o.render.renderer = {.width = 640, .height = 480, .camera = "front"};
  fmt::print("{} frames of {} at 640x480 (physics alone: {:.2f} s)\n", frames, o.model, physics);
  for (bool overlays : {false, true}) {
    o.render.overlays = overlays;
    const double seconds = WallSeconds(o) - physics;
    fmt::print("  {:17s} {:6.1f} frames/s  ({:.1f} ms/frame, render + readback + MP4 encode)\n",
               overlays ? "with overlays:" : "without overlays:", frames / seconds,
               1e3 * seconds / frames);
  }
  // Four steppers (the render tests' arm, default camera): the side panel pages through them.
  o.model = MJSTEPPER_SOURCE_DIR "/tests/tools/models/arm4.xml";
  o.ctrl = {{"base", "constant(5rad)"},
            {"shoulder", "constant(-8rad)"},
            {"elbow", "constant(6rad)"},
            {"wrist", "constant(10rad)"}};
  o.render.video.clear();
  const double arm_physics = WallSeconds(o);
  o.render.video = video.string();
  o.render.renderer = {.width = 640, .height = 480, .camera = ""};
  const double arm_seconds = WallSeconds(o) - arm_physics;
  fmt::print("  {:17s} {:6.1f} frames/s  ({:.1f} ms/frame; {} with 4 steppers, physics {:.2f} s)\n",
             "arm4, overlays:", frames / arm_seconds, 1e3 * arm_seconds / frames, o.model,
             arm_physics);
  std::filesystem::remove(video);
  return 0;
}
