#pragma once

//! \file cgal_reference.h
//! \brief CGAL's hole filler on the same input, for the comparison benchmark only (CGAL's
//! Polygon Mesh Processing is GPL-3; it is never linked into the product).

#include <cstdint>
#include <span>
#include <vector>

#include "server/geometry/intersection.h"
#include "server/geometry/mesh.h"

namespace touchmend::bench {

struct CgalHoleResult {
  bool ok = false;
  double seconds = 0;  //!< time inside the CGAL call only
  std::vector<geometry::TrianglePoints> new_triangles;
};

enum class CgalMode { RefineAndFair, TriangulateOnly };

//! Fills, one after another, the holes given by their boundary vertex loops (soup vertex ids)
//! with CGAL::Polygon_mesh_processing::triangulate_refine_and_fair_hole (or triangulate_hole),
//! CGAL 5.5 defaults.
std::vector<CgalHoleResult> cgal_fill_holes(const geometry::MeshSoup& soup,
                                            const std::vector<std::vector<std::uint32_t>>& loops,
                                            CgalMode mode);

}  // namespace touchmend::bench
