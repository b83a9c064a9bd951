#include "diagnosis/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace fesim::diagnosis {
namespace {

constexpr render::Rgba kWhite{1, 1, 1, 1}, kAxis{0.2f, 0.2f, 0.2f, 1}, kText{0, 0, 0, 1};
constexpr int kLeft = 70, kRight = 10, kTop = 18, kBottom = 28;

std::string Tick(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

void Line(render::Image* im, int x0, int y0, int x1, int y1, render::Rgba c, int clip_top,
          int clip_bottom) {
  const int dx = std::abs(x1 - x0), dy = -std::abs(y1 - y0);
  const int sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
  int err = dx + dy;
  for (int guard = 0; guard < 100000; ++guard) {
    if (y0 >= clip_top && y0 < clip_bottom) render::FillRect(im, x0, y0, 1, 1, c);
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

}  // namespace

render::Image LinePlots(const std::vector<PlotPanel>& panels, int width, int panel_height) {
  render::Image im =
      render::MakeImage(width, panel_height * std::max<int>(1, panels.size()), kWhite);
  for (std::size_t p = 0; p < panels.size(); ++p) {
    const PlotPanel& panel = panels[p];
    const int top = static_cast<int>(p) * panel_height;
    const int x0 = kLeft, x1 = width - kRight, y0 = top + kTop, y1 = top + panel_height - kBottom;
    double xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
    for (const auto& s : panel.series) {
      for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
        if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
        xmin = std::min(xmin, s.x[i]);
        xmax = std::max(xmax, s.x[i]);
        ymin = std::min(ymin, s.y[i]);
        ymax = std::max(ymax, s.y[i]);
      }
    }
    if (!(xmax > xmin)) xmax = xmin + 1.0;
    if (!(ymax > ymin)) ymax = ymin + 1.0;
    if (!std::isfinite(xmin)) xmin = 0.0, xmax = 1.0;
    if (!std::isfinite(ymin)) ymin = 0.0, ymax = 1.0;
    const double pad = 0.05 * (ymax - ymin);
    ymin -= pad;
    ymax += pad;
    render::FillRect(&im, x0, y1, x1 - x0, 1, kAxis);
    render::FillRect(&im, x0, y0, 1, y1 - y0, kAxis);
    render::DrawText(&im, x0, top + 4, panel.title, 1, kText);
    render::DrawText(&im, 2, y0, Tick(ymax), 1, kText);
    render::DrawText(&im, 2, y1 - 8, Tick(ymin), 1, kText);
    render::DrawText(&im, 2, (y0 + y1) / 2, panel.y_label, 1, kText);
    render::DrawText(&im, x0, y1 + 4, Tick(xmin), 1, kText);
    render::DrawText(&im, x1 - render::TextWidthPx(Tick(xmax), 1), y1 + 4, Tick(xmax), 1, kText);
    render::DrawText(&im, (x0 + x1) / 2 - render::TextWidthPx(panel.x_label, 1) / 2, y1 + 14,
                     panel.x_label, 1, kText);
    if (ymin < 0.0 && ymax > 0.0) {
      const int yz = y1 - static_cast<int>((0.0 - ymin) / (ymax - ymin) * (y1 - y0));
      render::FillRect(&im, x0, yz, x1 - x0, 1, {0.8f, 0.8f, 0.8f, 1});
    }
    int legend_x = x1 - 10;
    for (auto it = panel.series.rbegin(); it != panel.series.rend(); ++it) {
      legend_x -= render::TextWidthPx(it->label, 1) + 16;
      render::FillRect(&im, legend_x, top + 6, 10, 3, it->colour);
      render::DrawText(&im, legend_x + 13, top + 4, it->label, 1, kText);
    }
    for (const auto& s : panel.series) {
      bool have = false;
      int px = 0, py = 0;
      for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
        if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
          have = false;
          continue;
        }
        const int qx = x0 + static_cast<int>((s.x[i] - xmin) / (xmax - xmin) * (x1 - x0));
        const int qy = y1 - static_cast<int>((s.y[i] - ymin) / (ymax - ymin) * (y1 - y0));
        if (have) Line(&im, px, py, qx, qy, s.colour, y0, y1 + 1);
        px = qx;
        py = qy;
        have = true;
      }
    }
  }
  return im;
}

}  // namespace fesim::diagnosis
