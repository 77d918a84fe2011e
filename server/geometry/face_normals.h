#pragma once

//! \file face_normals.h
//! \brief Unit face normals of a hole's neighbourhood, each computed once.
//!
//! \details The mesh stores no normals (a fill changes faces as it goes); the passes around a
//! hole (the shape decision, the crease tracing) read every face near the boundary, most of
//! them several times, and recomputing a normal (a cross product and a square root) each time
//! was a tenth of a small hole's fill.

#include <algorithm>
#include <cstddef>

#include "server/geometry/local_map.h"
#include "server/geometry/mesh.h"

namespace touchmend::geometry {

class FaceNormals {
 public:
  FaceNormals(const Mesh& mesh, std::size_t expected) : mesh_(mesh), normals_(expected) {}

  //! The unit normal of \p f (zero for a degenerate face), as Mesh::calc_face_normal gives it.
  Vec3 operator()(FaceHandle f) {
    if (const Vec3* n = normals_.find(f.idx())) return *n;
    const Vec3 n = mesh_.calc_face_normal(f);
    normals_.insert(f.idx(), n);
    return n;
  }

  //! Cosine of the dihedral angle at interior edge \p e (the angle between its faces'
  //! normals; 1 when either face is degenerate). Decisions compare and rank these cosines, so
  //! the angle itself (an acos) is computed only for what is reported.
  double dihedral_cos(EdgeHandle e) {
    const Vec3 a = (*this)(mesh_.face_handle(mesh_.halfedge_handle(e, 0)));
    const Vec3 b = (*this)(mesh_.face_handle(mesh_.halfedge_handle(e, 1)));
    if (a.sqrnorm() == 0 || b.sqrnorm() == 0) return 1.0;
    return std::clamp(OpenMesh::dot(a, b), -1.0, 1.0);
  }

  const Mesh& mesh() const { return mesh_; }

 private:
  const Mesh& mesh_;
  LocalMap<Vec3> normals_;
};

}  // namespace touchmend::geometry
