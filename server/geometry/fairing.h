#pragma once

//! \file fairing.h
//! \brief Fairing of a filled patch: solve L^k x = 0 for the patch's interior vertices with
//! everything else fixed (Liepa 2003 as implemented by CGAL's fair_impl; ALGORITHMS.md §6.4).
//! With k = 2 (bi-Laplacian, the default) the hole boundary and the ring of mesh vertices
//! around it constrain the patch, so it meets its neighbours with matching tangents.

#include <functional>
#include <span>
#include <string>

#include "server/geometry/mesh.h"

namespace touchmend::geometry {

enum class FairingWeights {
  Cotangent,  //!< cotangent weights over barycentric vertex areas (CGAL's default)
  Uniform,    //!< umbrella operator with unit weights
};

struct FairingOptions {
  int continuity = 1;  //!< k = continuity + 1: 0 = membrane (L), 1 = thin plate (L^2), 2 = L^3
  FairingWeights weights = FairingWeights::Cotangent;
  //! Faces the operator treats as absent (e.g. the other side of a crease the patch was split
  //! along, so each side is faired on its own and the crease stays sharp). Empty: none.
  std::function<bool(FaceHandle)> ignore_face;
};

struct FairingReport {
  bool ok = false;
  std::string failure;
  std::size_t free_vertices = 0;
};

//! Moves \p free_vertices to the solution of L^k x = 0; all other vertices stay fixed.
//! On failure (singular system) nothing moves.
FairingReport fair_vertices(Mesh& mesh, std::span<const VertexHandle> free_vertices,
                            const FairingOptions& options = {});

}  // namespace touchmend::geometry
