#include "diagnosis/plot.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fesim::diagnosis {
namespace {

int CountColour(const render::Image& im, int r, int g, int b) {
  int n = 0;
  for (int y = 0; y < im.height; ++y) {
    for (int x = 0; x < im.width; ++x) {
      const auto* p = im.At(x, y);
      n += (p[0] == r && p[1] == g && p[2] == b) ? 1 : 0;
    }
  }
  return n;
}

TEST(Plot, DrawsEachSeriesInItsColourInsideItsPanel) {
  PlotSeries a;
  a.label = "a";
  a.colour = {1, 0, 0, 1};
  for (int i = 0; i <= 100; ++i) {
    a.x.push_back(i);
    a.y.push_back(i * i);
  }
  PlotSeries b = a;
  b.label = "b";
  b.colour = {0, 0, 1, 1};
  b.y[50] = NAN;  // a gap
  const render::Image im =
      LinePlots({{"first", "x", "y", {a}}, {"second", "x", "y", {b}}}, 400, 150);
  ASSERT_EQ(im.width, 400);
  ASSERT_EQ(im.height, 300);
  // A monotone curve across ≈ 320 px of plot width draws at least that many pixels.
  EXPECT_GT(CountColour(im, 255, 0, 0), 320);
  EXPECT_GT(CountColour(im, 0, 0, 255), 300);
  // Red only in the top panel.
  for (int y = 150; y < 300; ++y) {
    for (int x = 0; x < 400; ++x) {
      const auto* p = im.At(x, y);
      ASSERT_FALSE(p[0] == 255 && p[1] == 0 && p[2] == 0) << x << "," << y;
    }
  }
}

}  // namespace
}  // namespace fesim::diagnosis
