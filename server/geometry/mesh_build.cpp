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
  // Sorted arrays instead of hash maps: a million-face scan stays well under a second.
  const std::size_t n_faces = soup.triangles.size();
  std::vector<std::uint8_t> referenced(soup.points.size(), 0);
  std::vector<std::uint8_t> usable(n_faces, 1);
  std::vector<std::pair<Triangle, std::uint32_t>> by_corners;  // sorted corners -> face
  by_corners.reserve(n_faces);
  for (std::size_t f = 0; f < n_faces; ++f) {
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
    by_corners.emplace_back(sorted, static_cast<std::uint32_t>(f));
  }
  std::sort(by_corners.begin(), by_corners.end());
  for (std::size_t i = 1; i < by_corners.size(); ++i)
    if (by_corners[i].first == by_corners[i - 1].first) {  // a later face with the same corners
      ++rep.duplicate_faces;
      usable[by_corners[i].second] = 0;
      rep.refused_faces.push_back({by_corners[i].second, RefusedFaceReason::DuplicateFace});
    }
  std::vector<std::uint64_t> directed, undirected;
  directed.reserve(3 * n_faces);
  undirected.reserve(3 * n_faces);
  for (std::size_t f = 0; f < n_faces; ++f) {
    if (!usable[f]) continue;
    const Triangle& t = soup.triangles[f];
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t u = t[k], v = t[(k + 1) % 3];
      directed.push_back(edge_key(u, v));
      undirected.push_back(edge_key(std::min(u, v), std::max(u, v)));
    }
  }
  std::sort(directed.begin(), directed.end());
  std::sort(undirected.begin(), undirected.end());
  auto undirected_count = [&](std::uint64_t key) {
    const auto range = std::equal_range(undirected.begin(), undirected.end(), key);
    return static_cast<std::size_t>(range.second - range.first);
  };
  for (std::size_t i = 0; i < undirected.size();) {
    std::size_t j = i;
    while (j < undirected.size() && undirected[j] == undirected[i]) ++j;
    if (j - i > 2) ++rep.non_manifold_edges;
    i = j;
  }
  for (std::size_t i = 0; i < directed.size();) {
    std::size_t j = i;
    while (j < directed.size() && directed[j] == directed[i]) ++j;
    if (j - i > 1) {
      const auto u = static_cast<std::uint32_t>(directed[i] >> 32),
                 v = static_cast<std::uint32_t>(directed[i]);
      if (undirected_count(edge_key(std::min(u, v), std::max(u, v))) == 2) ++rep.inconsistent_edges;
    }
    i = j;
  }
  rep.unreferenced_vertices =
      static_cast<std::size_t>(std::count(referenced.begin(), referenced.end(), 0));

  // Fans: faces around a vertex that share an edge through it belong to the same fan.
  {
    std::vector<std::uint32_t> offset(soup.points.size() + 1, 0);
    for (std::size_t f = 0; f < n_faces; ++f)
      if (usable[f])
        for (std::uint32_t v : soup.triangles[f]) ++offset[v + 1];
    std::partial_sum(offset.begin(), offset.end(), offset.begin());
    std::vector<std::uint32_t> incident(offset.back());
    std::vector<std::uint32_t> fill(offset.begin(), offset.end() - 1);
    for (std::size_t f = 0; f < n_faces; ++f)
      if (usable[f])
        for (std::uint32_t v : soup.triangles[f])
          incident[fill[v]++] = static_cast<std::uint32_t>(f);
    std::vector<std::pair<std::uint32_t, std::uint32_t>> first_face_with;  // other vertex -> slot
    for (std::size_t v = 0; v < soup.points.size(); ++v) {
      const std::uint32_t begin = offset[v], end = offset[v + 1];
      if (end - begin < 2) continue;
      DisjointSets sets(end - begin);
      // Two faces of v are in one fan if they share another vertex (an edge through v).
      first_face_with.clear();
      for (std::uint32_t i = begin; i < end; ++i)
        for (std::uint32_t w : soup.triangles[incident[i]]) {
          if (w == v) continue;
          auto it = std::find_if(first_face_with.begin(), first_face_with.end(),
                                 [w](const auto& e) { return e.first == w; });
          if (it == first_face_with.end())
            first_face_with.emplace_back(w, i - begin);
          else
            sets.unite(i - begin, it->second);
        }
      std::uint32_t roots = 0;
      for (std::uint32_t i = 0; i < end - begin; ++i) roots += sets.find(i) == i;
      if (roots > 1) ++rep.non_manifold_vertices;
    }
  }

  // --- Build -----------------------------------------------------------------------------
  // Headroom for the fills to come: growing past the capacity copies every property array
  // of the mesh once, which on a large mesh costs more than filling a hole.
  const std::size_t nv = soup.points.size(), nf = soup.triangles.size();
  mesh.reserve(nv + nv / 8 + 1024, (nf + nf / 8 + 2048) * 3 / 2, nf + nf / 8 + 2048);
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

bool has_deleted_tail(const Mesh& mesh) {
  const auto last_deleted = [&mesh](auto handle, std::size_t n) {
    return n > 0 && mesh.status(decltype(handle)(static_cast<int>(n - 1))).deleted();
  };
  return last_deleted(VertexHandle{}, mesh.n_vertices()) ||
         last_deleted(EdgeHandle{}, mesh.n_edges()) || last_deleted(FaceHandle{}, mesh.n_faces());
}

bool drop_deleted_tail(Mesh& mesh) {
  if (!has_deleted_tail(mesh)) return false;
  std::size_t n_vertices = mesh.n_vertices();
  std::size_t n_edges = mesh.n_edges();
  std::size_t n_faces = mesh.n_faces();
  while (n_faces > 0 && mesh.status(FaceHandle(static_cast<int>(n_faces - 1))).deleted()) --n_faces;
  while (n_edges > 0 && mesh.status(EdgeHandle(static_cast<int>(n_edges - 1))).deleted()) --n_edges;
  while (n_vertices > 0 && mesh.status(VertexHandle(static_cast<int>(n_vertices - 1))).deleted())
    --n_vertices;
  mesh.resize(n_vertices, n_edges, n_faces);
  return true;
}

}  // namespace touchmend::geometry
