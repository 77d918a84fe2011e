#include "server/geometry/triangulation_front.h"

namespace touchmend::geometry::detail {

TriangulationFront::TriangulationFront(std::size_t n_vertices, std::span<const int> loop,
                                       std::span<const std::pair<int, int>> blocked)
    : degree_(n_vertices, 0) {
  for (const auto& [a, b] : blocked) used_.insert(undirected(a, b));
  const std::size_t n = loop.size();
  for (std::size_t i = 0; i < n; ++i) {
    const int a = loop[i], b = loop[(i + 1) % n];
    front_.insert(key(a, b));
    used_.insert(undirected(a, b));
    ++degree_[static_cast<std::size_t>(a)];
    ++degree_[static_cast<std::size_t>(b)];
  }
}

std::vector<std::pair<int, int>> TriangulationFront::add_face(int a, int b, int c) {
  std::vector<std::pair<int, int>> created;
  const int corners[3] = {a, b, c};
  for (int k = 0; k < 3; ++k) {
    const int x = corners[k], y = corners[(k + 1) % 3];
    if (front_.erase(key(x, y)) != 0) {
      --degree_[static_cast<std::size_t>(x)];
      --degree_[static_cast<std::size_t>(y)];
    } else {
      front_.insert(key(y, x));
      ++degree_[static_cast<std::size_t>(x)];
      ++degree_[static_cast<std::size_t>(y)];
      created.emplace_back(y, x);
    }
    used_.insert(undirected(x, y));
  }
  faces_.push_back({a, b, c});
  return created;
}

std::vector<std::pair<int, int>> TriangulationFront::edges() const {
  std::vector<std::pair<int, int>> out;
  out.reserve(front_.size());
  for (std::uint64_t k : front_)
    out.emplace_back(static_cast<int>(k >> 32), static_cast<int>(k & 0xffffffffu));
  return out;
}

std::vector<int> TriangulationFront::active_vertices() const {
  std::vector<int> out;
  for (std::size_t v = 0; v < degree_.size(); ++v)
    if (degree_[v] > 0) out.push_back(static_cast<int>(v));
  return out;
}

}  // namespace touchmend::geometry::detail
