#include "render_session.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>

#include "core/units.h"
#include "options.h"
#include "output_file.h"

namespace mjstepper::tools {

struct RenderSession::History {
  std::vector<double> time;
  std::vector<StepperSample> samples;
};

TableText StepperTable(const StepperActuator& stepper, const StepperSample& last,
                       const OverlayLayout& layout, const FontMetrics& font, double rad_per_metre) {
  // The third line: a drive with StallGuard shows SG_RESULT and its stall flag (issue 32, item 4:
  // a homing video could not show the detection); any other its detent damping.
  std::string third_label = "damping", third = "none";
  if (StallGuardOf(stepper.config.controller) != nullptr) {
    third_label = "stall";
    third = fmt::format("SG {:.0f}{}", last.stallguard, last.stall ? " STALL" : "");
  } else if (const HarmonicCompensation* comp = Damping(stepper.config.controller);
             comp != nullptr && !comp->harmonics.empty()) {
    third = "h";
    for (const DetentHarmonic& h : comp->harmonics) third += fmt::format(" {}", h.order);
  }
  auto speed = [rad_per_metre](double omega) {  // rad/s at the rotor
    return rad_per_metre != 0 ? fmt::format("{:.1f} mm/s", 1e3 * omega / rad_per_metre)
                              : fmt::format("{:.1f} r/min", RadPerSecToRpm(omega));
  };
  return {
      {"stepper", "drive", third_label, "cmd", "speed", "load", "lost"},
      {FitText(stepper.name, layout.value_width, font),
       FitText(ControllerName(stepper.config.controller), layout.value_width, font),
       FitText(third, layout.value_width, font), speed(last.omega_cmd),
       speed(last.omega_cmd + last.velocity_error), fmt::format("{:+.3f} el. rad", last.load_angle),
       fmt::format("{:+.0f} steps", last.lost_steps + 0.0)}};
}

RenderSession::RenderSession(const mjModel* m, const std::vector<StepperActuator>& steppers,
                             const RenderOptions& options)
    : model_(m), steppers_(steppers), options_(options), history_(steppers.size()) {
  for (const StepperActuator& s : steppers) rad_per_metre_.push_back(RadPerMetre(m, s).value_or(0));
  RequireInRange("--fps", Range("fps"), options.fps);
  RequireInRange("--playback", Range("playback"), options.playback);
  if (options.overlay_steppers.empty()) {
    for (int i = 0; i < static_cast<int>(steppers.size()); ++i) overlay_.push_back(i);
  } else {
    for (const std::string& name : options.overlay_steppers) {
      const auto it = std::find_if(steppers.begin(), steppers.end(),
                                   [&](const StepperActuator& s) { return s.name == name; });
      if (it == steppers.end()) {
        throw std::invalid_argument(fmt::format("--overlay {}: no stepper of that name", name));
      }
      overlay_.push_back(static_cast<int>(it - steppers.begin()));
    }
  }
  renderer_ = std::make_unique<OffscreenRenderer>(m, options.renderer);
  if (!options.video.empty()) {
    video_.emplace(options.video, renderer_->width(), renderer_->height(), options.fps);
  }
  if (!options.frames_dir.empty()) CheckOutputDirectory(options.frames_dir);
  figure_ = std::make_unique<mjvFigure>();
  layout_ = LayOutOverlay(renderer_->width(), renderer_->height(),
                          static_cast<int>(overlay_.size()), renderer_->font());
}

RenderSession::~RenderSession() = default;

void RenderSession::Step(double t, const std::vector<StepperSample>& samples, mjData* d,
                         double origin) {
  for (size_t i = 0; i < samples.size(); ++i) {
    history_[i].time.push_back(t);
    history_[i].samples.push_back(samples[i]);
  }
  // Frame k shows simulated time k·playback/fps: render each frame whose time has come.
  while (frame_ * options_.playback / options_.fps <= d->time - origin + 1e-12) {
    const double frame_time = frame_ * options_.playback / options_.fps;
    RenderFrame(frame_time, d);
    ++frame_;
    // Later frames never look further back than this one did: drop what is older, in bulk.
    for (History& hist : history_) {
      const size_t stale =
          std::lower_bound(hist.time.begin(), hist.time.end(), frame_time - options_.window) -
          hist.time.begin();
      if (stale > hist.time.size() / 2) {
        hist.time.erase(hist.time.begin(), hist.time.begin() + stale);
        hist.samples.erase(hist.samples.begin(), hist.samples.begin() + stale);
      }
    }
  }
}

void RenderSession::RenderFrame(double frame_time, mjData* d) {
  const int w = renderer_->width(), h = renderer_->height();
  if (!options_.overlays) {
    renderer_->RenderScene(d);
  } else {
    // The scene left of the panel, the panel opaque (nothing of the scene under the plots).
    renderer_->RenderScene(d, layout_.scene);
    renderer_->DrawRectangle(layout_.panel, 0.12f, 0.12f, 0.14f, 1.0f);
    const double video_time = frame_ / options_.fps;  // s: pages turn on the video's clock
    const int page = layout_.PageAt(video_time);
    const int pages = static_cast<int>(layout_.pages.size());
    renderer_->DrawTable(layout_.time, fmt::format("t = {:.4f} s", frame_time), "");
    if (pages > 0) {
      renderer_->DrawTable(
          layout_.header,
          pages == 1
              ? (overlay_.size() == 1 ? std::string("1 stepper")
                                      : fmt::format("all {} steppers", overlay_.size()))
              : fmt::format("page {}/{}, {:g} s each", page + 1, pages, layout_.page_seconds),
          "");
    }
    for (const StepperSlot& slot : pages > 0 ? layout_.pages[page] : std::vector<StepperSlot>{}) {
      const int index = overlay_[slot.stepper];
      const History& hist = history_[index];
      const TableText table = StepperTable(
          steppers_[index], hist.samples.empty() ? StepperSample{} : hist.samples.back(), layout_,
          renderer_->font(), rad_per_metre_[index]);
      renderer_->DrawTable(slot.table, fmt::format("{}", fmt::join(table.labels, "\n")),
                           fmt::format("{}", fmt::join(table.values, "\n")));
      const auto begin =
          std::lower_bound(hist.time.begin(), hist.time.end(), frame_time - options_.window);
      const auto end = std::upper_bound(hist.time.begin(), hist.time.end(), frame_time);
      const size_t first = begin - hist.time.begin(), last = end - hist.time.begin();
      const size_t stride = std::max<size_t>(1, (last - first) / (mjMAXLINEPNT - 1) + 1);
      struct Plot {
        std::vector<std::pair<const char*, double StepperSample::*>> lines;
        double scale;
      };
      const Plot plots[3] = {
          {{{"", &StepperSample::velocity_error}}, 60.0 / kTwoPi},
          {{{"ia", &StepperSample::current_a}, {"ib", &StepperSample::current_b}}, 1.0},
          {{{"", &StepperSample::load_angle}}, 1.0}};
      for (int p = 0; p < 3; ++p) {
        mjvFigure& fig = *figure_;
        mjv_defaultFigure(&fig);
        fig.flg_extend = 1;
        fig.gridsize[0] = 3;
        fig.gridsize[1] = 3;
        fig.flg_ticklabel[0] = p == 2;  // time ticks under the block's last plot only
        fig.figurergba[3] = 0.6f;
        fig.panergba[3] = 0.6f;
        fig.range[0][0] = frame_time - options_.window;
        fig.range[0][1] = frame_time;
        std::snprintf(fig.xformat, sizeof(fig.xformat), "%s", kTimeTickFormat);
        double max_abs = 0;  // of the plotted data: the ticks' decimals (TickFormat)
        std::snprintf(fig.title, sizeof(fig.title), "%s", kPlotTitles[p]);
        const float colours[2][3] = {{0.95f, 0.35f, 0.2f}, {0.3f, 0.7f, 1.0f}};
        for (size_t l = 0; l < plots[p].lines.size(); ++l) {
          int n = 0;
          for (size_t k = first; k < last && n < mjMAXLINEPNT; k += stride, ++n) {
            fig.linedata[l][2 * n] = static_cast<float>(hist.time[k]);
            fig.linedata[l][2 * n + 1] =
                static_cast<float>(plots[p].scale * (hist.samples[k].*plots[p].lines[l].second));
          }
          fig.linepnt[l] = n;
          for (int q = 0; q < n; ++q)
            max_abs = std::max(max_abs, std::abs(static_cast<double>(fig.linedata[l][2 * q + 1])));
          std::copy(colours[l], colours[l] + 3, fig.linergb[l]);
          std::snprintf(fig.linename[l], sizeof(fig.linename[l]), "%s", plots[p].lines[l].first);
        }
        std::snprintf(fig.yformat, sizeof(fig.yformat), "%s", TickFormat(max_abs));
        // The legend (ia, ib) needs two lines of the plot area: MuJoCo cuts it to one below that.
        fig.flg_legend =
            plots[p].lines.size() > 1 && slot.plots[p].height >= 6 * renderer_->font().char_height;
        renderer_->DrawFigure(slot.plots[p], &fig);
      }
    }
  }
  const std::vector<std::uint8_t>& rgb = renderer_->ReadPixels();
  if (video_) video_->Write(rgb);
  if (!options_.frames_dir.empty()) {
    WritePng(fmt::format("{}/frame_{:05d}.png", options_.frames_dir, frame_), rgb, w, h);
  }
}

long RenderSession::Finish() {
  if (video_) video_->Finish();
  video_.reset();
  return frame_;
}

}  // namespace mjstepper::tools
