#pragma once

//! \file refinement.h
//! \brief Liepa-style patch refinement with a user cap on rounds (seed 000 §3.4.4,
//! Algorithm III; ALGORITHMS.md §2.4): scale attributes, centroid split with the √2 density
//! factor, edge relaxing by the circumsphere test.

#include <numbers>
#include <vector>

#include "server/geometry/mesh.h"

namespace touchmend::geometry {

struct RefinementOptions {
  int max_rounds = 3;  //!< seed 000 §3.4.4: the user's preset, 1-5 "provides satisfied result"
  double density_factor = std::numbers::sqrt2;  //!< Liepa's α
  int max_relax_passes = 10;  //!< relaxing in 3D need not terminate: cap the passes
  //! Only flip edges whose two triangles are coplanar (within 1°), so relaxing never changes
  //! the surface: used when the patch stays flat (a flip across a fold would move it).
  bool keep_surface = false;
};

struct RefinementReport {
  int rounds = 0;
  std::size_t splits = 0;
  std::size_t flips = 0;
};

//! Refines the patch faces in place. \p patch_faces and \p new_vertices get the faces and
//! vertices the splits create. Edges with a face outside the patch are never flipped.
RefinementReport refine_patch(Mesh& mesh, std::vector<FaceHandle>& patch_faces,
                              std::vector<VertexHandle>& new_vertices,
                              const RefinementOptions& options = {});

//! Flips interior patch edges whose opposite vertex lies inside the smallest sphere through
//! the other triangle (both ways), when the flip is admissible; returns the flip count.
std::size_t relax_patch_edges(Mesh& mesh, const std::vector<FaceHandle>& patch_faces,
                              int max_passes, bool keep_surface = false);

}  // namespace touchmend::geometry
