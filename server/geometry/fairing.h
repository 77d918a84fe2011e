#pragma once

//! \file fairing.h
//! \brief Fairing of a filled patch: solve L^k x = 0 for the patch's interior vertices with
//! everything else fixed (Liepa 2003 as implemented by CGAL's fair_impl; ALGORITHMS.md §6.4).
//! With k = 2 (bi-Laplacian, the default) the hole boundary and the ring of mesh vertices
//! around it constrain the patch, so it meets its neighbours with matching tangents. Where the
//! surroundings are a sphere or a quadratic height field, the patch continues that surface.

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
  //! Rings of fixed vertices around the free set that a base surface (a sphere or a quadratic
  //! height field) is fitted to; 0: no base surface, plain L^k x = 0.
  int base_fit_rings = 2;
  //! The better of the two fits is used only if the fitted points' RMS distance from it is
  //! below this fraction of their RMS distance from their centroid: surroundings such a
  //! surface describes (measured on the cases: 0.05 takes spheres and smooth scan patches,
  //! 0.1-0.2 takes bumpy ones, where the fit is a worse guess than plain fairing).
  double base_fit_tolerance = 0.05;
  //! With a base surface: move the free vertices along its normal (by a bump that vanishes at
  //! the fixed rings) so that the patch's triangles lie off it as the surroundings' do: a
  //! triangle is a chord, inside a convex surface by up to its sag, and the fit goes through
  //! the vertices while the surface the mesh shows is its triangles. The patch's triangles get
  //! the surroundings' sag on top of their corners' faired deviation, or, where the thin plate
  //! carried the corners farther off than any fixed vertex is (an overshoot), the
  //! surroundings' mean triangle deviation. Off: the vertices stay on the continued base
  //! surface exactly.
  bool match_facet_offset = true;
  //! The patch's own faces (those around the free vertices, and triangles across the hole's
  //! rim that have no free corner), which are not the surroundings' in match_facet_offset.
  //! Unset: faces with a free corner are the patch, and faces with every corner on the rim are
  //! left out of both.
  std::function<bool(FaceHandle)> in_patch;
  //! Free vertices up to which the system is solved by a dense factorisation; above, by a
  //! sparse one. Measured: below 128 the dense factorisation is faster than the sparse one's
  //! ordering and analysis.
  int dense_up_to = 128;
  //! A thin plate solved dense is summed straight from the operator's rows, each entry's terms
  //! in the order the sparse product sums them: the same system bit for bit, without the
  //! sparse matrices (most of a small fairing's time). False: through the sparse product (for
  //! comparison).
  bool direct_dense_assembly = true;
};

struct FairingReport {
  bool ok = false;
  std::string failure;
  std::size_t free_vertices = 0;
  //! "sphere" or "quadric": the surface fitted to the surroundings that the patch continues
  //! (its deviation from it was faired); empty: plain fairing.
  std::string base_surface;
};

//! Moves \p free_vertices to the solution of L^k x = 0; all other vertices stay fixed.
//! With a base surface (options.base_fit_rings > 0 and a fit within tolerance), that solution
//! places the free vertices along the surface, and their offsets from the base surface solve
//! L^k d = 0 with the fixed vertices' offsets as boundary values: the patch is the base
//! surface plus the smoothest correction that meets the boundary. Surroundings that lie on a
//! sphere or a quadric are so continued exactly, where L^k x = 0 alone flattens them (the
//! discrete thin plate's minimiser is not a sphere). On failure (singular system) nothing moves.
FairingReport fair_vertices(Mesh& mesh, std::span<const VertexHandle> free_vertices,
                            const FairingOptions& options = {});

}  // namespace touchmend::geometry
