#pragma once

//! \file mesh.h
//! \brief The in-memory mesh type of touchmend and the raw "triangle soup" it is built from.

#include <cstdint>
#include <string>
#include <vector>

#include <OpenMesh/Core/Geometry/VectorT.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>

namespace touchmend::geometry {

//! Double-precision traits with status attributes everywhere, so no algorithm has to
//! request them and deleted elements can be marked without garbage collection.
struct MeshTraits : public OpenMesh::DefaultTraitsDouble {
  VertexAttributes(OpenMesh::Attributes::Status);
  HalfedgeAttributes(OpenMesh::Attributes::Status | OpenMesh::Attributes::PrevHalfedge);
  EdgeAttributes(OpenMesh::Attributes::Status);
  FaceAttributes(OpenMesh::Attributes::Status);
};

using Mesh = OpenMesh::TriMesh_ArrayKernelT<MeshTraits>;
using Vec3 = OpenMesh::Vec3d;
using VertexHandle = Mesh::VertexHandle;
using FaceHandle = Mesh::FaceHandle;
using HalfedgeHandle = Mesh::HalfedgeHandle;
using EdgeHandle = Mesh::EdgeHandle;

//! A triangle as three vertex indices.
using Triangle = std::array<std::uint32_t, 3>;

//! Raw vertex and face arrays exactly as a file stores them (after fan-triangulating
//! polygons). Validation works on this form, so what OpenMesh would refuse or silently
//! duplicate is still visible.
struct MeshSoup {
  std::vector<Vec3> points;
  std::vector<Triangle> triangles;
};

}  // namespace touchmend::geometry
