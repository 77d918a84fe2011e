#pragma once

//! \file liepa_triangulation.h
//! \brief Minimum-weight triangulation of a 3D hole loop (Liepa 2003, after Barequet and
//! Sharir): the fallback for holes that no plane can project (ALGORITHMS.md §6.2).

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <unordered_set>
#include <utility>
#include <vector>

#include "server/geometry/mesh.h"

namespace touchmend::geometry {

struct LiepaTriangulationOptions {
  std::size_t max_vertices = 400;  //!< O(n^3) time, O(n^2) memory: refuse larger loops
  //! Triangles (i, m, k), i < m < k, that may not be used (ours: those found to intersect the
  //! mesh on an earlier solve; see forbidden_key).
  const std::unordered_set<std::uint64_t>* forbidden = nullptr;
};

//! Key of triangle (i, m, k), i < m < k, of an n-vertex loop in
//! LiepaTriangulationOptions::forbidden.
inline std::uint64_t forbidden_key(int i, int m, int k, int n) {
  const auto N = static_cast<std::uint64_t>(n);
  return (static_cast<std::uint64_t>(i) * N + static_cast<std::uint64_t>(m)) * N +
         static_cast<std::uint64_t>(k);
}

struct LiepaTriangulation {
  bool ok = false;
  std::string failure;
  std::vector<std::array<int, 3>> triangles;  //!< indices into the loop, oriented like it
};

//! Triangulates \p loop (hole on the left of i -> i+1) minimising, lexicographically, the
//! largest dihedral angle against already-known neighbours and then the total area.
//! \param opposite for boundary edge i -> i+1 the third vertex of the mesh triangle on the
//!        other side (NaN-free; use the edge midpoint if there is none)
//! \param blocked undirected index pairs already joined by a mesh edge outside the hole
LiepaTriangulation triangulate_min_dihedral(std::span<const Vec3> loop,
                                            std::span<const Vec3> opposite,
                                            std::span<const std::pair<int, int>> blocked,
                                            const LiepaTriangulationOptions& options = {});

}  // namespace touchmend::geometry
