// Frames per second of the headless renderer on models/tsui_rigid.xml at 640x480: with and
// without overlays, MP4 encoding included (ffmpeg runs on the other core). The physics-only time of
// the same run is measured too and subtracted. Usage: bench_render [frames].
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
  std::filesystem::remove(video);
  return 0;
}
