// Report plots drawn into an Image (for `fesim benchmark` and `fesim diagnose` reports): line
// plots, Tukey box plots (single or grouped) and grouped bar charts with nice ticks, grid, labels
// and a legend.
//
// Layout rules a reader relies on (issue 27 item 4, checked in tests/render/plot_test.cc): the
// title is word-wrapped to the image width, never clipped; a plot of ≥ 2 series has a legend,
// placed in a corner of the plot area holding no drawn data or, when every corner holds some, to
// the right of the plot area; point markers are drawn under lines in a lighter tint so that a
// model's line stays visible over its measured points.
//
// Everything here is a pure function of its arguments using integer pixel arithmetic and the
// built-in 5×7 font of render/image.h: the same input gives byte-identical images and PNGs.
#pragma once

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "render/image.h"
#include "render/scene.h"

namespace fesim::render {

/// Colour k of the 8-colour Okabe–Ito palette (colour-blind safe), in the order blue,
/// vermillion, bluish green, orange, sky blue, reddish purple, yellow, black; k is taken modulo 8
/// (negative k too).
Rgba PaletteColour(int k);

/// One curve of a LinePlot. x and y must have the same length; a non-finite x or y (or y ≤ 0 on a
/// log axis) is a gap: the line is broken there.
struct Series {
  std::string label;      ///< legend text.
  std::vector<double> x;  ///< data units of the x axis.
  std::vector<double> y;  ///< data units of the y axis; NaN = gap.
  Rgba colour = PaletteColour(0);
  bool points = false;  ///< true: a 5×5 px square at each point instead of a 2 px line.
};

/// One method of a GroupedBoxPlot: samples[i] is its sample in category i (empty: no box).
struct BoxSeries {
  std::string label;                         ///< legend text.
  std::vector<std::vector<double>> samples;  ///< data units of the y axis, one per category.
  Rgba colour = PaletteColour(0);
};

/// One set of bars of a BarChart: values[i] is the bar of category i (NaN: no bar).
struct BarSeries {
  std::string label;           ///< legend text.
  std::vector<double> values;  ///< data units of the y axis, one per category.
  Rgba colour = PaletteColour(0);
};

/// Text and size of a plot.
struct Axes {
  std::string title;    ///< drawn centred above the plot; empty: none.
  std::string x_label;  ///< drawn centred below the x tick labels; empty: none.
  std::string y_label;  ///< drawn above the y axis, left-aligned; empty: none.
  bool log_y = false;   ///< logarithmic y axis (base 10); values ≤ 0 are not drawn.
  /// Fixed y range in data units (both finite, y_min < y_max; > 0 on a log axis), else NaN for
  /// autoscaling. Data outside is clipped at the plot area's edge: say so in the title.
  double y_min = std::numeric_limits<double>::quiet_NaN();
  double y_max = std::numeric_limits<double>::quiet_NaN();
  int width_px = 800;   ///< image width, pixels, 160–8192 (kMaxImageSidePx).
  int height_px = 450;  ///< image height, pixels, 120–8192 (kMaxImageSidePx).
};

/// Up to max_ticks (at least 2 are allowed) "nice" values m·10^e, m ∈ {1, 2, 5} times an integer,
/// evenly spaced and inside [lo, hi] (lo and hi may come in either order), ascending. The step is
/// the smallest 1-2-5 step giving at most max_ticks ticks. lo == hi gives {lo}; a non-finite bound
/// gives {}.
std::vector<double> NiceTicks(double lo, double hi, int max_ticks);

/// A pixel rectangle: columns [x, x + w), rows [y, y + h); w or h ≤ 0 is no box.
struct PixelBox {
  int x = 0, y = 0, w = 0, h = 0;
  bool empty() const { return w <= 0 || h <= 0; }
};

/// text broken at spaces into lines no wider than max_width_px at this font scale (a word wider
/// than that is broken between characters). Empty text gives no line.
std::vector<std::string> WrapText(const std::string& text, int max_width_px, int scale);

/// The plot area of an image and the data → pixel transform of its axes.
struct PlotFrame {
  int left = 0;                 ///< leftmost pixel column of the plot area.
  int top = 0;                  ///< topmost pixel row of the plot area.
  int right = 0;                ///< rightmost pixel column (inclusive).
  int bottom = 0;               ///< bottom pixel row (inclusive).
  double x_lo = 0, x_hi = 1;    ///< x data range mapped to [left, right].
  double y_lo = 0, y_hi = 1;    ///< y data range mapped to [bottom, top] (> 0 when log_y).
  bool log_y = false;           ///< y maps through log10.
  std::vector<double> x_ticks;  ///< x tick values, data units (category indices for categories).
  std::vector<double> y_ticks;  ///< y tick values, data units.
  std::vector<std::string> title_lines;  ///< the title wrapped to the image width.
  int title_scale = 2;                   ///< font scale of the title.
  PixelBox title_box;                    ///< pixels the title's glyphs occupy; empty: no title.
  PixelBox legend_box;                   ///< the legend; empty: no legend (< 2 series).

  /// Pixel column (fractional) of data x: x_lo → left, x_hi → right.
  double PxX(double x) const;
  /// Pixel row (fractional) of data y: y_lo → bottom, y_hi → top; NaN for y ≤ 0 on a log axis.
  double PxY(double y) const;
};

/// The frame LinePlot uses: x and y ranges of all finite points with 5 % margins each side (a
/// zero-width range is widened around its value, Axes::y_min/y_max override y), nice ticks on
/// both axes, and the legend box (see the layout rules above).
PlotFrame LinePlotFrame(const Axes& axes, const std::vector<Series>& series);

/// Line plot on white: grid, frame, ticks with labels, axis labels, title and a legend box at
/// LinePlotFrame's legend_box when there are ≥ 2 series. Point series are drawn first, as 4×4 px
/// squares in a lighter tint of their colour; lines are 2 px Bresenham segments clipped to the
/// plot area. Throws std::invalid_argument on a bad size or a series whose x and y lengths differ.
Image LinePlot(const Axes& axes, const std::vector<Series>& series);

/// Tukey box-plot statistics of the finite values of a sample.
struct BoxStats {
  std::size_t count = 0;         ///< finite values used.
  double q1 = 0;                 ///< first quartile (NumPy's default "linear" method, type 7).
  double median = 0;             ///< second quartile.
  double q3 = 0;                 ///< third quartile.
  double whisker_lo = 0;         ///< smallest value ≥ q1 − 1.5·IQR.
  double whisker_hi = 0;         ///< largest value ≤ q3 + 1.5·IQR.
  std::vector<double> outliers;  ///< values outside the whiskers, ascending.
};

/// Box statistics of values (non-finite values are ignored). With no finite value count is 0 and
/// the statistics are NaN.
BoxStats ComputeBoxStats(std::vector<double> values);

/// The frame BoxPlot uses: box i centred at x = i (range [−0.5, n − 0.5]), y range of all finite
/// samples with 5 % margins.
PlotFrame BoxPlotFrame(const Axes& axes, const std::vector<std::vector<double>>& samples);

/// Tukey box plot, one box per sample, labelled with group_labels below the x axis: a box from q1
/// to q3 (its colour, translucent fill), a 3 px dark median line, whiskers with caps and outliers
/// as 4×4 px squares. colours: one per box, or empty for PaletteColour(0) throughout. Throws
/// std::invalid_argument on a bad size or when the label or colour counts do not match.
Image BoxPlot(const Axes& axes, const std::vector<std::string>& group_labels,
              const std::vector<std::vector<double>>& samples,
              const std::vector<Rgba>& colours = {});

/// The frame GroupedBoxPlot uses: category i centred at x = i, y range of all finite samples with
/// 5 % margins (Axes::y_min/y_max override), and the legend box.
PlotFrame GroupedBoxPlotFrame(const Axes& axes, const std::vector<std::string>& categories,
                              const std::vector<BoxSeries>& series);

/// Tukey box plot grouped by category: for each category one box per series side by side, drawn
/// as in BoxPlot in the series' colour, the category names as x tick labels and a legend of the
/// series when there are ≥ 2. Throws std::invalid_argument on a bad size or a series without one
/// sample per category.
Image GroupedBoxPlot(const Axes& axes, const std::vector<std::string>& categories,
                     const std::vector<BoxSeries>& series);

/// The frame BarChart uses: category i centred at x = i, y range including 0 and all finite
/// values, with a 5 % margin on the sides away from 0.
PlotFrame BarChartFrame(const Axes& axes, const std::vector<std::string>& categories,
                        const std::vector<BarSeries>& series);

/// Grouped bar chart: for each category one bar per series, side by side, from 0 (from the
/// bottom of a log axis) to the value; legend when there are ≥ 2 series. Throws
/// std::invalid_argument on a bad size or a series without one value per category.
Image BarChart(const Axes& axes, const std::vector<std::string>& categories,
               const std::vector<BarSeries>& series);

/// Convenience: WritePng(path, LinePlot(axes, series)) (atomic; throws like WritePng).
void WriteLinePlotPng(const std::string& path, const Axes& axes, const std::vector<Series>& series);
/// Convenience: WritePng(path, BoxPlot(axes, group_labels, samples, colours)).
void WriteBoxPlotPng(const std::string& path, const Axes& axes,
                     const std::vector<std::string>& group_labels,
                     const std::vector<std::vector<double>>& samples,
                     const std::vector<Rgba>& colours = {});
/// Convenience: WritePng(path, GroupedBoxPlot(axes, categories, series)).
void WriteGroupedBoxPlotPng(const std::string& path, const Axes& axes,
                            const std::vector<std::string>& categories,
                            const std::vector<BoxSeries>& series);
/// Convenience: WritePng(path, BarChart(axes, categories, series)).
void WriteBarChartPng(const std::string& path, const Axes& axes,
                      const std::vector<std::string>& categories,
                      const std::vector<BarSeries>& series);

}  // namespace fesim::render
