#include "server/geometry/mesh_build.h"

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <unordered_map>
#include <unordered_set>

#include "server/geometry/holes.h"

namespace touchmend::geometry {
namespace {

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return (static_cast<std::uint64_t>(a) << 32) | b;
}

struct TriangleHash {
  std::size_t operator()(const Triangle& t) const {
    return std::hash<std::uint64_t>{}(edge_key(t[0], t[1]) * 31 + t[2]);
  }
};

//! Union-find used to count the fans around each vertex.
struct DisjointSets {
  std::vector<std::uint32_t> parent;
  explicit DisjointSets(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  std::uint32_t find(std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(std::uint32_t a, std::uint32_t b) { parent[find(a)] = find(b); }
};

}  // namespace

const char* to_string(RefusedFaceReason reason) {
  switch (reason) {
    case RefusedFaceReason::RepeatedVertex:
      return "repeated vertex (degenerate face)";
    case RefusedFaceReason::DuplicateFace:
      return "duplicate of an earlier face";
    case RefusedFaceReason::NonManifoldEdge:
      return "edge already has two faces (non-manifold edge)";
    case RefusedFaceReason::FlippedNeighbour:
      return "edge already used in the same direction (inconsistent orientation)";
    case RefusedFaceReason::ComplexVertex:
      return "cannot be linked into a vertex fan (complex vertex)";
  }
  return "?";
}

std::size_t ValidationReport::refused(RefusedFaceReason reason) const {
  return static_cast<std::size_t>(
      std::count_if(refused_faces.begin(), refused_faces.end(),
                    [&](const RefusedFace& f) { return f.reason == reason; }));
}

BuildResult build_mesh(const MeshSoup& soup) {
  BuildResult out;
  ValidationReport& rep = out.report;
  Mesh& mesh = out.mesh;
  rep.input_vertices = soup.points.size();
  rep.input_faces = soup.triangles.size();

  // --- Validation on the raw arrays -----------------------------------------------------
  std::vector<std::uint8_t> referenced(soup.points.size(), 0);
  std::unordered_map<std::uint64_t, std::uint32_t> directed_use;  // (a,b) -> count
  std::unordered_map<std::uint64_t, std::uint32_t> undirected_use;
  std::unordered_set<Triangle, TriangleHash> seen;
  directed_use.reserve(soup.triangles.size() * 3);
  undirected_use.reserve(soup.triangles.size() * 3);
  std::vector<std::uint8_t> usable(soup.triangles.size(), 1);
  for (std::size_t f = 0; f < soup.triangles.size(); ++f) {
    const Triangle& t = soup.triangles[f];
    for (std::uint32_t v : t) referenced[v] = 1;
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      ++rep.degenerate_faces;
      usable[f] = 0;
      rep.refused_faces.push_back({f, RefusedFaceReason::RepeatedVertex});
      continue;
    }
    const Vec3& a = soup.points[t[0]];
    const Vec3& b = soup.points[t[1]];
    const Vec3& c = soup.points[t[2]];
    const double area2 = OpenMesh::cross(b - a, c - a).norm();
    const double scale = std::max({(b - a).sqrnorm(), (c - a).sqrnorm(), (c - b).sqrnorm()});
    if (!(area2 > 1e-14 * scale)) ++rep.degenerate_faces;  // kept, but reported
    Triangle sorted = t;
    std::sort(sorted.begin(), sorted.end());
    if (!seen.insert(sorted).second) {
      ++rep.duplicate_faces;
      usable[f] = 0;
      rep.refused_faces.push_back({f, RefusedFaceReason::DuplicateFace});
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t u = t[k], v = t[(k + 1) % 3];
      ++directed_use[edge_key(u, v)];
      ++undirected_use[edge_key(std::min(u, v), std::max(u, v))];
    }
  }
  for (const auto& [key, n] : undirected_use)
    if (n > 2) ++rep.non_manifold_edges;
  for (const auto& [key, n] : directed_use) {
    const auto u = static_cast<std::uint32_t>(key >> 32), v = static_cast<std::uint32_t>(key);
    if (n > 1 && undirected_use[edge_key(std::min(u, v), std::max(u, v))] == 2)
      ++rep.inconsistent_edges;
  }
  rep.unreferenced_vertices =
      static_cast<std::size_t>(std::count(referenced.begin(), referenced.end(), 0));

  // Fans: faces around a vertex that share an edge through it belong to the same fan.
  {
    std::vector<std::uint32_t> offset(soup.points.size() + 1, 0);
    for (std::size_t f = 0; f < soup.triangles.size(); ++f)
      if (usable[f])
        for (std::uint32_t v : soup.triangles[f]) ++offset[v + 1];
    std::partial_sum(offset.begin(), offset.end(), offset.begin());
    std::vector<std::uint32_t> incident(offset.back());
    std::vector<std::uint32_t> fill(offset.begin(), offset.end() - 1);
    for (std::size_t f = 0; f < soup.triangles.size(); ++f)
      if (usable[f])
        for (std::uint32_t v : soup.triangles[f])
          incident[fill[v]++] = static_cast<std::uint32_t>(f);
    for (std::size_t v = 0; v < soup.points.size(); ++v) {
      const std::uint32_t begin = offset[v], end = offset[v + 1];
      if (end - begin < 2) continue;
      DisjointSets sets(end - begin);
      // Two faces of v are in one fan if they share another vertex (an edge through v).
      std::unordered_map<std::uint32_t, std::uint32_t> first_face_with;  // other vertex -> slot
      for (std::uint32_t i = begin; i < end; ++i)
        for (std::uint32_t w : soup.triangles[incident[i]]) {
          if (w == v) continue;
          auto [it, inserted] = first_face_with.try_emplace(w, i - begin);
          if (!inserted) sets.unite(i - begin, it->second);
        }
      std::uint32_t roots = 0;
      for (std::uint32_t i = 0; i < end - begin; ++i) roots += sets.find(i) == i;
      if (roots > 1) ++rep.non_manifold_vertices;
    }
  }

  // --- Build -----------------------------------------------------------------------------
  mesh.reserve(soup.points.size(), soup.triangles.size() * 3 / 2 + 16, soup.triangles.size());
  for (const Vec3& p : soup.points) mesh.add_vertex(p);
  for (std::size_t f = 0; f < soup.triangles.size(); ++f) {
    if (!usable[f]) continue;
    const Triangle& t = soup.triangles[f];
    const VertexHandle vh[3] = {VertexHandle(static_cast<int>(t[0])),
                                VertexHandle(static_cast<int>(t[1])),
                                VertexHandle(static_cast<int>(t[2]))};
    bool blocked = false;
    for (int k = 0; k < 3 && !blocked; ++k) {
      const HalfedgeHandle h = mesh.find_halfedge(vh[k], vh[(k + 1) % 3]);
      if (h.is_valid() && !mesh.is_boundary(h)) {
        const bool both_sides = !mesh.is_boundary(mesh.opposite_halfedge_handle(h));
        rep.refused_faces.push_back({f, both_sides ? RefusedFaceReason::NonManifoldEdge
                                                   : RefusedFaceReason::FlippedNeighbour});
        blocked = true;
      }
    }
    if (blocked) continue;
    if (!mesh.add_face(vh[0], vh[1], vh[2]).is_valid())
      rep.refused_faces.push_back({f, RefusedFaceReason::ComplexVertex});
  }
  std::sort(rep.refused_faces.begin(), rep.refused_faces.end(),
            [](const RefusedFace& a, const RefusedFace& b) { return a.face_index < b.face_index; });
  for (const HalfedgeHandle h : mesh.halfedges())
    if (mesh.is_boundary(h)) ++rep.boundary_edges;
  rep.boundary_loops = find_holes(mesh).holes.size();
  return out;
}

}  // namespace touchmend::geometry
