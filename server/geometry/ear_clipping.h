#pragma once

//! \file ear_clipping.h
//! \brief Last-resort triangulation of a hole loop in 3D by clipping ears, each checked against
//! the mesh and the ears already cut, so that the patch intersects nothing (ours, after the
//! ear-cutting hole filler of MeshLab/VCG that BASELINE.md measures: it closes the holes whose
//! every minimum-weight triangulation crosses the surrounding surface).
//!
//! \details The next ear is the one that bends least against its neighbours (the mesh triangle
//! across a boundary edge, or an ear cut earlier), ties going to the better-shaped triangle; an
//! ear the check refuses is set aside until one of its neighbours is cut. O(n²) ear scores,
//! one intersection check per ear tried.

#include <array>
#include <functional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "server/geometry/intersection.h"
#include "server/geometry/mesh.h"

namespace touchmend::geometry {

struct EarClippingInput {
  std::span<const Vec3> loop;      //!< hole on the left of i -> i+1
  std::span<const Vec3> opposite;  //!< third vertex of the mesh triangle across edge i
  std::span<const std::pair<int, int>> blocked;  //!< loop pairs already joined by a mesh edge
  //! Whether a candidate triangle over loop indices crosses the mesh (the caller's index);
  //! the ears already cut are checked here.
  std::function<bool(const std::array<int, 3>& corners)> crosses_mesh;
  //! An ear may bend at most this much (radians) against a neighbour, while one that bends less
  //! is left; when none is, up to fold_bend (a fold back onto the surface is not a patch).
  double max_bend = 2.0;
  double fold_bend = 2.8;
};

struct EarClipping {
  bool ok = false;
  std::string failure;
  std::vector<std::array<int, 3>> triangles;  //!< loop indices, oriented like the loop
};

EarClipping clip_ears(const EarClippingInput& input);

}  // namespace touchmend::geometry
