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
    const Vec3 n = unit_normal(mesh_, f);
    normals_.insert(f.idx(), n);
    return n;
  }

  //! Mesh::calc_face_normal of triangle \p f, bit for bit, read straight from its halfedges:
  //! OpenMesh walks a face-vertex circulator (checks at every step) and looks the point
  //! property up three times, most of the cost of a normal (measured: a tenth of a small
  //! hole's fill, in the shape decision's dihedral median). The corners in the circulator's
  //! order (to-vertices from the face's halfedge on) and its arithmetic: (p2 - p1) x (p0 - p1),
  //! scaled by one over its length.
  static Vec3 unit_normal(const Mesh& mesh, FaceHandle f) {
    const HalfedgeHandle h0 = mesh.halfedge_handle(f);
    const HalfedgeHandle h1 = mesh.next_halfedge_handle(h0);
    const Vec3* points = mesh.points();
    const Vec3& p0 = points[mesh.to_vertex_handle(h0).idx()];
    const Vec3& p1 = points[mesh.to_vertex_handle(h1).idx()];
    const Vec3& p2 = points[mesh.to_vertex_handle(mesh.next_halfedge_handle(h1)).idx()];
    Vec3 n = OpenMesh::cross(p2 - p1, p0 - p1);
    const double length = n.norm();
    return length != 0.0 ? (n *= 1.0 / length) : Vec3(0, 0, 0);
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
