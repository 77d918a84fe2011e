// The viewer's text without a window: the stroke font and the status line's wrapping.
#include <algorithm>
#include <string>

#include <gtest/gtest.h>

#include "client/view/stroke_font.h"
#include "client/view/viewer.h"

namespace touchmend::view {
namespace {

TEST(StrokeFont, EveryGlyphStaysInItsCellAndCharactersAdvance) {
  const std::string all = "ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789.,:;-+=/()[]<>|_%'\"!?#*";
  for (const char c : all) {
    const auto ends = text_strokes(std::string(1, c));
    EXPECT_FALSE(ends.empty()) << c;
    EXPECT_EQ(ends.size() % 2, 0u) << c;
    for (const auto& e : ends) {
      EXPECT_GE(e[0], 0.0f) << c;
      EXPECT_LE(e[0], kGlyphWidth) << c;
      EXPECT_GE(e[1], 0.0f) << c;
      EXPECT_LE(e[1], kGlyphHeight) << c;
    }
  }
  // The second character is the first moved one advance to the right.
  const auto one = text_strokes("7"), two = text_strokes("77");
  ASSERT_EQ(two.size(), 2 * one.size());
  for (std::size_t i = 0; i < one.size(); ++i) {
    EXPECT_FLOAT_EQ(two[one.size() + i][0], one[i][0] + kGlyphAdvance);
    EXPECT_FLOAT_EQ(two[one.size() + i][1], one[i][1]);
  }
}

TEST(StrokeFont, LowerCaseIsUpperCaseAndUnknownCharactersAreSpaces) {
  EXPECT_EQ(text_strokes("session"), text_strokes("SESSION"));
  EXPECT_TRUE(text_strokes("  ").empty());
  EXPECT_FALSE(has_glyph('\x01'));
  EXPECT_TRUE(has_glyph('q'));
  // A character without a glyph still takes its place.
  const auto spaced = text_strokes(
      "1\x01"
      "1");
  const auto first = text_strokes("1");
  ASSERT_EQ(spaced.size(), 2 * first.size());
  EXPECT_FLOAT_EQ(spaced[first.size()][0], first[0][0] + 2 * kGlyphAdvance);
  // Different letters draw differently.
  EXPECT_NE(text_strokes("E"), text_strokes("F"));
  EXPECT_NE(text_strokes("0"), text_strokes("O"));
}

TEST(WrapStatus, BreaksAtSeparatorsAndSpacesWithinTheWidth) {
  const std::string status =
      "session abc v12 | fill | 3 holes (hole 7 under the tool) | loop 1000 ticks | armed";
  const auto lines = wrap_status(status, 30, 5);
  ASSERT_GE(lines.size(), 3u);
  std::string joined;
  for (const auto& line : lines) {
    EXPECT_LE(line.size(), 30u) << line;
    EXPECT_NE(line.front(), '|') << line;  // a separator never starts a line
    joined += line + " ";
  }
  EXPECT_NE(joined.find("hole 7 under the tool"), std::string::npos) << joined;
  EXPECT_NE(joined.find("armed"), std::string::npos);
  // The line limit holds; a word longer than a line is cut.
  EXPECT_EQ(wrap_status(status, 30, 2).size(), 2u);
  const auto cut = wrap_status(std::string(25, 'x'), 10, 5);
  ASSERT_EQ(cut.size(), 3u);
  EXPECT_EQ(cut[2], std::string(5, 'x'));
  EXPECT_TRUE(wrap_status("", 10, 3).empty());
}

}  // namespace
}  // namespace touchmend::view
