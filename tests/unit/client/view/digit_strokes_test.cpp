// The viewer's seven-segment digits (the sharp-edge picks' numbers).
#include <algorithm>

#include <gtest/gtest.h>

#include "client/view/viewer.h"

namespace touchmend::view {
namespace {

TEST(DigitStrokes, EachDigitLightsItsSegments) {
  // Segment counts of 0..9 on a seven-segment display.
  const std::size_t segments[10] = {6, 2, 5, 5, 4, 5, 6, 3, 7, 6};
  for (int d = 0; d < 10; ++d)
    EXPECT_EQ(digit_strokes(std::to_string(d)).size(), 2 * segments[d]) << d;
  // "1" is the right-hand column: both segments at x = 1, spanning y 0..2.
  for (const auto& end : digit_strokes("1")) EXPECT_FLOAT_EQ(end[0], 1.0f);
}

TEST(DigitStrokes, DigitsAdvanceAndOtherCharactersAreSkipped) {
  const auto one = digit_strokes("1"), eleven = digit_strokes("11");
  ASSERT_EQ(eleven.size(), 2 * one.size());
  for (std::size_t i = 0; i < one.size(); ++i) {
    EXPECT_FLOAT_EQ(eleven[i][0], one[i][0]);
    EXPECT_GT(eleven[one.size() + i][0], one[i][0] + 1.0f);  // the second digit sits right of it
  }
  EXPECT_EQ(digit_strokes("P4 "), digit_strokes("4"));
  EXPECT_TRUE(digit_strokes("").empty());
  for (const auto& end : digit_strokes("0123456789")) {
    EXPECT_GE(end[1], 0.0f);
    EXPECT_LE(end[1], 2.0f);
  }
}

}  // namespace
}  // namespace touchmend::view
