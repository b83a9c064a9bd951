#include "render/plot.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "render/video.h"

namespace fesim::render {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Whether pixel (x, y) has exactly the 8-bit value of an opaque colour.
bool IsColour(const Image& image, int x, int y, Rgba c) {
  if (x < 0 || y < 0 || x >= image.width || y >= image.height) return false;
  const std::uint8_t* p = image.At(x, y);
  const auto byte = [](float v) { return static_cast<std::uint8_t>(std::lround(v * 255.0f)); };
  return p[0] == byte(c.r) && p[1] == byte(c.g) && p[2] == byte(c.b);
}

int Round(double v) { return static_cast<int>(std::lround(v)); }

void ExpectTicks(const std::vector<double>& actual, const std::vector<double>& expected) {
  ASSERT_EQ(actual.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_DOUBLE_EQ(actual[i], expected[i]) << i;
}

TEST(NiceTicksTest, ZeroToOne) {
  ExpectTicks(NiceTicks(0, 1, 6), {0, 0.2, 0.4, 0.6, 0.8, 1});
  ExpectTicks(NiceTicks(0, 1, 11), {0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1});
  ExpectTicks(NiceTicks(0, 1, 3), {0, 0.5, 1});
  ExpectTicks(NiceTicks(0, 1, 1), {0, 1});  // at least 2 ticks are allowed
}

TEST(NiceTicksTest, ZeroToSevenPointThree) {
  ExpectTicks(NiceTicks(0, 7.3, 6), {0, 2, 4, 6});
  ExpectTicks(NiceTicks(0, 7.3, 10), {0, 1, 2, 3, 4, 5, 6, 7});
  ExpectTicks(NiceTicks(0, 7.3, 3), {0, 5});
}

TEST(NiceTicksTest, NegativeRangesAndOrder) {
  ExpectTicks(NiceTicks(-3.7, -0.2, 5), {-3, -2, -1});
  ExpectTicks(NiceTicks(-1, 1, 5), {-1, -0.5, 0, 0.5, 1});
  ExpectTicks(NiceTicks(1, -1, 5), {-1, -0.5, 0, 0.5, 1});
  ExpectTicks(NiceTicks(-0.07, 0.13, 5), {-0.05, 0, 0.05, 0.1});
  ExpectTicks(NiceTicks(-2500, 12000, 8), {0, 5000, 10000});
  EXPECT_FALSE(std::signbit(NiceTicks(-1, 1, 5)[2]));  // 0, not -0
}

TEST(NiceTicksTest, DegenerateRanges) {
  ExpectTicks(NiceTicks(2.5, 2.5, 5), {2.5});
  EXPECT_TRUE(NiceTicks(kNaN, 1, 5).empty());
  EXPECT_TRUE(NiceTicks(0, std::numeric_limits<double>::infinity(), 5).empty());
}

TEST(NiceTicksTest, StepsAreOneTwoFiveAndCountIsBounded) {
  for (double hi : {0.013, 0.9, 3.3, 47.0, 101.0, 2.2e5}) {
    for (int max_ticks = 2; max_ticks <= 12; ++max_ticks) {
      const std::vector<double> t = NiceTicks(-0.3 * hi, hi, max_ticks);
      // A step may exceed half the range (only one tick inside) only when max_ticks < 6.
      EXPECT_GE(t.size(), max_ticks < 6 ? 1u : 2u) << hi << " " << max_ticks;
      EXPECT_LE(t.size(), static_cast<std::size_t>(max_ticks)) << hi << " " << max_ticks;
      EXPECT_GE(t.front(), -0.3 * hi);
      EXPECT_LE(t.back(), hi);
      if (t.size() < 2) continue;
      const double step = t[1] - t[0];
      const double mantissa = step / std::pow(10.0, std::floor(std::log10(step) + 1e-9));
      EXPECT_TRUE(std::abs(mantissa - 1) < 1e-6 || std::abs(mantissa - 2) < 1e-6 ||
                  std::abs(mantissa - 5) < 1e-6)
          << step;
    }
  }
}

TEST(PaletteColourTest, OkabeItoWrapsAround) {
  const Rgba blue = PaletteColour(0);
  EXPECT_FLOAT_EQ(blue.r, 0.0f);
  EXPECT_FLOAT_EQ(blue.g, 114 / 255.0f);
  EXPECT_FLOAT_EQ(blue.b, 178 / 255.0f);
  EXPECT_FLOAT_EQ(PaletteColour(9).r, PaletteColour(1).r);
  EXPECT_FLOAT_EQ(PaletteColour(-1).g, PaletteColour(7).g);
}

TEST(ComputeBoxStatsTest, QuartilesLikeNumpyAndHighOutlier) {
  // np.percentile([1..9, 100], [25, 50, 75]) = [3.25, 5.5, 7.75]; fences −3.5 and 14.5.
  const BoxStats b = ComputeBoxStats({100, 9, 1, 8, 2, 7, 3, 6, 4, 5});
  EXPECT_EQ(b.count, 10u);
  EXPECT_DOUBLE_EQ(b.q1, 3.25);
  EXPECT_DOUBLE_EQ(b.median, 5.5);
  EXPECT_DOUBLE_EQ(b.q3, 7.75);
  EXPECT_DOUBLE_EQ(b.whisker_lo, 1);
  EXPECT_DOUBLE_EQ(b.whisker_hi, 9);
  ASSERT_EQ(b.outliers.size(), 1u);
  EXPECT_DOUBLE_EQ(b.outliers[0], 100);
}

TEST(ComputeBoxStatsTest, EvenSampleWithoutOutliers) {
  // np.percentile([7, 15, 36, 39, 40, 41], [25, 50, 75]) = [20.25, 37.5, 39.75].
  const BoxStats b = ComputeBoxStats({41, 7, 39, 15, 40, 36});
  EXPECT_DOUBLE_EQ(b.q1, 20.25);
  EXPECT_DOUBLE_EQ(b.median, 37.5);
  EXPECT_DOUBLE_EQ(b.q3, 39.75);
  EXPECT_DOUBLE_EQ(b.whisker_lo, 7);
  EXPECT_DOUBLE_EQ(b.whisker_hi, 41);
  EXPECT_TRUE(b.outliers.empty());
}

TEST(ComputeBoxStatsTest, LowOutliersAndNonFiniteValuesIgnored) {
  // Finite values {−50, 1, 2, 3, 4, 5}: q1 = 1.25, median = 2.5, q3 = 3.75, fences −2.5 and 7.5.
  const BoxStats b =
      ComputeBoxStats({5, kNaN, 1, -50, 3, std::numeric_limits<double>::infinity(), 2, 4});
  EXPECT_EQ(b.count, 6u);
  EXPECT_DOUBLE_EQ(b.q1, 1.25);
  EXPECT_DOUBLE_EQ(b.median, 2.5);
  EXPECT_DOUBLE_EQ(b.q3, 3.75);
  EXPECT_DOUBLE_EQ(b.whisker_lo, 1);
  EXPECT_DOUBLE_EQ(b.whisker_hi, 5);
  ASSERT_EQ(b.outliers.size(), 1u);
  EXPECT_DOUBLE_EQ(b.outliers[0], -50);
}

TEST(ComputeBoxStatsTest, SingleValueAndEmpty) {
  const BoxStats one = ComputeBoxStats({4});
  EXPECT_EQ(one.count, 1u);
  EXPECT_DOUBLE_EQ(one.q1, 4);
  EXPECT_DOUBLE_EQ(one.median, 4);
  EXPECT_DOUBLE_EQ(one.q3, 4);
  EXPECT_DOUBLE_EQ(one.whisker_lo, 4);
  EXPECT_DOUBLE_EQ(one.whisker_hi, 4);
  const BoxStats none = ComputeBoxStats({kNaN});
  EXPECT_EQ(none.count, 0u);
  EXPECT_TRUE(std::isnan(none.median));
  EXPECT_TRUE(none.outliers.empty());
}

/// y = x for x = 0, 1, …, 10, with y[gap] = NaN when gap ≥ 0.
Series Diagonal(int gap) {
  Series s;
  s.label = "y = x";
  for (int i = 0; i <= 10; ++i) {
    s.x.push_back(i);
    s.y.push_back(i == gap ? kNaN : i);
  }
  return s;
}

TEST(LinePlotTest, DiagonalLineFollowsTheTransform) {
  Axes axes;
  axes.title = "Diagonal";
  axes.x_label = "x (s)";
  axes.y_label = "y (rad)";
  const std::vector<Series> series = {Diagonal(-1)};
  const PlotFrame f = LinePlotFrame(axes, series);
  const Image image = LinePlot(axes, series);
  ASSERT_EQ(image.width, 800);
  ASSERT_EQ(image.height, 450);
  // 5 % margins: x and y ranges are [−0.5, 10.5].
  EXPECT_DOUBLE_EQ(f.x_lo, -0.5);
  EXPECT_DOUBLE_EQ(f.x_hi, 10.5);
  EXPECT_DOUBLE_EQ(f.y_lo, -0.5);
  EXPECT_DOUBLE_EQ(f.y_hi, 10.5);
  const Rgba c = series[0].colour;
  const auto expected_row = [&](int col) {
    const double x = f.x_lo + (col - f.left) * (f.x_hi - f.x_lo) / (f.right - f.left);
    return f.PxY(x);
  };
  const int first = Round(f.PxX(0)), last = Round(f.PxX(10));
  for (int col = first; col <= last; ++col) {
    const int row = Round(expected_row(col));
    bool hit = false;
    for (int r = row - 2; r <= row + 2; ++r) hit = hit || IsColour(image, col, r, c);
    EXPECT_TRUE(hit) << "column " << col << " row " << row;
  }
  int coloured = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      if (!IsColour(image, x, y, c)) continue;
      ++coloured;
      EXPECT_GE(x, first - 1);
      EXPECT_LE(x, last + 2);
      EXPECT_LE(std::abs(y - expected_row(x)), 3.0) << x << "," << y;
    }
  }
  EXPECT_GT(coloured, 2 * (last - first));
  // Grid and frame: the plot corner is the frame colour, a point between grid lines is white.
  EXPECT_TRUE(IsColour(image, f.left, f.top, Rgba{0.10f, 0.10f, 0.12f, 1}));
}

TEST(LinePlotTest, NanLeavesAGap) {
  const Axes axes;
  const std::vector<Series> series = {Diagonal(5)};
  const PlotFrame f = LinePlotFrame(axes, series);
  const Image image = LinePlot(axes, series);
  const Rgba c = series[0].colour;
  const auto coloured_in_column = [&](int col) {
    for (int y = 0; y < image.height; ++y) {
      if (IsColour(image, col, y, c)) return true;
    }
    return false;
  };
  for (int col = Round(f.PxX(4)) + 3; col <= Round(f.PxX(6)) - 1; ++col) {
    EXPECT_FALSE(coloured_in_column(col)) << col;
  }
  EXPECT_TRUE(coloured_in_column(Round(f.PxX(3.5))));
  EXPECT_TRUE(coloured_in_column(Round(f.PxX(6.5))));
}

TEST(LinePlotTest, ConstantSeriesAndNoData) {
  Series flat;
  flat.x = {0, 1, 2};
  flat.y = {3, 3, 3};
  const PlotFrame f = LinePlotFrame(Axes{}, {flat});
  EXPECT_LT(f.y_lo, 3);
  EXPECT_GT(f.y_hi, 3);
  EXPECT_GE(f.y_ticks.size(), 2u);
  const Image image = LinePlot(Axes{}, {flat});
  const int row = Round(f.PxY(3));
  bool hit = false;
  for (int r = row - 1; r <= row + 1; ++r)
    hit = hit || IsColour(image, Round(f.PxX(1)), r, flat.colour);
  EXPECT_TRUE(hit);
  EXPECT_NO_THROW(LinePlot(Axes{}, {}));
  EXPECT_NO_THROW(LinePlot(Axes{}, {Diagonal(-1), Series{"empty", {}, {}, PaletteColour(1)}}));
}

TEST(LinePlotTest, LogAxisHasDecadeTicks) {
  Axes axes;
  axes.log_y = true;
  Series s;
  for (int i = 0; i <= 30; ++i) {
    s.x.push_back(i / 10.0);
    s.y.push_back(std::pow(10.0, i / 10.0));
  }
  s.x.push_back(3.5);
  s.y.push_back(0);  // not drawable on a log axis: ignored
  const PlotFrame f = LinePlotFrame(axes, {s});
  ExpectTicks(f.y_ticks, {1, 10, 100, 1000});
  // y = 10^x is a straight line on a log axis: its middle point is halfway up.
  EXPECT_NEAR(f.PxY(std::pow(10.0, 1.5)), (f.PxY(1) + f.PxY(1000)) / 2, 1e-6);
  const Image image = LinePlot(axes, {s});
  bool hit = false;
  const int col = Round(f.PxX(1.5)), row = Round(f.PxY(std::pow(10.0, 1.5)));
  for (int r = row - 2; r <= row + 2; ++r) hit = hit || IsColour(image, col, r, s.colour);
  EXPECT_TRUE(hit);
}

TEST(LinePlotTest, BadInputThrows) {
  Series bad;
  bad.x = {0, 1};
  bad.y = {0};
  EXPECT_THROW(LinePlot(Axes{}, {bad}), std::invalid_argument);
  Axes tiny;
  tiny.width_px = 10;
  EXPECT_THROW(LinePlot(tiny, {}), std::invalid_argument);
}

TEST(PlotTest, SmallestSizeDraws) {
  Axes axes;
  axes.title = "a title longer than the smallest image is wide";
  axes.x_label = "x";
  axes.y_label = "y";
  axes.width_px = 160;
  axes.height_px = 120;
  const Image line = LinePlot(axes, {Diagonal(2), Diagonal(-1)});
  EXPECT_EQ(line.width, 160);
  EXPECT_EQ(line.height, 120);
  EXPECT_EQ(BoxPlot(axes, {"a"}, {{1, 2, 3}}).rgb.size(), 3u * 160 * 120);
  EXPECT_EQ(BarChart(axes, {"a", "b"}, {{"s", {1, -2}, PaletteColour(3)}}).rgb.size(),
            3u * 160 * 120);
}

TEST(PlotTest, SameInputGivesIdenticalPng) {
  Axes axes;
  axes.title = "Two models";
  Series a = Diagonal(3);
  Series b = Diagonal(-1);
  b.label = "points";
  b.points = true;
  b.colour = PaletteColour(1);
  for (double& y : b.y) y = 10 - y;
  const std::vector<std::uint8_t> png = EncodePng(LinePlot(axes, {a, b}));
  EXPECT_EQ(png, EncodePng(LinePlot(axes, {a, b})));
  const std::vector<std::vector<double>> samples = {{1, 2, 3, 4, 30}, {2, 3, 3.5}};
  EXPECT_EQ(EncodePng(BoxPlot(axes, {"a", "b"}, samples)),
            EncodePng(BoxPlot(axes, {"a", "b"}, samples)));
  const std::vector<BarSeries> bars = {{"one", {1, 2}, PaletteColour(0)},
                                       {"two", {1.5, kNaN}, PaletteColour(1)}};
  EXPECT_EQ(EncodePng(BarChart(axes, {"elbow", "shoulder"}, bars)),
            EncodePng(BarChart(axes, {"elbow", "shoulder"}, bars)));
}

TEST(BoxPlotTest, MedianLineAtExpectedRow) {
  Axes axes;
  axes.y_label = "error (deg)";
  const std::vector<std::vector<double>> samples = {{1, 2, 3, 4, 5}, {2, 4, 6, 8, 10, 40}};
  const std::vector<Rgba> colours = {PaletteColour(0), PaletteColour(2)};
  const PlotFrame f = BoxPlotFrame(axes, samples);
  EXPECT_DOUBLE_EQ(f.x_lo, -0.5);
  EXPECT_DOUBLE_EQ(f.x_hi, 1.5);
  const Image image = BoxPlot(axes, {"model A", "model B"}, samples, colours);
  const Rgba ink{0.10f, 0.10f, 0.12f, 1};
  for (const auto& [box, median] : {std::pair<int, double>{0, 3}, {1, 7}}) {
    const int col = Round(f.PxX(box)) + 4;
    const int row = Round(f.PxY(median));
    EXPECT_TRUE(IsColour(image, col, row, ink)) << box;
    EXPECT_FALSE(IsColour(image, col, row - 4, ink)) << box;
    EXPECT_FALSE(IsColour(image, col, row + 4, ink)) << box;
    EXPECT_FALSE(IsColour(image, col, row - 4, Rgba{1, 1, 1, 1})) << box;  // box fill
  }
  // 40 is beyond q3 + 1.5 IQR = 9.5 + 7.5: drawn as an outlier square in the box colour.
  EXPECT_TRUE(IsColour(image, Round(f.PxX(1)), Round(f.PxY(40)), colours[1]));
  EXPECT_THROW(BoxPlot(axes, {"one label"}, samples), std::invalid_argument);
  EXPECT_THROW(BoxPlot(axes, {"a", "b"}, samples, {PaletteColour(0)}), std::invalid_argument);
}

TEST(BarChartTest, GroupedBarsFromZero) {
  Axes axes;
  axes.y_label = "normalised RMS error";
  const std::vector<std::string> joints = {"shoulder", "elbow", "wrist"};
  const std::vector<BarSeries> bars = {{"Hill", {0.2, 0.5, 0.3}, PaletteColour(0)},
                                       {"Hammerstein", {0.4, 0.1, kNaN}, PaletteColour(1)}};
  const PlotFrame f = BarChartFrame(axes, joints, bars);
  EXPECT_DOUBLE_EQ(f.y_lo, 0);  // no margin below the bars' baseline
  EXPECT_GT(f.y_hi, 0.5);
  // Headroom for the legend (6 px from the frame, 29 px high at 800×450): the tallest bar ends
  // below it.
  EXPECT_GT(Round(f.PxY(0.5)), f.top + 6 + 29);
  const Image image = BarChart(axes, joints, bars);
  // Bar j of category i spans x ∈ i − 0.4 + 0.4·[j, j + 1].
  EXPECT_TRUE(IsColour(image, Round(f.PxX(1 - 0.2)), Round(f.PxY(0.25)), bars[0].colour));
  EXPECT_TRUE(IsColour(image, Round(f.PxX(1 + 0.2)), Round(f.PxY(0.05)), bars[1].colour));
  EXPECT_FALSE(IsColour(image, Round(f.PxX(1 + 0.2)), Round(f.PxY(0.2)), bars[1].colour));
  EXPECT_FALSE(IsColour(image, Round(f.PxX(2 + 0.2)), Round(f.PxY(0.05)), bars[1].colour));
  EXPECT_THROW(BarChart(axes, {"one"}, bars), std::invalid_argument);
}

// Layout rules of render/plot.h (issue 27 item 4: titles clipped, legends over data).

/// Whether pixel (x, y) lies in box.
bool Inside(const PixelBox& b, int x, int y) {
  return x >= b.x && x < b.x + b.w && y >= b.y && y < b.y + b.h;
}

/// Whether box lies wholly inside a width × height image.
bool InImage(const PixelBox& b, int width, int height) {
  return !b.empty() && b.x >= 0 && b.y >= 0 && b.x + b.w <= width && b.y + b.h <= height;
}

TEST(WrapTextTest, LinesFitAndKeepTheWords) {
  const std::string title = "Hand array: normalised cross-validation error (paper 000 Tables 1-2)";
  ASSERT_GT(TextWidthPx(title, 2), 780);  // wider than the 800 px image less its margins
  const std::vector<std::string> lines = WrapText(title, 780, 2);
  ASSERT_EQ(lines.size(), 2u);
  std::string joined;
  for (const std::string& l : lines) {
    EXPECT_LE(TextWidthPx(l, 2), 780) << l;
    joined += (joined.empty() ? "" : " ") + l;
  }
  EXPECT_EQ(joined, title);
  // A word wider than the line is broken between characters.
  const std::vector<std::string> broken = WrapText(std::string(40, 'w'), 60, 1);
  ASSERT_GE(broken.size(), 4u);
  for (const std::string& l : broken) EXPECT_LE(TextWidthPx(l, 1), 60) << l;
  EXPECT_TRUE(WrapText("", 100, 1).empty());
}

TEST(PlotLayoutTest, LongTitleIsWrappedInsideTheImageAboveThePlot) {
  Axes axes;
  axes.title =
      "Reaching LOOCV normalised RMS torque error (1 = parametric, 2 = GP, 3 = semiparam.)";
  axes.y_label = "RMS torque error / max |torque| (dimensionless)";
  for (const int width : {800, 1000}) {
    axes.width_px = width;
    const PlotFrame f = LinePlotFrame(axes, {Diagonal(-1)});
    EXPECT_TRUE(InImage(f.title_box, axes.width_px, axes.height_px)) << width;
    EXPECT_GE(f.title_lines.size(), 2u) << width;
    EXPECT_LT(f.title_box.y + f.title_box.h, f.top) << width;  // the title ends above the plot
    // The title's glyphs are drawn in its box: ink in its first row band.
    const Image image = LinePlot(axes, {Diagonal(-1)});
    int ink = 0;
    for (int x = f.title_box.x; x < f.title_box.x + f.title_box.w; ++x) {
      for (int y = f.title_box.y; y < f.title_box.y + f.title_box.h; ++y) {
        ink += IsColour(image, x, y, Rgba{0.10f, 0.10f, 0.12f, 1}) ? 1 : 0;
      }
    }
    EXPECT_GT(ink, 100) << width;
  }
}

TEST(PlotLayoutTest, LegendGoesToAnEmptyCornerNotOverTheData) {
  // Like hand_array_prediction.png: three joints rising to the top right, measured points and
  // model lines; the top right corner holds data, the top left does not.
  Axes axes;
  axes.width_px = 1000;
  std::vector<Series> series;
  for (int j = 0; j < 3; ++j) {
    Series measured, model;
    measured.label = "joint " + std::to_string(j) + " measured";
    model.label = "joint " + std::to_string(j) + " model";
    measured.points = true;
    measured.colour = model.colour = PaletteColour(j);
    for (int i = 0; i <= 500; ++i) {
      const double t = 0.1 * i;
      const double y = 10 * j + (t < 35 ? 0 : 30 + 5 * j);
      measured.x.push_back(t);
      measured.y.push_back(y + (i % 7 - 3) * 0.5);
      model.x.push_back(t);
      model.y.push_back(y);
    }
    series.push_back(measured);
    series.push_back(model);
  }
  const PlotFrame f = LinePlotFrame(axes, series);
  ASSERT_FALSE(f.legend_box.empty());
  EXPECT_TRUE(InImage(f.legend_box, axes.width_px, axes.height_px));
  for (const Series& s : series) {
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      EXPECT_FALSE(Inside(f.legend_box, Round(f.PxX(s.x[i])), Round(f.PxY(s.y[i]))))
          << s.label << " point " << i;
    }
  }
  // One series: no legend.
  EXPECT_TRUE(LinePlotFrame(axes, {series[1]}).legend_box.empty());
}

TEST(PlotLayoutTest, LegendMovesRightOfThePlotWhenEveryCornerHoldsData) {
  Axes axes;
  Series a = Diagonal(-1), b = Diagonal(-1);  // an X through all four corners
  a.label = "rising";
  b.label = "falling";
  b.colour = PaletteColour(1);
  for (double& y : b.y) y = 10 - y;
  const PlotFrame f = LinePlotFrame(axes, {a, b});
  ASSERT_FALSE(f.legend_box.empty());
  EXPECT_GT(f.legend_box.x, f.right);  // outside the plot area
  EXPECT_TRUE(InImage(f.legend_box, axes.width_px, axes.height_px));
  const Image image = LinePlot(axes, {a, b});
  EXPECT_TRUE(IsColour(image, f.legend_box.x, f.legend_box.y, Rgba{0.10f, 0.10f, 0.12f, 1}));
}

TEST(PlotLayoutTest, BarLegendDoesNotCoverBars) {
  Axes axes;
  const std::vector<std::string> joints = {"wrist_flexion", "mcp_flexion", "pip_flexion"};
  const std::vector<BarSeries> bars = {{"fesim", {0.4, 0.8, 1.05}, PaletteColour(0)},
                                       {"paper", {0.6, 0.5, 0.75}, PaletteColour(1)}};
  const PlotFrame f = BarChartFrame(axes, joints, bars);
  ASSERT_FALSE(f.legend_box.empty());
  for (std::size_t j = 0; j < bars.size(); ++j) {
    for (std::size_t i = 0; i < joints.size(); ++i) {
      const double x = i - 0.4 + 0.4 * (j + 0.5);  // bar centre
      for (double v = 0; v <= bars[j].values[i]; v += 0.01) {
        EXPECT_FALSE(Inside(f.legend_box, Round(f.PxX(x)), Round(f.PxY(v)))) << i << "," << j;
      }
    }
  }
}

TEST(LinePlotTest, PointMarkersAreDrawnUnderLines) {
  Axes axes;
  Series measured = Diagonal(-1), model = Diagonal(-1);
  measured.label = "measured";
  measured.points = true;
  model.label = "model";
  const PlotFrame f = LinePlotFrame(axes, {model, measured});  // the line comes first in the list
  const Image image = LinePlot(axes, {model, measured});
  for (int i = 1; i < 10; ++i) {
    const int col = Round(f.PxX(i)), row = Round(f.PxY(i));
    bool line = false;
    for (int r = row - 1; r <= row + 1; ++r) line = line || IsColour(image, col, r, model.colour);
    EXPECT_TRUE(line) << "the model line is visible at x = " << i;
  }
}

TEST(LinePlotTest, FixedYRangeClipsOutlyingData) {
  Axes axes;
  axes.y_min = -1;
  axes.y_max = 3;
  Series s;
  s.label = "ratio";
  s.x = {0, 1, 2, 3, 4};
  s.y = {-330, 30, 1.5, 1.0, 1.0};
  const PlotFrame f = LinePlotFrame(axes, {s});
  EXPECT_DOUBLE_EQ(f.y_lo, -1);
  EXPECT_DOUBLE_EQ(f.y_hi, 3);
  for (double t : f.y_ticks) {
    EXPECT_GE(t, -1);
    EXPECT_LE(t, 3);
  }
  const Image image = LinePlot(axes, {s});
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      if (!IsColour(image, x, y, s.colour)) continue;
      EXPECT_TRUE(x >= f.left && x <= f.right && y >= f.top && y <= f.bottom) << x << "," << y;
    }
  }
  EXPECT_TRUE(IsColour(image, Round(f.PxX(3.5)), Round(f.PxY(1.0)), s.colour));
  axes.y_max = kNaN;
  EXPECT_THROW(LinePlotFrame(axes, {s}), std::invalid_argument);
  axes.y_max = -2;
  EXPECT_THROW(LinePlotFrame(axes, {s}), std::invalid_argument);
}

TEST(GroupedBoxPlotTest, CategoryNamesOnTicksAndOneBoxPerSeries) {
  Axes axes;
  axes.width_px = 1000;
  const std::vector<std::string> joints = {"shoulder_elv_plane", "shoulder_elevation",
                                           "elbow_flexion"};
  const std::vector<BoxSeries> methods = {
      {"parametric",
       {{0.10, 0.12, 0.13, 0.15}, {0.03, 0.04, 0.05}, {0.1, 0.12, 0.2}},
       PaletteColour(0)},
      {"gp", {{0.02, 0.03, 0.04}, {0.01, 0.013, 0.02}, {0.02, 0.03, 0.04}}, PaletteColour(1)}};
  const PlotFrame f = GroupedBoxPlotFrame(axes, joints, methods);
  const Image image = GroupedBoxPlot(axes, joints, methods);
  ASSERT_EQ(f.x_ticks.size(), joints.size());
  const Rgba ink{0.10f, 0.10f, 0.12f, 1};
  for (std::size_t i = 0; i < joints.size(); ++i) {
    // The tick label is the joint's name: the same pixels as the name drawn alone there.
    const int tw = TextWidthPx(joints[i], 1);
    const int x0 = Round(f.PxX(static_cast<double>(i))) - tw / 2, y0 = f.bottom + 1 + 6;
    Image alone = MakeImage(image.width, image.height, Rgba{1, 1, 1, 1});
    DrawText(&alone, x0, y0, joints[i], 1, ink);
    int ink_pixels = 0;
    for (int y = y0; y < y0 + 7; ++y) {
      for (int x = x0; x < x0 + tw; ++x) {
        EXPECT_EQ(IsColour(alone, x, y, ink), IsColour(image, x, y, ink)) << joints[i];
        ink_pixels += IsColour(alone, x, y, ink) ? 1 : 0;
      }
    }
    EXPECT_GT(ink_pixels, 20) << joints[i];
    // Box j of category i is centred at x = i − 0.4 + 0.4·(j + 0.5), in the series colour.
    for (std::size_t j = 0; j < methods.size(); ++j) {
      const BoxStats b = ComputeBoxStats(methods[j].samples[i]);
      const int col = Round(f.PxX(i - 0.4 + 0.4 * (j + 0.5)));
      const int row = Round(f.PxY(b.q3));
      bool hit = false;
      for (int r = row - 1; r <= row + 1; ++r)
        hit = hit || IsColour(image, col, r, methods[j].colour);
      EXPECT_TRUE(hit) << joints[i] << " " << methods[j].label;
      EXPECT_FALSE(Inside(f.legend_box, col, row));
    }
  }
  EXPECT_FALSE(f.legend_box.empty());
  EXPECT_THROW(GroupedBoxPlot(axes, {"one"}, methods), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::render
