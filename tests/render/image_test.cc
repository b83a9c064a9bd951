#include "render/image.h"

#include <gtest/gtest.h>

namespace fesim::render {
namespace {

constexpr Rgba kWhite{1, 1, 1, 1};
constexpr Rgba kBlack{0, 0, 0, 1};

int CountNonWhite(const Image& image, int x0, int y0, int x1, int y1) {
  int n = 0;
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) {
      const std::uint8_t* p = image.At(x, y);
      if (p[0] != 255 || p[1] != 255 || p[2] != 255) ++n;
    }
  }
  return n;
}

TEST(RenderImageTest, MakeImageFillsEveryPixel) {
  const Image image = MakeImage(4, 3, Rgba{1.0f, 0.5f, 0.0f, 1.0f});
  ASSERT_EQ(image.rgb.size(), 4u * 3u * 3u);
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 4; ++x) {
      EXPECT_EQ(image.At(x, y)[0], 255);
      EXPECT_EQ(image.At(x, y)[1], 128);
      EXPECT_EQ(image.At(x, y)[2], 0);
    }
  }
}

TEST(RenderImageTest, FillRectBlendsAndClips) {
  Image image = MakeImage(10, 10, kWhite);
  FillRect(&image, 8, 8, 5, 5, Rgba{0, 0, 0, 0.5f});  // partly outside
  EXPECT_EQ(image.At(9, 9)[0], 127);                  // (0·128 + 255·127 + 127) / 255
  EXPECT_EQ(image.At(7, 7)[0], 255);
  FillRect(&image, -5, -5, 3, 3, kBlack);  // fully outside: no effect, no crash
  EXPECT_EQ(CountNonWhite(image, 0, 0, 10, 10), 4);
}

TEST(RenderImageTest, TextStaysInsideItsBox) {
  Image image = MakeImage(140, 40, kWhite);
  const std::string text = "t = 1.5 s";
  DrawText(&image, 10, 10, text, 2, kBlack);
  const int w = TextWidthPx(text, 2);
  EXPECT_EQ(w, (9 * kGlyphAdvance - 1) * 2);
  EXPECT_GT(CountNonWhite(image, 10, 10, 10 + w, 24), 0);
  EXPECT_EQ(CountNonWhite(image, 0, 0, 140, 40), CountNonWhite(image, 10, 10, 10 + w, 24));
}

TEST(RenderImageTest, DegreeAndMicroHaveGlyphsUnknownCharactersDrawAsQuestionMark) {
  const auto draw = [](const std::string& s) {
    Image image = MakeImage(12, 12, kWhite);
    DrawText(&image, 0, 0, s, 1, kBlack);
    return image.rgb;
  };
  EXPECT_EQ(draw("\xE2\x82\xAC"), draw("?"));  // '€' has no glyph
  EXPECT_NE(draw("°"), draw("?"));
  EXPECT_NE(draw("µ"), draw("?"));
  EXPECT_NE(draw("°"), draw("µ"));
  EXPECT_EQ(TextWidthPx("°", 1), TextWidthPx("a", 1));  // one glyph, not two bytes
}

TEST(RenderImageTest, OverlayDrawsTimeBarsAndAnglesOnlyWhenVisible) {
  Overlay overlay;
  overlay.channels = {{"ch1", 300}, {"ch2", 0}};
  overlay.joint_angles = {{"elbow_flexion", 45}};
  Image image = MakeImage(640, 360, kWhite);
  DrawOverlay(&image, overlay, 1.25);
  EXPECT_GT(CountNonWhite(image, 0, 0, 200, 60), 0);    // left panel: time and bars
  EXPECT_GT(CountNonWhite(image, 440, 0, 640, 20), 0);  // right panel: angle
  EXPECT_EQ(CountNonWhite(image, 0, 200, 640, 360), 0);

  overlay.visible = false;
  Image hidden = MakeImage(640, 360, kWhite);
  DrawOverlay(&hidden, overlay, 1.25);
  EXPECT_EQ(CountNonWhite(hidden, 0, 0, 640, 360), 0);
}

}  // namespace
}  // namespace fesim::render
