#pragma once

//! \file mesh_intersections.h
//! \brief Intersections between chosen faces and the rest of a mesh.

#include <cstddef>
#include <span>
#include <utility>
#include <vector>

#include "server/geometry/mesh.h"

namespace touchmend::geometry {

//! Pairs of intersecting faces with at least one face in \p faces (each pair once). Faces
//! sharing a vertex or an edge intersect only beyond what they share (see
//! triangles_intersect). Stops after \p stop_after pairs (0: count all).
std::vector<std::pair<FaceHandle, FaceHandle>> find_face_intersections(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::size_t stop_after = 0);

//! Every intersecting pair of faces of the whole mesh.
std::vector<std::pair<FaceHandle, FaceHandle>> find_self_intersections(const Mesh& mesh,
                                                                      std::size_t stop_after = 0);

}  // namespace touchmend::geometry
