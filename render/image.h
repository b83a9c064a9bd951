// An RGB image in memory and small 2D drawing helpers (used for the overlay).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "render/scene.h"

namespace fesim::render {

/// 8-bit RGB image, rows top-down, 3 bytes per pixel (r, g, b), no row padding:
/// pixel (x, y) is rgb[3 * (y * width + x) + c], y = 0 the top row.
struct Image {
  int width = 0;   ///< pixels.
  int height = 0;  ///< pixels.
  std::vector<std::uint8_t> rgb;

  /// Pointer to pixel (x, y); no bounds check.
  std::uint8_t* At(int x, int y) { return &rgb[3 * (static_cast<std::size_t>(y) * width + x)]; }
  const std::uint8_t* At(int x, int y) const {
    return &rgb[3 * (static_cast<std::size_t>(y) * width + x)];
  }
};

/// An image of the given size filled with one colour (alpha ignored).
Image MakeImage(int width, int height, Rgba fill);

/// Blends colour (with its alpha) over the rectangle [x, x+w) × [y, y+h), clipped to the image.
/// Integer arithmetic: deterministic.
void FillRect(Image* image, int x, int y, int w, int h, Rgba colour);

/// Width of the 5×7 glyph cell in font pixels, including 1 pixel of spacing.
inline constexpr int kGlyphAdvance = 6;
/// Height of a text line in font pixels (7 rows + 3 spacing).
inline constexpr int kLineHeight = 10;

/// Draws UTF-8 text with the built-in 5×7 font, top-left corner at (x, y), each font pixel a
/// scale × scale square. Supports printable ASCII, '°' and 'µ'; other characters draw as '?'.
void DrawText(Image* image, int x, int y, const std::string& text, int scale, Rgba colour);

/// Width in pixels DrawText uses for text at this scale.
int TextWidthPx(const std::string& text, int scale);

/// Draws the overlay (time, stimulation bars, joint angles) onto the image. Font pixels are
/// max(1, min(width / 640, height / 360)) image pixels: 1 at 640×360, 2 at 1280×720, 3 at
/// 1920×1080. Parts that do not fit are clipped.
void DrawOverlay(Image* image, const Overlay& overlay, double time_s);

}  // namespace fesim::render
