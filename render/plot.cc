#include "render/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <stdexcept>

#include "render/renderer.h"
#include "render/video.h"

namespace fesim::render {
namespace {

constexpr double kMargin = 0.05;                    ///< autoscale margin, fraction of the range.
constexpr Rgba kWhite{1.0f, 1.0f, 1.0f, 1.0f};      ///< background.
constexpr Rgba kInk{0.10f, 0.10f, 0.12f, 1.0f};     ///< frame, ticks, text, median lines.
constexpr Rgba kGrid{0.88f, 0.88f, 0.88f, 1.0f};    ///< grid lines.
constexpr Rgba kLegendBg{1.0f, 1.0f, 1.0f, 0.85f};  ///< legend box fill.
constexpr int kMinWidthPx = 160;
constexpr int kMinHeightPx = 120;

/// Font pixel size in image pixels: 1 up to 1279×719, 2 at 1280×720, …
int TextScale(const Axes& axes) {
  return std::max(1, std::min(axes.width_px / 640, axes.height_px / 360));
}

void CheckSize(const Axes& axes) {
  if (axes.width_px < kMinWidthPx || axes.width_px > kMaxImageSidePx ||
      axes.height_px < kMinHeightPx || axes.height_px > kMaxImageSidePx) {
    throw std::invalid_argument("plot size " + std::to_string(axes.width_px) + "x" +
                                std::to_string(axes.height_px) + " px is outside " +
                                std::to_string(kMinWidthPx) + "x" + std::to_string(kMinHeightPx) +
                                " to " + std::to_string(kMaxImageSidePx) + " per side");
  }
}

/// Whether y can be drawn on the y axis.
bool Drawable(double y, bool log_y) { return std::isfinite(y) && (!log_y || y > 0); }

/// Running [lo, hi] of values; empty while lo > hi.
struct Extent {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void Add(double v) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool empty() const { return lo > hi; }
};

/// Display range of an extent: margins (fractions of the range, in log10 for log axes) below and
/// above; a zero-width range is widened around its value; no data gives [0, 1] ([1, 10] on log
/// axes).
Extent PadRange(Extent e, bool log_y, double margin_lo = kMargin, double margin_hi = kMargin) {
  if (e.empty()) return log_y ? Extent{1, 10} : Extent{0, 1};
  if (log_y) {
    e = Extent{std::log10(e.lo), std::log10(e.hi)};
  }
  if (e.lo == e.hi) {
    const double d = log_y ? 0.5 : (e.lo == 0 ? 1.0 : 0.1 * std::abs(e.lo));
    e = Extent{e.lo - d, e.hi + d};
  } else {
    const double span = e.hi - e.lo;
    e.lo -= margin_lo * span;
    e.hi += margin_hi * span;
  }
  if (log_y) e = Extent{std::pow(10.0, e.lo), std::pow(10.0, e.hi)};
  return e;
}

/// Ticks of a y range: decades on a log axis spanning ≥ 2 of them, else NiceTicks.
std::vector<double> YTicks(double lo, double hi, bool log_y, int max_ticks) {
  if (!log_y) return NiceTicks(lo, hi, max_ticks);
  std::vector<double> decades;
  for (double e : NiceTicks(std::log10(lo), std::log10(hi), max_ticks)) {
    if (std::abs(e - std::round(e)) < 1e-9) decades.push_back(std::pow(10.0, std::round(e)));
  }
  if (decades.size() >= 2) return decades;
  std::vector<double> linear;
  for (double v : NiceTicks(lo, hi, max_ticks)) {
    if (v > 0) linear.push_back(v);
  }
  return linear;
}

/// snprintf of one number with a precision (format has one "%.*" conversion).
std::string FormatNumber(const char* format, int precision, double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, precision, v);
  return buffer;
}

/// Tick labels with as many decimals as the tick step needs; %g for very large or small values
/// and on log axes.
std::vector<std::string> TickLabels(const std::vector<double>& ticks, bool log_y) {
  const double step = ticks.size() >= 2 ? ticks[1] - ticks[0] : 1.0;
  const int decimals = std::clamp(static_cast<int>(std::ceil(-std::log10(step) - 1e-9)), 0, 10);
  std::vector<std::string> labels;
  for (double v : ticks) {
    const double a = std::abs(v);
    if (v == 0) {
      labels.push_back("0");
    } else if (log_y || a >= 1e6 || a < 1e-4) {
      labels.push_back(FormatNumber("%.*g", 6, v));
    } else {
      labels.push_back(FormatNumber("%.*f", decimals, v));
    }
  }
  return labels;
}

/// Axes::y_min/y_max when set (checked), else the autoscaled range y.
Extent FixedOrAuto(const Axes& axes, Extent y) {
  const bool lo = std::isfinite(axes.y_min), hi = std::isfinite(axes.y_max);
  if (!lo && !hi) return y;
  if (lo != hi || !(axes.y_min < axes.y_max) || (axes.log_y && !(axes.y_min > 0))) {
    throw std::invalid_argument("plot y range [" + std::to_string(axes.y_min) + ", " +
                                std::to_string(axes.y_max) +
                                "] needs both bounds finite, min < max (> 0 on a log axis)");
  }
  return Extent{axes.y_min, axes.y_max};
}

/// Wraps the title to the image width (scale one larger than the text) and sets its pixel box.
void LayOutTitle(const Axes& axes, int pad, PlotFrame* f) {
  const int ts = TextScale(axes) + 1;
  f->title_scale = ts;
  f->title_lines = WrapText(axes.title, axes.width_px - 2 * pad, ts);
  if (f->title_lines.empty()) return;
  int w = 0;
  for (const std::string& l : f->title_lines) w = std::max(w, TextWidthPx(l, ts));
  const int n = static_cast<int>(f->title_lines.size());
  f->title_box = PixelBox{(axes.width_px - w) / 2, pad, w, (n - 1) * kLineHeight * ts + 7 * ts};
}

/// Lays out the plot area around the text and picks ticks. categories: number of categories on a
/// categorical x axis (ticks at 0 … n − 1), or −1 for a numeric x axis. reserve_right_px: width
/// kept free right of the plot area (for a legend placed outside).
PlotFrame MakeFrame(const Axes& axes, Extent x, Extent y, int categories,
                    int reserve_right_px = 0) {
  CheckSize(axes);
  y = FixedOrAuto(axes, y);
  const int s = TextScale(axes);
  const int line = kLineHeight * s;
  const int pad = 6 * s;
  PlotFrame f;
  f.log_y = axes.log_y;
  f.x_lo = x.lo;
  f.x_hi = x.hi;
  f.y_lo = y.lo;
  f.y_hi = y.hi;
  LayOutTitle(axes, pad, &f);
  f.top = pad + (f.title_box.empty() ? 0 : f.title_box.h + pad) + (axes.y_label.empty() ? 0 : line);
  f.top += pad;
  f.bottom = axes.height_px - 1 - pad - (axes.x_label.empty() ? 0 : line) - line - 4 * s;
  const int max_y_ticks = std::clamp((f.bottom - f.top) / (40 * s) + 1, 2, 12);
  f.y_ticks = YTicks(y.lo, y.hi, axes.log_y, max_y_ticks);
  int label_w = 0;
  for (const std::string& t : TickLabels(f.y_ticks, axes.log_y)) {
    label_w = std::max(label_w, TextWidthPx(t, s));
  }
  f.left = pad + label_w + 4 * s + 2 * s;
  f.right = axes.width_px - 1 - pad - 3 * kGlyphAdvance * s - reserve_right_px;
  if (categories >= 0) {
    for (int i = 0; i < categories; ++i) f.x_ticks.push_back(i);
  } else {
    f.x_ticks = NiceTicks(x.lo, x.hi, std::clamp((f.right - f.left) / (80 * s) + 1, 2, 12));
  }
  return f;
}

/// FillRect clipped to the plot area.
void Fill(Image* image, const PlotFrame& f, int x, int y, int w, int h, Rgba colour) {
  const int x0 = std::max(x, f.left), y0 = std::max(y, f.top);
  const int x1 = std::min(x + w, f.right + 1), y1 = std::min(y + h, f.bottom + 1);
  if (x0 < x1 && y0 < y1) FillRect(image, x0, y0, x1 - x0, y1 - y0, colour);
}

int Px(double v) { return static_cast<int>(std::lround(std::clamp(v, -1e6, 1e6))); }

/// Clips the segment (xa, ya)–(xb, yb) to the plot area widened by 2 px (Liang–Barsky); false
/// when nothing of it is inside. Keeps Bresenham short when a point lies far outside a fixed
/// y range.
bool ClipSegment(const PlotFrame& f, double* xa, double* ya, double* xb, double* yb) {
  const double dx = *xb - *xa, dy = *yb - *ya;
  const double p[4] = {-dx, dx, -dy, dy};
  const double q[4] = {*xa - (f.left - 2), (f.right + 2) - *xa, *ya - (f.top - 2),
                       (f.bottom + 2) - *ya};
  double t0 = 0, t1 = 1;
  for (int k = 0; k < 4; ++k) {
    if (p[k] == 0) {
      if (q[k] < 0) return false;
      continue;
    }
    const double t = q[k] / p[k];
    if (p[k] < 0) {
      t0 = std::max(t0, t);
    } else {
      t1 = std::min(t1, t);
    }
  }
  if (t0 > t1) return false;
  const double x0 = *xa, y0 = *ya;
  *xa = x0 + t0 * dx;
  *ya = y0 + t0 * dy;
  *xb = x0 + t1 * dx;
  *yb = y0 + t1 * dy;
  return true;
}

/// 2 px thick Bresenham line between pixel positions, clipped to the plot area.
void Line(Image* image, const PlotFrame& f, double xa, double ya, double xb, double yb,
          Rgba colour) {
  if (!ClipSegment(f, &xa, &ya, &xb, &yb)) return;
  int x0 = Px(xa), y0 = Px(ya);
  const int x1 = Px(xb), y1 = Px(yb);
  const int dx = std::abs(x1 - x0), dy = -std::abs(y1 - y0);
  const int sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
  int err = dx + dy;
  for (;;) {
    Fill(image, f, x0, y0, 2, 2, colour);
    if (x0 == x1 && y0 == y1) break;
    const int e2 = 2 * err;
    if (e2 >= dy) {
      err += dy;
      x0 += sx;
    }
    if (e2 <= dx) {
      err += dx;
      y0 += sy;
    }
  }
}

/// White background and grid lines (vertical ones only on a numeric x axis).
Image Background(const Axes& axes, const PlotFrame& f, bool x_grid) {
  Image image = MakeImage(axes.width_px, axes.height_px, kWhite);
  for (double t : f.y_ticks) Fill(&image, f, f.left, Px(f.PxY(t)), f.right - f.left + 1, 1, kGrid);
  if (x_grid) {
    for (double t : f.x_ticks) Fill(&image, f, Px(f.PxX(t)), f.top, 1, f.bottom - f.top + 1, kGrid);
  }
  return image;
}

/// Frame, tick marks and labels, axis labels and title. x_labels: one per x tick.
void Decorate(Image* image, const Axes& axes, const PlotFrame& f,
              const std::vector<std::string>& x_labels) {
  const int s = TextScale(axes);
  const int line = kLineHeight * s;
  const int pad = 6 * s;
  const int w = f.right - f.left + 1, h = f.bottom - f.top + 1;
  FillRect(image, f.left, f.top, w, 1, kInk);
  FillRect(image, f.left, f.bottom, w, 1, kInk);
  FillRect(image, f.left, f.top, 1, h, kInk);
  FillRect(image, f.right, f.top, 1, h, kInk);
  const std::vector<std::string> y_labels = TickLabels(f.y_ticks, axes.log_y);
  for (std::size_t i = 0; i < f.y_ticks.size(); ++i) {
    const int row = Px(f.PxY(f.y_ticks[i]));
    FillRect(image, f.left - 4 * s, row, 4 * s, 1, kInk);
    DrawText(image, f.left - 6 * s - TextWidthPx(y_labels[i], s), row - 7 * s / 2, y_labels[i], s,
             kInk);
  }
  const int label_row = f.bottom + 1 + 4 * s + 2 * s;
  for (std::size_t i = 0; i < f.x_ticks.size() && i < x_labels.size(); ++i) {
    const int col = Px(f.PxX(f.x_ticks[i]));
    FillRect(image, col, f.bottom + 1, 1, 4 * s, kInk);
    const int tw = TextWidthPx(x_labels[i], s);
    DrawText(image, std::clamp(col - tw / 2, 0, std::max(0, axes.width_px - tw)), label_row,
             x_labels[i], s, kInk);
  }
  if (!axes.x_label.empty()) {
    const int tw = TextWidthPx(axes.x_label, s);
    DrawText(image, std::max(0, f.left + (w - tw) / 2), label_row + line, axes.x_label, s, kInk);
  }
  if (!axes.y_label.empty()) DrawText(image, pad, f.top - pad - 7 * s, axes.y_label, s, kInk);
  const int ts = f.title_scale;
  for (std::size_t i = 0; i < f.title_lines.size(); ++i) {
    const int tw = TextWidthPx(f.title_lines[i], ts);
    DrawText(image, std::max(0, (axes.width_px - tw) / 2),
             f.title_box.y + static_cast<int>(i) * kLineHeight * ts, f.title_lines[i], ts, kInk);
  }
}

/// Height of a legend box of n entries, pixels.
int LegendHeightPx(const Axes& axes, std::size_t n) {
  const int s = TextScale(axes);
  return 6 * s + static_cast<int>(n) * kLineHeight * s - 3 * s + 6 * s;
}

/// A legend entry: a line (or a square swatch) of a colour and its label.
struct LegendEntry {
  std::string label;
  Rgba colour;
  bool square;
};

/// One square legend entry per series (bars, boxes), in order.
template <typename S>
std::vector<LegendEntry> SquareEntries(const std::vector<S>& series) {
  std::vector<LegendEntry> entries;
  for (const S& s : series) entries.push_back({s.label, s.colour, true});
  return entries;
}

/// Width of the legend box of entries, pixels.
int LegendWidthPx(const Axes& axes, const std::vector<LegendEntry>& entries) {
  const int s = TextScale(axes);
  int text_w = 0;
  for (const LegendEntry& e : entries) text_w = std::max(text_w, TextWidthPx(e.label, s));
  return 6 * s + 16 * s + 6 * s + text_w + 6 * s;
}

/// Whether the data layer (data drawn on white) has a non-white pixel in box widened by margin.
bool HasData(const Image& layer, PixelBox box, int margin) {
  const int x0 = std::max(0, box.x - margin), y0 = std::max(0, box.y - margin);
  const int x1 = std::min(layer.width, box.x + box.w + margin);
  const int y1 = std::min(layer.height, box.y + box.h + margin);
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) {
      const std::uint8_t* p = layer.At(x, y);
      if (p[0] != 255 || p[1] != 255 || p[2] != 255) return true;
    }
  }
  return false;
}

/// Draws a plot's data (no grid, frame or text) into an image in a frame's transform.
using DataPainter = std::function<void(Image*, const PlotFrame&)>;
/// The frame of a plot with reserve_right_px kept free right of the plot area.
using FrameMaker = std::function<PlotFrame(int reserve_right_px)>;

/// The frame with its legend box: the first corner of the plot area (top right, top left,
/// bottom right, bottom left) whose box, with a gap, holds no pixel paint draws there; if every
/// corner holds data, a frame narrowed by the legend's width and the legend right of it, level
/// with the plot area's top. Fewer than 2 entries: no legend.
PlotFrame PlaceLegend(const Axes& axes, const std::vector<LegendEntry>& entries,
                      const FrameMaker& make, const DataPainter& paint) {
  PlotFrame f = make(0);
  if (entries.size() < 2) return f;
  const int pad = 6 * TextScale(axes);
  const int w = LegendWidthPx(axes, entries), h = LegendHeightPx(axes, entries.size());
  Image layer = MakeImage(axes.width_px, axes.height_px, kWhite);
  paint(&layer, f);
  const int xl = f.left + pad, xr = f.right - pad - w;
  const int yt = f.top + pad, yb = f.bottom - pad - h;
  if (xl <= xr && yt <= yb) {
    for (const auto& [x, y] : {std::pair{xr, yt}, {xl, yt}, {xr, yb}, {xl, yb}}) {
      const PixelBox box{x, y, w, h};
      if (!HasData(layer, box, pad / 2)) {
        f.legend_box = box;
        return f;
      }
    }
  }
  f = make(w + pad);
  f.legend_box = PixelBox{f.right + pad, f.top, w, h};
  return f;
}

/// Legend box at f.legend_box (inside or outside the plot area).
void Legend(Image* image, const Axes& axes, const PlotFrame& f,
            const std::vector<LegendEntry>& entries) {
  if (f.legend_box.empty()) return;
  const int s = TextScale(axes);
  const int line = kLineHeight * s;
  const int pad = 6 * s;
  const int swatch = 16 * s;
  const auto [x, y, w, h] = f.legend_box;
  FillRect(image, x, y, w, h, kLegendBg);
  FillRect(image, x, y, w, 1, kInk);
  FillRect(image, x, y + h - 1, w, 1, kInk);
  FillRect(image, x, y, 1, h, kInk);
  FillRect(image, x + w - 1, y, 1, h, kInk);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const int ty = y + pad + static_cast<int>(i) * line;
    if (entries[i].square) {
      FillRect(image, x + pad + swatch / 4, ty, swatch / 2, 7 * s, entries[i].colour);
    } else {
      FillRect(image, x + pad, ty + 3 * s, swatch, 2 * s, entries[i].colour);
    }
    DrawText(image, x + pad + swatch + pad, ty, entries[i].label, s, kInk);
  }
}

/// The lighter tint point markers are drawn in: halfway to white.
Rgba MarkerTint(Rgba c) {
  return Rgba{0.5f + 0.5f * c.r, 0.5f + 0.5f * c.g, 0.5f + 0.5f * c.b, 1.0f};
}

/// Type-7 quantile of sorted values: linear interpolation between order statistics at (n−1)·p.
double Quantile(const std::vector<double>& sorted, double p) {
  const double h = (static_cast<double>(sorted.size()) - 1) * p;
  const std::size_t i = static_cast<std::size_t>(std::floor(h));
  if (i + 1 >= sorted.size()) return sorted.back();
  return sorted[i] + (h - static_cast<double>(i)) * (sorted[i + 1] - sorted[i]);
}

Extent CategoryRange(std::size_t n) { return Extent{-0.5, std::max<double>(0.5, n - 0.5)}; }

/// The series of a line plot: point series first (under the lines, in MarkerTint), then lines.
void DrawLines(Image* image, const PlotFrame& f, const std::vector<Series>& series) {
  for (const bool points : {true, false}) {
    for (const Series& s : series) {
      if (s.points != points) continue;
      bool have_prev = false;
      double px = 0, py = 0;
      for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
        if (!std::isfinite(s.x[i]) || !Drawable(s.y[i], f.log_y)) {
          have_prev = false;
          continue;
        }
        const double cx = f.PxX(s.x[i]), cy = f.PxY(s.y[i]);
        if (s.points) {
          Fill(image, f, Px(cx) - 2, Px(cy) - 2, 4, 4, MarkerTint(s.colour));
        } else if (have_prev) {
          Line(image, f, px, py, cx, cy, s.colour);
        } else {
          Fill(image, f, Px(cx), Px(cy), 2, 2, s.colour);  // a lone point stays visible
        }
        have_prev = true;
        px = cx;
        py = cy;
      }
    }
  }
}

/// Legend entries of line-plot series, in their order.
std::vector<LegendEntry> LineLegend(const std::vector<Series>& series) {
  std::vector<LegendEntry> entries;
  for (const Series& s : series) {
    entries.push_back({s.label, s.points ? MarkerTint(s.colour) : s.colour, s.points});
  }
  return entries;
}

/// One Tukey box (statistics b) centred at pixel column cx, half its width wide each side.
void DrawBox(Image* image, const PlotFrame& f, const BoxStats& b, int cx, int half, Rgba c) {
  if (b.count == 0) return;
  const int r1 = Px(f.PxY(b.q1)), r3 = Px(f.PxY(b.q3)), rm = Px(f.PxY(b.median));
  const int rlo = Px(f.PxY(b.whisker_lo)), rhi = Px(f.PxY(b.whisker_hi));
  Fill(image, f, cx, rhi, 2, r3 - rhi, c);  // whiskers
  Fill(image, f, cx, r1, 2, rlo - r1, c);
  Fill(image, f, cx - half / 2, rhi, half + 2, 2, c);  // caps
  Fill(image, f, cx - half / 2, rlo - 1, half + 2, 2, c);
  Fill(image, f, cx - half, r3, 2 * half + 2, r1 - r3 + 1, kWhite);
  Fill(image, f, cx - half, r3, 2 * half + 2, r1 - r3 + 1, Rgba{c.r, c.g, c.b, 0.3f});
  Fill(image, f, cx - half, r3, 2 * half + 2, 2, c);  // outline
  Fill(image, f, cx - half, r1 - 1, 2 * half + 2, 2, c);
  Fill(image, f, cx - half, r3, 2, r1 - r3 + 1, c);
  Fill(image, f, cx + half, r3, 2, r1 - r3 + 1, c);
  Fill(image, f, cx - half, rm - 1, 2 * half + 2, 3, kInk);  // median
  for (double v : b.outliers) Fill(image, f, cx - 1, Px(f.PxY(v)) - 2, 4, 4, c);
}

/// Box statistics of the values of a sample drawable on the y axis.
BoxStats DrawableBoxStats(const std::vector<double>& sample, bool log_y) {
  std::vector<double> usable;
  for (double v : sample) {
    if (Drawable(v, log_y)) usable.push_back(v);
  }
  return ComputeBoxStats(usable);
}

/// The boxes of a grouped box plot: category i spans [i − 0.4, i + 0.4], one box per series.
void DrawGroupedBoxes(Image* image, const PlotFrame& f, const std::vector<BoxSeries>& series) {
  const double slot = 0.8 / std::max<std::size_t>(1, series.size());
  const int half = std::max(3, Px(0.35 * slot * (f.PxX(1) - f.PxX(0))));
  for (std::size_t j = 0; j < series.size(); ++j) {
    for (std::size_t i = 0; i < series[j].samples.size(); ++i) {
      const double x = static_cast<double>(i) - 0.4 + (static_cast<double>(j) + 0.5) * slot;
      DrawBox(image, f, DrawableBoxStats(series[j].samples[i], f.log_y), Px(f.PxX(x)), half,
              series[j].colour);
    }
  }
}

/// Grouped bars: for each category one bar per series side by side, from 0 (the bottom of a log
/// axis) to the value.
void DrawBars(Image* image, const PlotFrame& f, const std::vector<BarSeries>& series) {
  const double group = 0.8, bar = series.empty() ? group : group / series.size();
  const int base = f.log_y ? f.bottom : Px(f.PxY(0.0));
  for (std::size_t j = 0; j < series.size(); ++j) {
    for (std::size_t i = 0; i < series[j].values.size(); ++i) {
      const double v = series[j].values[i];
      if (!Drawable(v, f.log_y)) continue;
      const double a = static_cast<double>(i) - group / 2 + static_cast<double>(j) * bar;
      const int x0 = Px(f.PxX(a)), x1 = Px(f.PxX(a + bar)) - 1;  // 1 px gap between bars
      const int top = Px(f.PxY(v));
      Fill(image, f, x0, std::min(top, base), std::max(1, x1 - x0), std::abs(base - top) + 1,
           series[j].colour);
    }
  }
}

}  // namespace

Rgba PaletteColour(int k) {
  static constexpr std::uint8_t kOkabeIto[8][3] = {{0, 114, 178},  {213, 94, 0},   {0, 158, 115},
                                                   {230, 159, 0},  {86, 180, 233}, {204, 121, 167},
                                                   {240, 228, 66}, {0, 0, 0}};
  const std::uint8_t* c = kOkabeIto[((k % 8) + 8) % 8];
  return Rgba{c[0] / 255.0f, c[1] / 255.0f, c[2] / 255.0f, 1.0f};
}

std::vector<double> NiceTicks(double lo, double hi, int max_ticks) {
  if (!std::isfinite(lo) || !std::isfinite(hi)) return {};
  if (lo > hi) std::swap(lo, hi);
  if (lo == hi) return {lo};
  max_ticks = std::clamp(max_ticks, 2, 1000);
  const double raw = (hi - lo) / (max_ticks - 1);
  int e = static_cast<int>(std::floor(std::log10(raw)));
  const double f = raw / std::pow(10.0, e);
  int m = 10;
  for (int c : {1, 2, 5}) {
    if (c >= f * (1 - 1e-9)) {
      m = c;
      break;
    }
  }
  if (m == 10) {
    m = 1;
    ++e;
  }
  // value(k) = k·m·10^e, computed so that it is the double nearest the exact decimal.
  const double scale = std::pow(10.0, std::abs(e));
  const auto value = [&](long long k) {
    const double km = static_cast<double>(k * m);
    return e >= 0 ? km * scale : km / scale;
  };
  const double step = e >= 0 ? m * scale : m / scale;
  const double k_lo = std::ceil(lo / step - 1e-9), k_hi = std::floor(hi / step + 1e-9);
  if (std::abs(k_lo) > 1e15 || std::abs(k_hi) > 1e15) return {lo, hi};
  std::vector<double> ticks;
  for (auto k = static_cast<long long>(k_lo); k <= static_cast<long long>(k_hi); ++k) {
    ticks.push_back(value(k));
  }
  return ticks;
}

std::vector<std::string> WrapText(const std::string& text, int max_width_px, int scale) {
  std::vector<std::string> lines;
  std::string line;
  std::size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && text[i] == ' ') ++i;
    std::size_t j = text.find(' ', i);
    if (j == std::string::npos) j = text.size();
    std::string word = text.substr(i, j - i);
    i = j;
    if (word.empty()) break;
    if (!line.empty() && TextWidthPx(line + " " + word, scale) <= max_width_px) {
      line += " " + word;
      continue;
    }
    if (!line.empty()) lines.push_back(line);
    line.clear();
    while (TextWidthPx(word, scale) > max_width_px && word.size() > 1) {  // an over-long word
      std::size_t cut = word.size() - 1;  // the longest prefix that fits, at a UTF-8 boundary
      while (cut > 1 && (TextWidthPx(word.substr(0, cut), scale) > max_width_px ||
                         (static_cast<unsigned char>(word[cut]) & 0xC0) == 0x80)) {
        --cut;
      }
      lines.push_back(word.substr(0, cut));
      word = word.substr(cut);
    }
    line = word;
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

double PlotFrame::PxX(double x) const { return left + (x - x_lo) / (x_hi - x_lo) * (right - left); }

double PlotFrame::PxY(double y) const {
  if (log_y) {
    if (!(y > 0)) return std::numeric_limits<double>::quiet_NaN();
    return bottom - (std::log10(y) - std::log10(y_lo)) / (std::log10(y_hi) - std::log10(y_lo)) *
                        (bottom - top);
  }
  return bottom - (y - y_lo) / (y_hi - y_lo) * (bottom - top);
}

PlotFrame LinePlotFrame(const Axes& axes, const std::vector<Series>& series) {
  Extent x, y;
  for (const Series& s : series) {
    if (s.x.size() != s.y.size()) {
      throw std::invalid_argument("plot series '" + s.label + "' has " +
                                  std::to_string(s.x.size()) + " x values but " +
                                  std::to_string(s.y.size()) + " y values");
    }
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (std::isfinite(s.x[i]) && Drawable(s.y[i], axes.log_y)) {
        x.Add(s.x[i]);
        y.Add(s.y[i]);
      }
    }
  }
  const Extent xr = PadRange(x, false), yr = PadRange(y, axes.log_y);
  return PlaceLegend(
      axes, LineLegend(series), [&](int reserve) { return MakeFrame(axes, xr, yr, -1, reserve); },
      [&](Image* image, const PlotFrame& f) { DrawLines(image, f, series); });
}

Image LinePlot(const Axes& axes, const std::vector<Series>& series) {
  const PlotFrame f = LinePlotFrame(axes, series);
  Image image = Background(axes, f, true);
  DrawLines(&image, f, series);
  Decorate(&image, axes, f, TickLabels(f.x_ticks, false));
  Legend(&image, axes, f, LineLegend(series));
  return image;
}

BoxStats ComputeBoxStats(std::vector<double> values) {
  values.erase(
      std::remove_if(values.begin(), values.end(), [](double v) { return !std::isfinite(v); }),
      values.end());
  BoxStats b;
  b.count = values.size();
  if (values.empty()) {
    b.q1 = b.median = b.q3 = b.whisker_lo = b.whisker_hi = std::nan("");
    return b;
  }
  std::sort(values.begin(), values.end());
  b.q1 = Quantile(values, 0.25);
  b.median = Quantile(values, 0.5);
  b.q3 = Quantile(values, 0.75);
  const double fence_lo = b.q1 - 1.5 * (b.q3 - b.q1), fence_hi = b.q3 + 1.5 * (b.q3 - b.q1);
  b.whisker_lo = b.q1;
  b.whisker_hi = b.q3;
  for (double v : values) {
    if (v < fence_lo || v > fence_hi) {
      b.outliers.push_back(v);
    } else {
      b.whisker_lo = std::min(b.whisker_lo, v);
      b.whisker_hi = std::max(b.whisker_hi, v);
    }
  }
  return b;
}

PlotFrame BoxPlotFrame(const Axes& axes, const std::vector<std::vector<double>>& samples) {
  Extent y;
  for (const std::vector<double>& sample : samples) {
    for (double v : sample) {
      if (Drawable(v, axes.log_y)) y.Add(v);
    }
  }
  return MakeFrame(axes, CategoryRange(samples.size()), PadRange(y, axes.log_y),
                   static_cast<int>(samples.size()));
}

Image BoxPlot(const Axes& axes, const std::vector<std::string>& group_labels,
              const std::vector<std::vector<double>>& samples, const std::vector<Rgba>& colours) {
  if (group_labels.size() != samples.size() ||
      (!colours.empty() && colours.size() != samples.size())) {
    throw std::invalid_argument("box plot: " + std::to_string(samples.size()) + " samples, " +
                                std::to_string(group_labels.size()) + " labels and " +
                                std::to_string(colours.size()) + " colours do not match");
  }
  const PlotFrame f = BoxPlotFrame(axes, samples);
  Image image = Background(axes, f, false);
  const int half = std::max(3, Px(0.25 * (f.PxX(1) - f.PxX(0))));
  for (std::size_t i = 0; i < samples.size(); ++i) {
    DrawBox(&image, f, DrawableBoxStats(samples[i], axes.log_y), Px(f.PxX(static_cast<double>(i))),
            half, colours.empty() ? PaletteColour(0) : colours[i]);
  }
  Decorate(&image, axes, f, group_labels);
  return image;
}

PlotFrame GroupedBoxPlotFrame(const Axes& axes, const std::vector<std::string>& categories,
                              const std::vector<BoxSeries>& series) {
  Extent y;
  for (const BoxSeries& s : series) {
    if (s.samples.size() != categories.size()) {
      throw std::invalid_argument("box series '" + s.label + "' has " +
                                  std::to_string(s.samples.size()) + " samples for " +
                                  std::to_string(categories.size()) + " categories");
    }
    for (const std::vector<double>& sample : s.samples) {
      for (double v : sample) {
        if (Drawable(v, axes.log_y)) y.Add(v);
      }
    }
  }
  const int n = static_cast<int>(categories.size());
  const Extent yr = PadRange(y, axes.log_y);
  const std::vector<LegendEntry> entries = SquareEntries(series);
  return PlaceLegend(
      axes, entries, [&](int reserve) { return MakeFrame(axes, CategoryRange(n), yr, n, reserve); },
      [&](Image* image, const PlotFrame& f) { DrawGroupedBoxes(image, f, series); });
}

Image GroupedBoxPlot(const Axes& axes, const std::vector<std::string>& categories,
                     const std::vector<BoxSeries>& series) {
  const PlotFrame f = GroupedBoxPlotFrame(axes, categories, series);
  Image image = Background(axes, f, false);
  DrawGroupedBoxes(&image, f, series);
  Decorate(&image, axes, f, categories);
  const std::vector<LegendEntry> entries = SquareEntries(series);
  Legend(&image, axes, f, entries);
  return image;
}

PlotFrame BarChartFrame(const Axes& axes, const std::vector<std::string>& categories,
                        const std::vector<BarSeries>& series) {
  Extent y;
  if (!axes.log_y) y.Add(0.0);
  for (const BarSeries& s : series) {
    if (s.values.size() != categories.size()) {
      throw std::invalid_argument("bar series '" + s.label + "' has " +
                                  std::to_string(s.values.size()) + " values for " +
                                  std::to_string(categories.size()) + " categories");
    }
    for (double v : s.values) {
      if (Drawable(v, axes.log_y)) y.Add(v);
    }
  }
  // No margin at the bars' baseline 0; above the bars, room for the legend box when there is one.
  const int n = static_cast<int>(categories.size());
  double margin_hi = !axes.log_y && y.hi == 0 ? 0.0 : kMargin;
  if (series.size() >= 2 && margin_hi > 0) {
    const PlotFrame probe = MakeFrame(axes, CategoryRange(n), PadRange(y, axes.log_y), n);
    const double legend = (LegendHeightPx(axes, series.size()) + 2 * 6 * TextScale(axes)) /
                          static_cast<double>(probe.bottom - probe.top);
    if (legend < 0.5) margin_hi = std::max(margin_hi, legend / (1 - legend));
  }
  const double margin_lo = !axes.log_y && y.lo == 0 ? 0.0 : kMargin;
  const Extent yr = PadRange(y, axes.log_y, margin_lo, margin_hi);
  const std::vector<LegendEntry> entries = SquareEntries(series);
  return PlaceLegend(
      axes, entries, [&](int reserve) { return MakeFrame(axes, CategoryRange(n), yr, n, reserve); },
      [&](Image* image, const PlotFrame& f) { DrawBars(image, f, series); });
}

Image BarChart(const Axes& axes, const std::vector<std::string>& categories,
               const std::vector<BarSeries>& series) {
  const PlotFrame f = BarChartFrame(axes, categories, series);
  Image image = Background(axes, f, false);
  DrawBars(&image, f, series);
  if (!axes.log_y) Fill(&image, f, f.left, Px(f.PxY(0.0)), f.right - f.left + 1, 1, kInk);
  Decorate(&image, axes, f, categories);
  const std::vector<LegendEntry> entries = SquareEntries(series);
  Legend(&image, axes, f, entries);
  return image;
}

void WriteLinePlotPng(const std::string& path, const Axes& axes,
                      const std::vector<Series>& series) {
  WritePng(path, LinePlot(axes, series));
}

void WriteBoxPlotPng(const std::string& path, const Axes& axes,
                     const std::vector<std::string>& group_labels,
                     const std::vector<std::vector<double>>& samples,
                     const std::vector<Rgba>& colours) {
  WritePng(path, BoxPlot(axes, group_labels, samples, colours));
}

void WriteGroupedBoxPlotPng(const std::string& path, const Axes& axes,
                            const std::vector<std::string>& categories,
                            const std::vector<BoxSeries>& series) {
  WritePng(path, GroupedBoxPlot(axes, categories, series));
}

void WriteBarChartPng(const std::string& path, const Axes& axes,
                      const std::vector<std::string>& categories,
                      const std::vector<BarSeries>& series) {
  WritePng(path, BarChart(axes, categories, series));
}

}  // namespace fesim::render
