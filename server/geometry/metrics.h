#pragma once

//! \file metrics.h
//! \brief Fill quality metrics shared by the tests, the benchmarks and (later) the server,
//! with the definitions of DESIGN.md "Quality metrics" and ALGORITHMS.md §11.1.

#include <array>
#include <cstddef>
#include <span>
#include <vector>

#include "server/geometry/intersection.h"
#include "server/geometry/mesh.h"
#include "server/geometry/mesh_build.h"

namespace touchmend::geometry {

//! Distances between two triangle sets. Each side is sampled on a barycentric grid of
//! spacing \p spacing (corners and edges included); distances are point-to-surface.
struct SurfaceDistance {
  double h_a_to_b = 0;  //!< max over samples of A of the distance to B
  double h_b_to_a = 0;
  double hausdorff = 0;    //!< max of the two
  double mean_a_to_b = 0;  //!< area-weighted mean
  double mean_b_to_a = 0;
  double mean = 0;                  //!< (mean_a_to_b + mean_b_to_a) / 2
  double normal_deviation_deg = 0;  //!< mean angle between A's normals and B's at the closest point
  bool valid = false;               //!< false when either set is empty
};

SurfaceDistance surface_distance(std::span<const TrianglePoints> a,
                                 std::span<const TrianglePoints> b, double spacing);

//! Distance from line segments (sampled at \p spacing, ends included) to a triangle set: the
//! sharp-edge fidelity of ALGORITHMS.md §11.1 (ground-truth crease edges to the fill).
struct SegmentDistance {
  double max = 0;
  double mean = 0;     //!< length-weighted
  bool valid = false;  //!< false when either set is empty
};

SegmentDistance segment_distance(std::span<const std::array<Vec3, 2>> segments,
                                 std::span<const TrianglePoints> triangles, double spacing);

struct TriangleQuality {
  double min_angle_deg = 180;
  double max_aspect_ratio = 0;  //!< longest edge / (2√3 · inradius): 1 for equilateral
  std::size_t below_10_deg = 0;
  std::size_t degenerate = 0;
};

TriangleQuality triangle_quality(std::span<const TrianglePoints> triangles);

//! The non-deleted faces and vertices of \p mesh as arrays (compact indices).
MeshSoup to_soup(const Mesh& mesh);

//! Independent structural check of a mesh: rebuilds it from its arrays and validates them
//! (manifold edges and vertices, consistent orientation, degenerate and duplicate faces).
ValidationReport validate_mesh(const Mesh& mesh);

//! Bounding-box diagonal of the non-deleted vertices.
double bounding_box_diagonal(const Mesh& mesh);

//! Triangles of the given faces.
std::vector<TrianglePoints> face_triangles(const Mesh& mesh, std::span<const FaceHandle> faces);

}  // namespace touchmend::geometry
