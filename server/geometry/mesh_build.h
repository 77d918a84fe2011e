#pragma once

//! \file mesh_build.h
//! \brief Builds the OpenMesh mesh from raw arrays and reports everything wrong with them.
//!
//! \details OpenMesh's own importer silently duplicates the vertices of faces it cannot add
//! (non-manifold edges, flipped neighbours), which hides defects. Here every face is checked
//! before it is added; a face that cannot be added is left out and counted with its reason,
//! so the validation report is honest and nothing is changed behind the user's back.

#include <cstddef>
#include <string>
#include <vector>

#include "server/geometry/mesh.h"

namespace touchmend::geometry {

enum class RefusedFaceReason {
  RepeatedVertex,    //!< a corner index appears twice (zero-area by construction)
  DuplicateFace,     //!< same three vertices as an earlier face
  NonManifoldEdge,   //!< one of its edges already has two faces
  FlippedNeighbour,  //!< an edge is already used in the same direction (inconsistent orientation)
  ComplexVertex,     //!< OpenMesh could not link the face into a vertex's fan
};
const char* to_string(RefusedFaceReason reason);

struct RefusedFace {
  std::size_t face_index;  //!< index in the input face list
  RefusedFaceReason reason;
};

struct ValidationReport {
  std::size_t input_vertices = 0;
  std::size_t input_faces = 0;
  std::size_t unreferenced_vertices = 0;
  std::size_t degenerate_faces = 0;  //!< repeated corner or (numerically) zero area
  std::size_t duplicate_faces = 0;
  std::size_t non_manifold_edges = 0;     //!< undirected edges with more than two faces
  std::size_t inconsistent_edges = 0;     //!< edges whose two faces run in the same direction
  std::size_t non_manifold_vertices = 0;  //!< vertices whose faces form more than one fan
  std::vector<RefusedFace> refused_faces;
  std::size_t boundary_edges = 0;  //!< in the built mesh
  std::size_t boundary_loops = 0;  //!< in the built mesh (see find_holes)

  bool is_clean() const {
    return degenerate_faces == 0 && duplicate_faces == 0 && non_manifold_edges == 0 &&
           inconsistent_edges == 0 && non_manifold_vertices == 0 && refused_faces.empty();
  }
  //! Count of refused faces with \p reason.
  std::size_t refused(RefusedFaceReason reason) const;
};

struct BuildResult {
  Mesh mesh;
  ValidationReport report;
};

//! Builds a mesh from \p soup (vertex i of the soup is vertex i of the mesh; unreferenced
//! vertices are kept so indices stay stable) and validates it.
//! \pre every coordinate is finite and every index is in range (the readers guarantee it).
BuildResult build_mesh(const MeshSoup& soup);

//! Drops the deleted vertices, edges and faces at the ends of \p mesh's arrays: a garbage
//! collection of the tail alone, in O(what it drops), that leaves every other handle as it was
//! (OpenMesh's collection reads the whole mesh and renumbers it). Elements deleted last sit
//! there: those a fill's rejected attempts took out again, or those an undo removes, since undo
//! takes back the last edit first. A live element never refers to a deleted one (OpenMesh's
//! deletions unlink them), so nothing kept refers past the cut. Returns whether it dropped any.
bool drop_deleted_tail(Mesh& mesh);
//! Whether drop_deleted_tail would drop anything (its last vertex, edge or face is deleted).
bool has_deleted_tail(const Mesh& mesh);

}  // namespace touchmend::geometry
