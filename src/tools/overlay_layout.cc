#include "overlay_layout.h"

#include <algorithm>
#include <cmath>

namespace mjstepper::tools {

bool Overlaps(const PixelRect& a, const PixelRect& b) {
  return a.left < b.right() && b.left < a.right() && a.bottom < b.top() && b.bottom < a.top();
}

bool Inside(const PixelRect& inner, const PixelRect& outer) {
  return inner.left >= outer.left && inner.bottom >= outer.bottom &&
         inner.right() <= outer.right() && inner.top() <= outer.top() && inner.width >= 0 &&
         inner.height >= 0;
}

int FontScaleFor(int /*width*/, int height) {
  // MuJoCo's normal font is 18 px high at 100 % (its 50 % is the same font), 28 px at 150 %, 37 px
  // at 200 % (measured with mjr_makeContext): a line every 1/27 to 1/65 of the frame's height.
  return height <= 1200 ? 100 : height <= 1800 ? 150 : 200;
}

const char* const kPlotTitles[3] = {"velocity error (r/min)", "phase currents (A)",
                                    "load angle (el. rad)"};

TableText StepperTableTemplate() {
  // The stepper's name and its drive each on a line of their own, in the values' column, the
  // panel's widest (issue 32, item 4: a name cut to the label column read "steppe~"); each is
  // fitted to it only when longer than the whole column.
  return {{"stepper", "drive", "damping", "cmd", "speed", "load", "lost"},
          {"-8888.8 r/min", "-8888.8 r/min", "SG 1023 STALL", "-8888.8 r/min", "-8888.8 r/min",
           "+8.888 el. rad", "+88888 steps"}};
}

// (One page says "all N steppers", narrower.)
TableText HeaderTemplate() { return {{"page 88/88, 8 s each"}, {}}; }
TableText TimeTemplate() { return {{"t = 8888.8888 s"}, {}}; }

namespace {

// mjr_overlay's padding (render_gl2.c, draw_overlay): PAD = 5 around the text and between lines,
// 8 after a column's text; the second column starts PAD after the first one's width less 2; the
// box's top is 1 + PAD below the rectangle's.
constexpr int kPad = 5;

int Widest(const std::vector<std::string>& lines, const FontMetrics& font) {
  int widest = 0;
  for (const std::string& line : lines) widest = std::max(widest, font.width(line));
  return widest;
}

// The width a column of this text width takes in mjr_overlay.
int ColumnWidth(int text_width) { return kPad + text_width + 8; }

}  // namespace

PixelRect TableSize(const TableText& text, const FontMetrics& font) {
  const int lines = static_cast<int>(std::max(text.labels.size(), text.values.size()));
  const int text_height = kPad + lines * font.char_height + (lines - 1) * kPad;
  const int first = ColumnWidth(Widest(text.labels, font));
  const int second = text.values.empty() ? 0 : kPad - 2 + ColumnWidth(Widest(text.values, font));
  // Left PAD, the columns, 1 px to spare on the right; top 1 + PAD, 1 px to spare below.
  return {0, 0, kPad + first + second + 1, 1 + kPad + text_height + 1};
}

std::string FitText(const std::string& text, int max_width, const FontMetrics& font) {
  if (font.width(text) <= max_width) return text;
  std::string cut = text;
  while (!cut.empty() && font.width(cut + "~") > max_width) cut.pop_back();
  return font.width(cut + "~") <= max_width ? cut + "~" : "";
}

const char* TickFormat(double max_abs) {
  if (!(max_abs < 1e5)) return "%.2g";  // NaN, inf, absurd: MuJoCo's own compact form
  static const char* const kFixed[] = {"%.0f", "%.1f", "%.2f", "%.3f", "%.4f"};
  const int decimals =
      max_abs > 0 ? static_cast<int>(std::clamp(1.0 - std::floor(std::log10(max_abs)), 0.0, 4.0))
                  : 1;
  return kFixed[decimals];
}

int OverlayLayout::PageAt(double video_time) const {
  const int n = static_cast<int>(pages.size());
  if (n <= 1) return 0;
  return static_cast<int>(std::floor(std::max(0.0, video_time) / page_seconds)) % n;
}

OverlayLayout LayOutOverlay(int width, int height, int steppers, const FontMetrics& font) {
  constexpr int kGap = 4;  // pixels between panels and around the panel's content
  OverlayLayout layout;
  layout.frame = {0, 0, width, height};
  const int panel_width = static_cast<int>(std::floor(width * kMaxPanelFraction));
  layout.panel = {width - panel_width, 0, panel_width, height};
  layout.scene = {0, 0, width - panel_width, height};
  const int inner_left = layout.panel.left + kGap;
  const int inner_width = std::max(0, panel_width - 2 * kGap);
  const int ch = font.char_height;

  // The time at the scene's top left, the page (header) beside it: the panel's whole height is
  // the steppers' (issue 32, item 4: their tables gained a line for the stepper's full name).
  const PixelRect header = TableSize(HeaderTemplate(), font);
  const PixelRect time = TableSize(TimeTemplate(), font);
  layout.time = {0, std::max(0, height - time.height), std::min(time.width, layout.scene.width),
                 std::min(time.height, height)};
  const int header_left = std::min(layout.time.right() + kGap, layout.scene.right());
  layout.header = {header_left, std::max(0, height - header.height),
                   std::min(header.width, layout.scene.right() - header_left),
                   std::min(header.height, height)};
  layout.legible = time.width + kGap + header.width <= layout.scene.width;

  // A stepper's block: its table, then three plots, each kMinPlotLines lines high at least and as
  // wide as its title and y tick labels need (mjr_figure centres the title and clips it, pads
  // charHeight/2 around the plot area, and puts the tick labels left of it).
  const TableText table_text = StepperTableTemplate();
  const PixelRect table = TableSize(table_text, font);
  int min_plot_width = 0;
  for (const char* title : kPlotTitles)
    min_plot_width = std::max(min_plot_width, font.width(title));
  min_plot_width = std::max(min_plot_width + 4, font.width(kWidestTick) + 3 * (ch / 2) + 3 * ch);
  const int min_plot_height = static_cast<int>(std::ceil(kMinPlotLines * ch));
  const int min_block_width = std::max(table.width, min_plot_width);
  const int min_block_height = table.height + 3 * (kGap + min_plot_height);
  if (steppers <= 0) return layout;

  // Stepper blocks fill the panel below the header in columns and rows: the fewest pages, and for
  // those the fewest columns (the widest plots).
  const int area_top = height - kGap, area_bottom = kGap;
  const int area_height = std::max(0, area_top - area_bottom);
  const int max_rows = std::max(1, (area_height + kGap) / (min_block_height + kGap));
  const int max_columns = std::max(1, (inner_width + kGap) / (min_block_width + kGap));
  int columns = 1, rows = 1, pages = steppers + 1;
  for (int c = 1; c <= max_columns; ++c) {
    const int r = std::min(max_rows, (steppers + c - 1) / c);
    const int p = (steppers + c * r - 1) / (c * r);
    if (p < pages) columns = c, rows = r, pages = p;
  }
  layout.steppers_per_page = columns * rows;
  layout.legible =
      layout.legible && min_block_width <= inner_width && min_block_height <= area_height;

  const int block_width = std::max(0, (inner_width + kGap) / columns - kGap);
  const int block_height = std::max(0, (area_height + kGap) / rows - kGap);
  const int plot_height = std::max(0, (block_height - table.height - 3 * kGap) / 3);
  const int table_height = std::min(table.height, block_height);
  // Table columns: the labels' own width; the values' column takes the rest of the block.
  layout.label_width = Widest(table_text.labels, font);
  layout.value_width = std::max(
      0, block_width - kPad - ColumnWidth(layout.label_width) - (kPad - 2) - ColumnWidth(0) - 1);
  for (int first = 0; first < steppers; first += layout.steppers_per_page) {
    std::vector<StepperSlot>& page = layout.pages.emplace_back();
    for (int k = 0; k < layout.steppers_per_page && first + k < steppers; ++k) {
      const int column = k % columns, row = k / columns;
      const int left = inner_left + column * (block_width + kGap);
      const int top = area_top - row * (block_height + kGap);
      StepperSlot slot;
      slot.stepper = first + k;
      slot.table = {left, top - table_height, block_width, table_height};
      int y = slot.table.bottom;
      for (PixelRect& plot : slot.plots) {
        y -= kGap + plot_height;
        plot = {left, std::max(0, y), block_width, plot_height};
      }
      page.push_back(slot);
    }
  }
  return layout;
}

}  // namespace mjstepper::tools
