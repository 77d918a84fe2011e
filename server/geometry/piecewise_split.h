#pragma once

//! \file piecewise_split.h
//! \brief Piecewise filling of complex holes (seed 001, Jun 2005): split the hole by the 3D
//! shape of its boundary into simple sub-holes and triangulate each on its own plane.
//!
//! \details Only the abstract and §2.1 of Jun's paper survive in seed 001, so the split rule
//! is ours (ALGORITHMS.md §5.2): a chord (a, b) between two boundary vertices is a candidate
//! when it leaves both ends into the hole (inside the interior-angle wedge in the vertex's
//! tangent plane), keeps a clearance of a quarter edge length from every mesh face not
//! incident to a or b, and is not already a mesh edge. Candidates are scored by
//!   J = |ab| / min(arc(a->b), arc(b->a)) + ψ(L1) + ψ(L2),
//! ψ = smallest eigenvalue / trace of a sub-loop's covariance (0 when planar): short chords
//! that cut the loop into flat halves win. Among the five best, the first whose halves both
//! project simply is taken. The chord is sampled at the boundary edge length, both halves
//! recurse until every piece is simple (or tiny, then the 3D minimum-weight triangulation
//! closes it). Each chord is shorter than either arc it replaces, so the recursion ends.

#include <array>
#include <functional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "server/geometry/mesh.h"
#include "server/geometry/planar_triangulation.h"

namespace touchmend::geometry {

struct PiecewiseInput {
  std::span<const Vec3> loop;            //!< hole loop, hole on the left of i -> i+1
  std::span<const Vec3> opposite;        //!< third vertex of the mesh triangle across edge i
  std::span<const Vec3> vertex_normals;  //!< mesh normal at each loop vertex
  std::span<const std::pair<int, int>> blocked;  //!< loop index pairs already joined by an edge
  double mean_edge_length = 0;
  //! Distance from segment [a, b] (loop indices ia, ib) to the nearest mesh face not incident
  //! to either end; used for the chord clearance test.
  std::function<double(int ia, int ib, const Vec3& a, const Vec3& b)> chord_clearance;
};

struct PiecewiseOptions {
  int max_depth = 64;
  std::size_t candidates_per_vertex = 8;
  //! When none of those gives a valid chord and the piece has more than max_dp_vertices (no
  //! DP can close it unsplit), the search is repeated with this many.
  std::size_t wide_candidates_per_vertex = 32;
  std::size_t max_dp_vertices = 400;  //!< tiny or unsplittable pieces go to the 3D DP
  PlanarTriangulationOptions planar;
};

struct PiecewiseResult {
  bool ok = false;
  std::string failure;
  std::vector<Vec3> new_points;               //!< chord vertices; pool index = loop.size() + i
  std::vector<std::array<int, 3>> triangles;  //!< pool indices, oriented like the loop
  std::size_t pieces = 0;
  std::size_t planar_pieces = 0;
  std::size_t angles_closed = 0;
};

PiecewiseResult triangulate_piecewise(const PiecewiseInput& input,
                                      const PiecewiseOptions& options = {});

}  // namespace touchmend::geometry
