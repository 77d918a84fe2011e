#include "client/view/stroke_font.h"

#include <cctype>
#include <cstddef>

namespace touchmend::view {
namespace {

//! Glyphs as polylines: "xy xy xy;xy xy" with single-digit grid coordinates (x 0-4, y 0-6,
//! y up); ';' starts a new polyline.
const char* glyph(char c) {
  switch (c) {
    case 'A':
      return "00 04 26 44 40;03 43";
    case 'B':
      return "00 06 36 45 44 33 03;33 42 41 30 00";
    case 'C':
      return "46 16 05 01 10 40";
    case 'D':
      return "00 06 26 44 42 20 00";
    case 'E':
      return "46 06 00 40;03 33";
    case 'F':
      return "46 06 00;03 33";
    case 'G':
      return "46 16 05 01 10 40 43 23";
    case 'H':
      return "00 06;40 46;03 43";
    case 'I':
      return "16 36;26 20;10 30";
    case 'J':
      return "46 41 30 10 01";
    case 'K':
      return "06 00;46 03 40";
    case 'L':
      return "06 00 40";
    case 'M':
      return "00 06 23 46 40";
    case 'N':
      return "00 06 40 46";
    case 'O':
      return "10 01 05 16 36 45 41 30 10";
    case 'P':
      return "00 06 36 45 44 33 03";
    case 'Q':
      return "10 01 05 16 36 45 41 30 10;22 40";
    case 'R':
      return "00 06 36 45 44 33 03;23 40";
    case 'S':
      return "46 16 05 04 13 33 42 41 30 00";
    case 'T':
      return "06 46;26 20";
    case 'U':
      return "06 01 10 30 41 46";
    case 'V':
      return "06 20 46";
    case 'W':
      return "06 10 23 30 46";
    case 'X':
      return "00 46;06 40";
    case 'Y':
      return "06 23 46;23 20";
    case 'Z':
      return "06 46 00 40";
    case '0':
      return "10 01 05 16 36 45 41 30 10;41 05";
    case '1':
      return "15 26 20;10 30";
    case '2':
      return "05 16 36 45 44 00 40";
    case '3':
      return "05 16 36 45 44 33 13;33 42 41 30 10 01";
    case '4':
      return "36 02 42;30 36";
    case '5':
      return "46 06 04 34 43 41 30 00";
    case '6':
      return "45 36 16 05 01 10 30 41 42 33 03";
    case '7':
      return "06 46 20";
    case '8':
      return "13 04 05 16 36 45 44 33 13 02 01 10 30 41 42 33";
    case '9':
      return "01 10 30 41 45 36 16 05 04 13 43";
    case '.':
      return "10 20 21 11 10";
    case ',':
      return "21 10";
    case ':':
      return "12 22;14 24";
    case ';':
      return "14 24;22 10";
    case '-':
      return "13 33";
    case '+':
      return "13 33;22 24";
    case '=':
      return "12 32;14 34";
    case '/':
      return "00 46";
    case '(':
      return "36 24 22 30";
    case ')':
      return "16 24 22 10";
    case '[':
      return "36 16 10 30";
    case ']':
      return "16 36 30 10";
    case '<':
      return "45 03 41";
    case '>':
      return "05 43 01";
    case '|':
      return "26 20";
    case '_':
      return "00 40";
    case '%':
      return "00 46;05 16;30 41";
    case '\'':
      return "26 24";
    case '"':
      return "16 14;36 34";
    case '!':
      return "26 22;20 21";
    case '?':
      return "05 16 36 45 44 23 22;20 21";
    case '#':
      return "10 16;30 36;02 42;04 44";
    case '*':
      return "13 33;22 24;12 34;14 32";
    default:
      return nullptr;
  }
}

}  // namespace

bool has_glyph(char c) {
  return glyph(static_cast<char>(std::toupper(static_cast<unsigned char>(c)))) != nullptr;
}

std::vector<std::array<float, 2>> text_strokes(std::string_view text) {
  std::vector<std::array<float, 2>> ends;
  float x = 0;
  for (const char raw : text) {
    const char* g = glyph(static_cast<char>(std::toupper(static_cast<unsigned char>(raw))));
    if (g) {
      // Each point is two digits; a space between points continues the polyline, ';' ends it.
      bool have_previous = false;
      std::array<float, 2> previous{};
      for (const char* p = g; *p;) {
        if (*p == ';') {
          have_previous = false;
          ++p;
          continue;
        }
        if (*p == ' ') {
          ++p;
          continue;
        }
        const std::array<float, 2> point{x + static_cast<float>(p[0] - '0'),
                                         static_cast<float>(p[1] - '0')};
        p += 2;
        if (have_previous) {
          ends.push_back(previous);
          ends.push_back(point);
        }
        previous = point;
        have_previous = true;
      }
    }
    x += kGlyphAdvance;
  }
  return ends;
}

}  // namespace touchmend::view
