#include "server/geometry/holes.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <set>

#include <fmt/format.h>

#include "server/geometry/local_map.h"
#include "server/geometry/projection.h"

namespace touchmend::geometry {

namespace {

//! The outgoing boundary halfedge at the far end of the fan whose first face lies across
//! \p incoming (rotating around its target vertex through faces only).
HalfedgeHandle same_fan_end(const Mesh& mesh, HalfedgeHandle incoming) {
  const VertexHandle v = mesh.to_vertex_handle(incoming);
  HalfedgeHandle g = mesh.opposite_halfedge_handle(incoming);
  const std::size_t max_steps = 4 * mesh.valence(v) + 4;
  for (std::size_t step = 0; step < max_steps; ++step) {
    g = mesh.opposite_halfedge_handle(mesh.prev_halfedge_handle(g));
    if (mesh.is_boundary(g)) return g;
  }
  return HalfedgeHandle();
}

}  // namespace

HalfedgeHandle next_hole_halfedge(const Mesh& mesh, HalfedgeHandle incoming) {
  // At a manifold boundary vertex the faces form one fan and the hole is the gap between
  // its two ends: the successor is the far end of the fan across `incoming` (ALGORITHMS.md
  // §1.2). Where holes touch at a vertex (seed 000 Fig. 3.5) the vertex has one fan per gap,
  // and each gap is bounded by the ends of two *different* fans: following the same fan
  // would jump into the other hole (a figure-8 loop), so the successor is taken from another
  // fan: the only other one when there are two, else the first boundary edge clockwise
  // from `incoming` around the vertex normal (the side the hole lies on).
  const VertexHandle v = mesh.to_vertex_handle(incoming);
  std::vector<HalfedgeHandle> outgoing;
  for (const HalfedgeHandle h : mesh.voh_range(v))
    if (mesh.is_boundary(h)) outgoing.push_back(h);
  const HalfedgeHandle same = same_fan_end(mesh, incoming);
  if (outgoing.size() <= 1) return same;
  if (!same.is_valid()) return same;
  if (outgoing.size() == 2) return outgoing[0] == same ? outgoing[1] : outgoing[0];
  Vec3 normal(0, 0, 0);
  for (const FaceHandle f : mesh.vf_range(v)) normal += mesh.calc_face_normal(f);
  normal.normalize_cond();
  const Vec3& pv = mesh.point(v);
  auto tangent = [&](const Vec3& d) { return d - OpenMesh::dot(d, normal) * normal; };
  const Vec3 d_in = tangent(mesh.point(mesh.from_vertex_handle(incoming)) - pv);
  HalfedgeHandle best;
  double best_angle = 1e300;
  for (const HalfedgeHandle h : outgoing) {
    if (h == same) continue;
    const Vec3 d = tangent(mesh.point(mesh.to_vertex_handle(h)) - pv);
    // Clockwise angle (seen from outside) from d_in to d, in (0, 2π].
    double a = std::atan2(OpenMesh::dot(OpenMesh::cross(d, d_in), normal), OpenMesh::dot(d_in, d));
    if (a <= 0) a += 2 * std::numbers::pi;
    if (a < best_angle) {
      best_angle = a;
      best = h;
    }
  }
  return best;
}

void compute_hole_properties(const Mesh& mesh, Hole& hole, bool compute_projectability) {
  hole.fragment_faces = count_fragment_faces(mesh, hole);
  const std::size_t n = hole.loop.size();
  std::vector<Vec3> points(n);
  for (std::size_t i = 0; i < n; ++i) points[i] = mesh.point(hole.loop[i]);
  hole.perimeter = 0;
  Vec3 weighted(0, 0, 0);
  Vec3 newell(0, 0, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3& p = points[i];
    const Vec3& q = points[(i + 1) % n];
    const double len = (q - p).norm();
    hole.perimeter += len;
    weighted += 0.5 * (p + q) * len;
    newell += OpenMesh::cross(p, q);
  }
  hole.mean_edge_length = n > 0 ? hole.perimeter / static_cast<double>(n) : 0;
  hole.centroid = hole.perimeter > 0 ? weighted / hole.perimeter : points.front();
  newell *= 0.5;
  hole.area = newell.norm();
  hole.newell_normal = hole.area > 0 ? newell / hole.area : Vec3(0, 0, 0);

  // Seed 000 §3.4.1: the hole normal is the average of the boundary triangles' normals.
  std::set<int> seen_faces;
  std::vector<Vec3> outside_points;
  Vec3 normal_sum(0, 0, 0);
  std::size_t boundary_faces = 0;
  for (const HalfedgeHandle h : hole.halfedges) {
    const HalfedgeHandle in_face = mesh.opposite_halfedge_handle(h);
    const FaceHandle f = mesh.face_handle(in_face);
    if (!f.is_valid()) continue;
    outside_points.push_back(mesh.point(mesh.to_vertex_handle(mesh.next_halfedge_handle(in_face))));
    if (!seen_faces.insert(f.idx()).second) continue;
    const Vec3 a = mesh.point(mesh.from_vertex_handle(in_face));
    const Vec3 b = mesh.point(mesh.to_vertex_handle(in_face));
    const Vec3 c = outside_points.back();
    Vec3 fn = OpenMesh::cross(b - a, c - a);
    const double len = fn.norm();
    if (len > 0) {
      normal_sum += fn / len;
      ++boundary_faces;
    }
  }
  const double sum_len = normal_sum.norm();
  hole.normal = sum_len > 0 ? normal_sum / sum_len : hole.newell_normal;

  const Vec3 pca = pca_normal(points, hole.normal);
  double planarity = 0;
  for (const Vec3& p : points)
    planarity = std::max(planarity, std::abs(OpenMesh::dot(p - hole.centroid, pca)));
  hole.planarity = planarity;

  hole.is_simple = false;
  hole.reference_source = "none";
  hole.reference_normal = hole.normal;
  hole.projectability_computed = compute_projectability;
  if (!compute_projectability || n < 3) return;
  // Fallback chain (ALGORITHMS.md §1.4): boundary-triangle average (unless it nearly cancels,
  // as at the open end of a tube), then the Newell normal, then the least-squares plane.
  struct Candidate {
    Vec3 normal;
    const char* source;
  };
  std::vector<Candidate> candidates;
  if (sum_len >= 0.1 * static_cast<double>(boundary_faces))
    candidates.push_back({hole.normal, "boundary-triangles"});
  if (hole.area > 0) candidates.push_back({hole.newell_normal, "newell"});
  candidates.push_back({pca, "pca"});
  const double tolerance = 0.05 * hole.mean_edge_length;
  for (const Candidate& c : candidates) {
    const ReferenceFrame frame = ReferenceFrame::from_normal(c.normal, hole.centroid);
    if (test_projectable(points, outside_points, frame, tolerance).projectable) {
      hole.is_simple = true;
      hole.reference_normal = c.normal;
      hole.reference_source = c.source;
      return;
    }
  }
}

namespace {

//! The fill's geometric tests multiply up to four lengths or coordinates (squared areas,
//! orientation determinants, the fairing's area weights). With boundary edges shorter than
//! kMinComputableLength or coordinates beyond kMaxComputableCoordinate those products leave the
//! double range (underflow to 0, overflow to inf): normals and angles come out 0 and a fill
//! would be wrong without knowing it. Such a hole is refused, saying why, instead.
constexpr double kMinComputableLength = 1e-60;
constexpr double kMaxComputableCoordinate = 1e60;

//! Reads the hole's properties (compute_hole_properties first).
std::string out_of_range_reason(const Mesh& mesh, const Hole& hole) {
  double largest = 0;
  for (const VertexHandle v : hole.loop) {
    const Vec3& p = mesh.point(v);
    largest = std::max({largest, std::abs(p[0]), std::abs(p[1]), std::abs(p[2])});
  }
  if (!(largest <= kMaxComputableCoordinate))
    return fmt::format(
        "a boundary coordinate is {:.3g}, beyond the {:.0e} the fill's geometric tests can "
        "multiply without overflow: rescale the mesh",
        largest, kMaxComputableCoordinate);
  if (hole.mean_edge_length == 0)
    return "the boundary's vertices all lie at one point (a degenerate hole)";
  if (!(hole.mean_edge_length >= kMinComputableLength))
    return fmt::format(
        "the boundary edges are {:.3g} long on average, below the {:.0e} the fill's geometric "
        "tests can multiply without underflow: a degenerate hole, or rescale the mesh",
        hole.mean_edge_length, kMinComputableLength);
  return {};
}

}  // namespace

std::size_t count_fragment_faces(const Mesh& mesh, const Hole& hole) {
  return fragment_piece(mesh, hole).size();
}

std::vector<FaceHandle> fragment_piece(const Mesh& mesh, const Hole& hole) {
  const std::size_t limit = hole.loop.size();
  std::set<int> piece;
  std::vector<FaceHandle> stack;
  for (const HalfedgeHandle h : hole.halfedges) {
    const FaceHandle f = mesh.opposite_face_handle(h);
    if (f.is_valid() && piece.insert(f.idx()).second) stack.push_back(f);
  }
  std::size_t border = 0;
  while (!stack.empty()) {
    if (piece.size() > limit) return {};
    const FaceHandle f = stack.back();
    stack.pop_back();
    for (const HalfedgeHandle h : mesh.fh_range(f)) {
      const FaceHandle g = mesh.opposite_face_handle(h);
      if (!g.is_valid())
        ++border;
      else if (piece.insert(g.idx()).second)
        stack.push_back(g);
    }
  }
  if (piece.size() > limit || border != hole.loop.size()) return {};
  std::vector<FaceHandle> faces;
  for (const int f : piece) faces.emplace_back(f);  // a std::set: in index order
  return faces;
}

bool trace_hole_loop(const Mesh& mesh, HalfedgeHandle start, std::size_t max_edges, Hole& hole) {
  hole.loop.clear();
  hole.halfedges.clear();
  HalfedgeHandle h = start;
  do {
    if (hole.loop.size() == max_edges) return false;
    hole.loop.push_back(mesh.from_vertex_handle(h));
    hole.halfedges.push_back(h);
    h = next_hole_halfedge(mesh, h);
  } while (h.is_valid() && h != start);
  return h == start;
}

namespace {

//! The loop through boundary halfedge \p start (next_hole_halfedge at each vertex), its
//! halfedges marked with \p mark; nullopt when a fan is corrupt (the walk does not close, or
//! runs into a halfedge \p walked says another loop took).
template <typename Walked, typename Mark>
std::optional<Hole> walk_loop(const Mesh& mesh, HalfedgeHandle start, Walked&& walked,
                              Mark&& mark) {
  Hole hole;
  HalfedgeHandle h = start;
  do {
    mark(h);
    hole.loop.push_back(mesh.from_vertex_handle(h));
    hole.halfedges.push_back(h);
    h = next_hole_halfedge(mesh, h);
    if (!h.is_valid() || (walked(h) && h != start) || hole.loop.size() > mesh.n_halfedges())
      return std::nullopt;
  } while (h != start);
  if (hole.loop.size() < 3) hole.unfillable_reason = "boundary loop with fewer than 3 edges";
  // A loop through the same vertex twice (the outside of a bowtie, a hole pinched at a
  // vertex) is not a disk: the fill closes the pinch first (fill_hole).
  std::vector<int> ids;
  for (const VertexHandle v : hole.loop) ids.push_back(v.idx());
  std::sort(ids.begin(), ids.end());
  for (auto dup = std::adjacent_find(ids.begin(), ids.end()); dup != ids.end();
       dup = std::adjacent_find(dup, ids.end())) {
    hole.pinched_at.push_back(VertexHandle(*dup));
    dup = std::upper_bound(dup, ids.end(), *dup);
  }
  return hole;
}

//! Orders \p holes deterministically (by their smallest halfedge (u, v)) and gives them their
//! stable ids in that order; computes the properties of those whose \p fresh flag is set and
//! only the fragment count of the others (which an edit away from the loop can change: the
//! filling of a second loop of the same small piece).
void finish_search(const Mesh& mesh, std::vector<Hole>& holes, const std::vector<char>& fresh,
                   const HoleSearchOptions& options) {
  auto key = [&](const Hole& hole) {
    std::pair<int, int> best{std::numeric_limits<int>::max(), std::numeric_limits<int>::max()};
    for (std::size_t i = 0; i < hole.loop.size(); ++i)
      best = std::min(best, {hole.loop[i].idx(), hole.loop[(i + 1) % hole.loop.size()].idx()});
    return best;
  };
  std::vector<std::pair<std::pair<int, int>, std::size_t>> order;
  for (std::size_t i = 0; i < holes.size(); ++i) order.push_back({key(holes[i]), i});
  std::sort(order.begin(), order.end());
  std::vector<Hole> sorted;
  sorted.reserve(holes.size());
  std::set<std::uint32_t> used_ids;
  std::uint32_t overflow_id = static_cast<std::uint32_t>(mesh.n_vertices());
  for (const auto& [k, i] : order) {
    Hole& hole = holes[i];
    std::vector<std::uint32_t> ids;
    for (const VertexHandle v : hole.loop) ids.push_back(static_cast<std::uint32_t>(v.idx()));
    std::sort(ids.begin(), ids.end());
    hole.id = overflow_id;
    for (std::uint32_t id : ids)
      if (!used_ids.count(id)) {
        hole.id = id;
        break;
      }
    if (hole.id == overflow_id) ++overflow_id;
    used_ids.insert(hole.id);
    if (fresh[i]) {
      compute_hole_properties(mesh, hole, options.compute_projectability);
      if (hole.unfillable_reason.empty()) hole.unfillable_reason = out_of_range_reason(mesh, hole);
    } else {
      hole.fragment_faces = count_fragment_faces(mesh, hole);
    }
    sorted.push_back(std::move(hole));
  }
  holes = std::move(sorted);
}

}  // namespace

HoleSearchResult find_holes(const Mesh& mesh, const HoleSearchOptions& options) {
  HoleSearchResult result;
  std::vector<std::uint8_t> visited(mesh.n_halfedges(), 0);
  for (const HalfedgeHandle start : mesh.halfedges()) {
    if (visited[start.idx()] || !mesh.is_boundary(start)) continue;
    std::optional<Hole> hole = walk_loop(
        mesh, start, [&](HalfedgeHandle h) { return visited[h.idx()] != 0; },
        [&](HalfedgeHandle h) { visited[h.idx()] = 1; });
    if (hole)
      result.holes.push_back(std::move(*hole));
    else
      ++result.corrupt_fans;
  }
  finish_search(mesh, result.holes, std::vector<char>(result.holes.size(), 1), options);
  return result;
}

bool update_holes(const Mesh& mesh, HoleSearchResult& result, std::span<const VertexHandle> touched,
                  const HoleSearchOptions& options) {
  if (result.corrupt_fans > 0) return false;  // which loops the corrupt walks hid is unknown
  LocalSet touched_set(2 * touched.size() + 16);
  for (const VertexHandle v : touched)
    if (v.is_valid() && static_cast<std::size_t>(v.idx()) < mesh.n_vertices())
      touched_set.insert(v.idx());
  // Every loop the edit made or changed has a boundary halfedge an added or deleted face
  // bordered, or a corner whose fans it changed: it leaves a touched vertex. A kept loop passes
  // no touched vertex, so none of these walks enters one.
  std::vector<Hole> traced;
  LocalSet walked(64);
  for (const VertexHandle v : touched) {
    if (!v.is_valid() || static_cast<std::size_t>(v.idx()) >= mesh.n_vertices() ||
        mesh.status(v).deleted())
      continue;
    for (const HalfedgeHandle start : mesh.voh_range(v)) {
      if (!mesh.is_boundary(start) || walked.contains(start.idx())) continue;
      std::optional<Hole> hole = walk_loop(
          mesh, start, [&](HalfedgeHandle h) { return walked.contains(h.idx()); },
          [&](HalfedgeHandle h) { walked.insert(h.idx()); });
      if (!hole) return false;
      // Started where find_holes starts it, at its halfedge of lowest index (the first its scan
      // meets): a fill depends on where its loop starts.
      const auto first =
          std::min_element(hole->halfedges.begin(), hole->halfedges.end(),
                           [](HalfedgeHandle a, HalfedgeHandle b) { return a.idx() < b.idx(); });
      const auto shift = first - hole->halfedges.begin();
      std::rotate(hole->halfedges.begin(), first, hole->halfedges.end());
      std::rotate(hole->loop.begin(), hole->loop.begin() + shift, hole->loop.end());
      traced.push_back(std::move(*hole));
    }
  }
  std::vector<Hole> holes;
  holes.reserve(result.holes.size() + traced.size());
  for (Hole& hole : result.holes)
    if (std::none_of(hole.loop.begin(), hole.loop.end(),
                     [&](VertexHandle v) { return touched_set.contains(v.idx()); }))
      holes.push_back(std::move(hole));
  std::vector<char> fresh(holes.size(), 0);
  for (Hole& hole : traced) holes.push_back(std::move(hole));
  fresh.resize(holes.size(), 1);
  finish_search(mesh, holes, fresh, options);
  result.holes = std::move(holes);
  return true;
}

std::optional<std::size_t> find_hole_by_id(const std::vector<Hole>& holes, std::uint32_t id) {
  for (std::size_t i = 0; i < holes.size(); ++i)
    if (holes[i].id == id) return i;
  return std::nullopt;
}

std::optional<NearestHole> find_nearest_hole(const Mesh& mesh, const std::vector<Hole>& holes,
                                             const Vec3& point) {
  std::optional<NearestHole> best;
  for (std::size_t i = 0; i < holes.size(); ++i) {
    const Hole& hole = holes[i];
    for (std::size_t k = 0; k < hole.loop.size(); ++k) {
      const Vec3 a = mesh.point(hole.loop[k]);
      const Vec3 b = mesh.point(hole.loop[(k + 1) % hole.loop.size()]);
      const Vec3 ab = b - a;
      const double len2 = ab.sqrnorm();
      const double t = len2 > 0 ? std::clamp(OpenMesh::dot(point - a, ab) / len2, 0.0, 1.0) : 0.0;
      const double d = (a + t * ab - point).norm();
      if (!best || d < best->distance) best = NearestHole{i, d};
    }
  }
  return best;
}

}  // namespace touchmend::geometry
