#pragma once

//! \file stroke_font.h
//! \brief A small vector font for the viewer's text (pick numbers, the status line): every
//! glyph is a few polylines on a 4 × 6 grid, drawn as GL lines, so text needs no texture, no
//! font file and no extra library. Upper-case letters, digits and common punctuation; lower
//! case is drawn as upper case, anything else as a space.

#include <array>
#include <string_view>
#include <vector>

namespace touchmend::view {

//! Glyph cell: 4 units wide, 6 high; the pen advances 6 units per character.
inline constexpr float kGlyphWidth = 4, kGlyphHeight = 6, kGlyphAdvance = 6;

//! Line segments (pairs of ends, x right and y up from the first glyph's lower left, in grid
//! units) that draw \p text on one line.
std::vector<std::array<float, 2>> text_strokes(std::string_view text);

//! Whether \p c has a glyph (after upper-casing); others are drawn as spaces.
bool has_glyph(char c);

}  // namespace touchmend::view
