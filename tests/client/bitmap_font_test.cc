#include "client/picture/bitmap_font.h"

#include <set>
#include <string>
#include <utility>

#include "gtest/gtest.h"

namespace riskplan::client {
namespace {

std::set<std::pair<int, int>> Pixels(std::string_view text, int scale) {
  std::set<std::pair<int, int>> pixels;
  ForEachTextPixel(text, scale, [&](int x, int y) { pixels.insert({x, y}); });
  return pixels;
}

TEST(BitmapFontTest, WidthIsSixPixelsACharacterLessTheLastGap) {
  EXPECT_EQ(TextWidth("", 1), 0);
  EXPECT_EQ(TextWidth("1 km", 1), 23);
  EXPECT_EQ(TextWidth("1 km", 2), 46);
  EXPECT_EQ(TextWidth("m²", 1), 11);  // '²' is one character of two bytes
}

TEST(BitmapFontTest, GlyphsAreDrawnLeftToRightAndScaled) {
  // '1': a vertical stroke in the middle column, a foot three wide.
  EXPECT_TRUE(GlyphPixel('1', 2, 0));
  EXPECT_TRUE(GlyphPixel('1', 2, 3));
  EXPECT_FALSE(GlyphPixel('1', 0, 3));
  EXPECT_TRUE(GlyphPixel('1', 1, 6) && GlyphPixel('1', 3, 6));
  const auto one = Pixels("1", 1);
  const auto dash_one = Pixels("-1", 1);
  EXPECT_EQ(one.size() + 5, dash_one.size());  // '-' is one row of five
  EXPECT_TRUE(dash_one.count({kGlyphAdvance + 2, 0}));
  // At scale 2 each pixel is a 2 x 2 square.
  EXPECT_EQ(Pixels("1", 2).size(), 4 * one.size());
  EXPECT_TRUE(Pixels("1", 2).count({5, 1}));
}

TEST(BitmapFontTest, CharactersWithoutAGlyphAreQuestionMarks) {
  EXPECT_FALSE(HasGlyph(U'€'));
  EXPECT_EQ(Pixels("€", 1), Pixels("?", 1));
  EXPECT_EQ(Pixels("a\xff", 1), Pixels("a?", 1));  // not UTF-8
  EXPECT_NE(Pixels("²", 1), Pixels("?", 1));
}

TEST(BitmapFontTest, OnlyDescendersReachBelowTheBaseline) {
  for (char32_t c = 32; c < 127; ++c) {
    if (!HasGlyph(c)) continue;
    bool below = false;
    for (int column = 0; column < kGlyphWidth; ++column) below |= GlyphPixel(c, column, kCapHeight);
    EXPECT_EQ(below, std::u32string(U"gjpqy,").find(c) != std::u32string::npos)
        << static_cast<char>(c);
  }
}

TEST(BitmapFontTest, LettersDigitsAndLabelPunctuationHaveGlyphs) {
  for (char c = 'a'; c <= 'z'; ++c) EXPECT_TRUE(HasGlyph(c)) << c;
  for (char c = 'A'; c <= 'Z'; ++c) EXPECT_TRUE(HasGlyph(c)) << c;
  for (char c = '0'; c <= '9'; ++c) EXPECT_TRUE(HasGlyph(c)) << c;
  for (char c : std::string(" .,:-+=_/()<>%'?")) EXPECT_TRUE(HasGlyph(c)) << c;
}

}  // namespace
}  // namespace riskplan::client
