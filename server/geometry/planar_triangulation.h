#pragma once

//! \file planar_triangulation.h
//! \brief Seed 000 §3.4.2-3.4.3: closing boundary angles below 5π/9, then triangulation by
//! the minimum sum of squared distances (Algorithm II), on the hole projected to its
//! reference plane.

#include <array>
#include <numbers>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "server/geometry/projection.h"

namespace touchmend::geometry {

struct PlanarTriangulationOptions {
  //! Consecutive boundary edges meeting at an interior angle below this are closed first
  //! (seed 000 §3.4.2: 5π/9, "after testing with some values").
  double close_angle = 5.0 * std::numbers::pi / 9.0;
  bool close_small_angles = true;
};

struct PlanarTriangulation {
  bool ok = false;
  std::string failure;
  std::vector<std::array<int, 3>> triangles;  //!< indices into the polygon, oriented like it
  std::size_t angles_closed = 0;              //!< triangles made by closing small angles
};

//! Triangulates a simple counter-clockwise polygon without adding vertices.
//! \param polygon the projected hole loop (hole on the left of i -> i+1)
//! \param blocked undirected index pairs already joined by a mesh edge outside the hole;
//!        no triangle may use them (a non-manifold edge would result).
PlanarTriangulation triangulate_planar(std::span<const Point2> polygon,
                                       std::span<const std::pair<int, int>> blocked,
                                       const PlanarTriangulationOptions& options = {});

//! Interior angle at b of the polygon path a -> b -> c (hole on the left), in [0, 2π).
double interior_angle(const Point2& a, const Point2& b, const Point2& c);

}  // namespace touchmend::geometry
