#pragma once

//! \file invariants.h
//! \brief Checks every fill must pass: targets closed and nothing else changed, manifold,
//! consistently oriented, no new face intersecting any face, original vertices untouched.

#include <set>
#include <string>
#include <utility>
#include <vector>

#include "server/geometry/hole_filling.h"
#include "server/geometry/mesh.h"

namespace touchmend::testing {

using HalfedgeSet = std::set<std::pair<int, int>>;

//! Directed boundary halfedges (from, to) of the mesh.
HalfedgeSet boundary_halfedges(const geometry::Mesh& mesh);

struct Snapshot {
  HalfedgeSet boundary;
  std::vector<geometry::Vec3> points;
  std::size_t non_manifold_vertices = 0;
};
Snapshot take_snapshot(const geometry::Mesh& mesh);

//! Empty string when every invariant holds for the fills in \p reports (holes that were
//! left open must have left their boundary in place); otherwise what failed.
std::string check_fill_invariants(const Snapshot& before, const geometry::Mesh& after,
                                  const std::vector<geometry::HoleFillReport>& reports,
                                  const std::vector<geometry::Hole>& holes_before);

}  // namespace touchmend::testing
