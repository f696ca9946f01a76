// A tiny bitmap font for the labels of PNG pictures (client/picture/picture.h): glyphs
// of 5 x 7 pixels above the baseline, in the style of a character LCD, and one
// row below it for descenders; ASCII letters, digits and the punctuation
// labels use, plus '²'. No font library is linked: the client depends on
// libpng alone.
#ifndef RISKPLAN_CLIENT_PICTURE_BITMAP_FONT_H_
#define RISKPLAN_CLIENT_PICTURE_BITMAP_FONT_H_

#include <functional>
#include <string_view>

namespace riskplan::client {

inline constexpr int kGlyphWidth = 5;
inline constexpr int kCapHeight = 7;                   // rows above the baseline
inline constexpr int kGlyphHeight = kCapHeight + 1;    // and the descenders' row
inline constexpr int kGlyphAdvance = kGlyphWidth + 1;  // one column between glyphs

// Whether the glyph of `code` has pixel (column, row) set, (0, 0) at its top
// left. A character without a glyph is drawn as '?'.
// REQUIRES: 0 <= column < kGlyphWidth, 0 <= row < kGlyphHeight.
bool GlyphPixel(char32_t code, int column, int row);

// Whether the font has a glyph of its own for `code`.
bool HasGlyph(char32_t code);

// The width of `text` (UTF-8) in pixels at `scale`: kGlyphAdvance per
// character, without the gap after the last one.
int TextWidth(std::string_view text, int scale);

// Calls plot(x, y) for every set pixel of `text` (UTF-8) drawn at `scale`
// with its top-left corner at (0, 0); each glyph pixel is a scale x scale
// square.
void ForEachTextPixel(std::string_view text, int scale, const std::function<void(int, int)>& plot);

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_PICTURE_BITMAP_FONT_H_
