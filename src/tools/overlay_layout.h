// Where a rendered frame's overlays go: a side panel on the right, at most a third of the frame
// wide, holding per stepper a text table (its full name, drive, speeds, load angle, lost steps) and
// three plots (velocity error, phase currents, load angle); the time and the page at the scene's
// top left. When every stepper's block does not fit legibly, the steppers are split into pages
// that the video cycles through, the header saying which page is shown. Pure
// arithmetic on pixel sizes: no MuJoCo, no GL (the renderer supplies the font's metrics).
#ifndef MJSTEPPER_TOOLS_OVERLAY_LAYOUT_H_
#define MJSTEPPER_TOOLS_OVERLAY_LAYOUT_H_

#include <functional>
#include <string>
#include <vector>

namespace mjstepper::tools {

/// A rectangle in pixels, from the frame's bottom left (MuJoCo's mjrRect convention).
struct PixelRect {
  int left = 0, bottom = 0, width = 0, height = 0;
  int right() const { return left + width; }
  int top() const { return bottom + height; }
};
bool Overlaps(const PixelRect& a, const PixelRect& b);
bool Inside(const PixelRect& inner, const PixelRect& outer);

/// The overlay font, as the renderer's GL context has it: a line's height and a string's width,
/// both in pixels (MuJoCo's mjrContext charHeight and sum of charWidth).
struct FontMetrics {
  int char_height = 0;
  std::function<int(const std::string&)> width;
};

/// MuJoCo's font scale (mjtFontScale, in %) for a frame: text about 1/30 of the frame's height.
/// 50 below 360 pixels high, 100 to 1000, 150 to 1600, 200 above.
int FontScaleFor(int width, int height);

/// The widest text each column of a table must hold: two columns (labels, values), one string per
/// line. MuJoCo's mjr_overlay draws them with its own padding, which TableSize adds.
struct TableText {
  std::vector<std::string> labels, values;
};
/// The size (pixels) mjr_overlay draws a two-column table of these lines in: 5 px padding around
/// and between lines and columns, 8 px after each column's text (MuJoCo's render_gl2.c).
PixelRect TableSize(const TableText& text, const FontMetrics& font);

/// The figure titles, in plot order, and the widest y tick label a plot draws ("%.2g").
extern const char* const kPlotTitles[3];
inline constexpr char kWidestTick[] = "-8.8e+08";

/// The printf format of a plot's y tick labels for data up to `max_abs` in magnitude: fixed point
/// with two significant digits at the largest tick (issue 32, item 4: "%.2g" printed 150 r/min as
/// "1.5e+02"), 0 to 4 decimals; "%.2g" only beyond 1e5, at most as wide as kWidestTick.
const char* TickFormat(double max_abs);

/// The printf format of the time ticks: seconds, with their unit.
inline constexpr char kTimeTickFormat[] = "%.2fs";
/// Worst-case strings of a stepper's table (values widest): the layout reserves room for them; the
/// session fits its names into the same widths (FitText).
TableText StepperTableTemplate();
/// The header's (page) and the time's widest strings.
TableText HeaderTemplate();
TableText TimeTemplate();

/// The longest prefix of text (with "~" marking a cut) no wider than max_width pixels.
std::string FitText(const std::string& text, int max_width, const FontMetrics& font);

struct StepperSlot {
  int stepper = 0;     ///< index in the model's stepper order
  PixelRect table;     ///< its text table (mjr_overlay, top left)
  PixelRect plots[3];  ///< velocity error, phase currents, load angle (mjr_figure)
};

struct OverlayLayout {
  PixelRect frame;   ///< the whole frame
  PixelRect panel;   ///< the side panel's background; all but `time` and `header` lie inside it
  PixelRect scene;   ///< the rest of the frame, where the 3D scene is drawn
  PixelRect header;  ///< the page shown (mjr_overlay), at the scene's top, right of `time`
  PixelRect time;    ///< the simulated time, at the scene's top left
  int label_width = 0, value_width = 0;  ///< pixels each table column may use (for FitText)
  int steppers_per_page = 0;
  std::vector<std::vector<StepperSlot>> pages;  ///< every stepper in exactly one page
  bool legible = true;  ///< false: the frame is too small for one stepper's block at the minimum
                        ///< sizes; the rectangles still lie inside the panel, but shrink
  double page_seconds = 3;  ///< video seconds each page is shown

  /// The page shown at video time t (s): pages cycle every page_seconds.
  int PageAt(double video_time) const;
};

/// Fraction of the frame's width the panel may take at most.
inline constexpr double kMaxPanelFraction = 1.0 / 3.0;

/// Lays out the overlays of a width × height frame with `steppers` steppers (0 gives a header
/// only). Each plot is at least kMinPlotLines text lines high (title, x ticks, padding and a plot
/// area of a line) and as wide as its title and tick labels need.
OverlayLayout LayOutOverlay(int width, int height, int steppers, const FontMetrics& font);

/// A plot's minimum height, in text lines: title 1.5, x tick labels 1.5, padding 1, plot area 1
/// (a 90-pixel plot at 640x480 shows its line over about 40 pixels, with three y ticks).
inline constexpr double kMinPlotLines = 5;

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_OVERLAY_LAYOUT_H_
