// A small line-plot rasteriser for the diagnosis report's PNG figures, on render/'s Image,
// FillRect and 5×7 font (render/image.h). Deterministic integer drawing, no anti-aliasing.
#pragma once

#include <string>
#include <vector>

#include "render/image.h"

namespace fesim::diagnosis {

struct PlotSeries {
  std::string label;
  std::vector<double> x, y;  ///< same length; non-finite points break the line.
  render::Rgba colour{0.1f, 0.3f, 0.8f, 1.0f};
};

struct PlotPanel {
  std::string title, x_label, y_label;
  std::vector<PlotSeries> series;
};

/// Panels stacked vertically in one image of width × (panel_height · panels) pixels; each panel
/// gets its own axis ranges (from the finite data, padded 5 %), ticks at both ends, a legend.
render::Image LinePlots(const std::vector<PlotPanel>& panels, int width, int panel_height);

}  // namespace fesim::diagnosis
