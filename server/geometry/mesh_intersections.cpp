#include "server/geometry/mesh_intersections.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <optional>

#include "server/geometry/bvh.h"
#include "server/geometry/intersection.h"
#include "server/geometry/local_map.h"
#include "server/geometry/projection.h"

namespace touchmend::geometry {
namespace {

//! The face of outgoing halfedge \p h (corners from(h), to(h), to(next(h)), in the face's
//! order) into \p t and \p ids, if from(h) is its corner of lowest index inside \p box: the
//! vertex scans meet every face once per corner inside the box and handle it at that one only,
//! with no set of faces seen. False for a boundary halfedge.
bool face_from_lowest_inside(const Mesh& mesh, HalfedgeHandle h, const Box3& box, TrianglePoints& t,
                             std::array<int, 3>& ids) {
  if (mesh.is_boundary(h)) return false;
  const VertexHandle a = mesh.from_vertex_handle(h), b = mesh.to_vertex_handle(h),
                     c = mesh.to_vertex_handle(mesh.next_halfedge_handle(h));
  t = {mesh.point(a), mesh.point(b), mesh.point(c)};
  ids = {a.idx(), b.idx(), c.idx()};
  const auto inside = [&](const Vec3& p) {
    return box.contains(Eigen::Vector3d(p[0], p[1], p[2]));
  };
  if (b.idx() < a.idx() && inside(t[1])) return false;
  if (c.idx() < a.idx() && inside(t[2])) return false;
  return true;
}

//! Squared length of the longest edge of \p t: the one measure SearchReach's "long" rests on
//! (the scans and the lists must agree on which faces are long).
double longest_sqr_edge(const TrianglePoints& t) {
  return std::max({(t[1] - t[0]).sqrnorm(), (t[2] - t[1]).sqrnorm(), (t[0] - t[2]).sqrnorm()});
}

VertexGrid file_vertices(const Mesh& mesh, double cell, std::size_t below);

//! Whether the grid, once filed, would serve a search of \p box (it covers at most a sixteenth
//! as many cells as there are vertices; the cells are at least the reach wide, so this count
//! is an upper bound of the filed grid's).
bool grid_would_serve(const Box3& box, const SearchReach& reach) {
  double covered = 1;
  for (int k = 0; k < 3; ++k) {
    const double extent = (box.max()[k] - box.min()[k]) / reach.longest_edge;
    if (!(extent >= 0)) return false;  // empty or NaN
    covered *= std::floor(extent) + 2;
  }
  return covered <= static_cast<double>(reach.grid_below) / 16;
}

//! Calls visit(vertex, point) for every non-deleted vertex that may lie in \p box (at least
//! those that do), in increasing index order, until it returns false: through the grid's cells
//! when the reach has a grid and the box covers few of them, else over the runs of vertices
//! whose boxes meet it. The order is a scan's either way, so a search finds the same things in
//! the same order with or without the grid or the runs (the fills' first crossing found, and so
//! every fill, do not depend on when or whether the grid was filed).
template <typename Visit>
void for_each_vertex_near(const Mesh& mesh, const Box3& box, const SearchReach& reach,
                          Visit&& visit) {
  // The point and status arrays directly: mesh.vertices() and mesh.status() look the status
  // property up for every vertex, several times the cost of the box test.
  const Vec3* points = mesh.points();
  const auto& status = mesh.property(mesh.vertex_status_pph()).data_vector();
  const std::size_t n_vertices = mesh.n_vertices();
  // Visits [first, last) in order; false when visit stopped.
  const auto scan_range = [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      if (status[i].deleted()) continue;
      const Vec3& p = points[i];
      if (!visit(VertexHandle(static_cast<int>(i)), Eigen::Vector3d(p[0], p[1], p[2])))
        return false;
    }
    return true;
  };
  // Every vertex from \p first on, passing over the runs whose boxes miss \p box; returns how
  // many points and runs' boxes it read. Right after a mesh is built its arrays are out of cache,
  // and a full scan was most of a search: the rocker arm's crease patch reads 37 of 313 runs.
  const auto scan_from = [&](std::size_t first) {
    constexpr std::size_t kBlock = SearchReach::kVertexBlock;
    const std::size_t blocked =
        std::min({reach.blocks_below, n_vertices, reach.block_boxes.size() * kBlock});
    std::size_t read = 0;
    std::size_t i = first;
    while (i < blocked) {
      const std::size_t from = i;
      i = std::min((from / kBlock + 1) * kBlock, blocked);
      ++read;  // the run's box, about a point's test
      if (!reach.block_boxes[from / kBlock].intersects(box)) {
#ifndef NDEBUG
        // The rule the runs rest on (SearchReach::block_boxes): no vertex moved into the box
        // since the reach was made.
        for (std::size_t k = from; k < i; ++k) {
          const Vec3& p = points[k];
          assert(status[k].deleted() || !box.contains(Eigen::Vector3d(p[0], p[1], p[2])));
        }
#endif
        continue;
      }
      read += i - from;
      if (!scan_range(from, i)) return read;
    }
    read += n_vertices - std::min(i, n_vertices);
    scan_range(i, n_vertices);
    return read;
  };
  VertexGrid& grid = reach.grid;
  const bool count_scan = grid.empty() && reach.grid_below > 0 && grid_would_serve(box, reach);
  if (count_scan && reach.scanned >= SearchReach::kScansBeforeFiling * reach.grid_below) {
    grid = file_vertices(mesh, reach.longest_edge, reach.grid_below);
    if (grid.empty()) reach.scanned = 0;  // nothing to file (all deleted): scan on
  }
  if (grid.empty()) {
    const std::size_t read = scan_from(0);
    if (count_scan) reach.scanned += read;
    return;
  }
  const Eigen::Vector3i lo = grid.cell_of(box.min()).cwiseMax(0);
  const Eigen::Vector3i hi = grid.cell_of(box.max()).cwiseMin(grid.cells - Eigen::Vector3i::Ones());
  double covered = 1;
  for (int k = 0; k < 3; ++k) covered *= std::max(0, hi[k] - lo[k] + 1);
  // A scan reads the points in order; the cells are read out of order, each vertex at a cache
  // miss. Measured on the subdivided sphere (237k vertices): past a sixteenth of the vertices
  // in cells the scan is faster.
  if (covered > static_cast<double>(grid.filed.size()) / 16) {
    scan_from(0);
    return;
  }
  // The filed vertices in the covered cells, then in index order (the scan's), then those added
  // since the filing (all of higher index).
  std::vector<std::uint32_t> found;
  if (covered > 0) {
    Eigen::Vector3i c;
    for (c.z() = lo.z(); c.z() <= hi.z(); ++c.z())
      for (c.y() = lo.y(); c.y() <= hi.y(); ++c.y())
        for (c.x() = lo.x(); c.x() <= hi.x(); ++c.x()) {
          const std::size_t bucket = grid.bucket_of(c);
          for (std::uint32_t k = grid.bucket_start[bucket]; k < grid.bucket_start[bucket + 1];
               ++k) {
            const std::uint32_t i = grid.filed[k];
            if (status[i].deleted()) continue;
            const Vec3& p = points[i];
            // Other cells share the bucket: each vertex is taken at its own cell only.
            if (grid.cell_of(Eigen::Vector3d(p[0], p[1], p[2])) == c) found.push_back(i);
          }
        }
  }
  std::sort(found.begin(), found.end());
  for (const std::uint32_t i : found) {
    const Vec3& p = points[i];
    if (!visit(VertexHandle(static_cast<int>(i)), Eigen::Vector3d(p[0], p[1], p[2]))) return;
  }
  scan_from(grid.filed_below);
}

//! Calls visit(face, triangle, corner ids) once for every non-deleted face that may meet \p box:
//! those with a corner within the reach's longest edge of it (only at points that pass
//! \p keep_point, a cheaper test the caller may narrow the search with), and the reach's long
//! faces whose boxes meet it. The callers test the boxes themselves.
template <typename KeepPoint, typename Visit>
void for_each_face_near(const Mesh& mesh, const Box3& box, const SearchReach& reach,
                        KeepPoint&& keep_point, Visit&& visit) {
  Box3 grown = box;
  grown.min().array() -= reach.longest_edge;
  grown.max().array() += reach.longest_edge;
  const double reach_sqr = reach.longest_edge * reach.longest_edge;
  bool stopped = false;
  for_each_vertex_near(mesh, grown, reach, [&](VertexHandle v, const Eigen::Vector3d& q) {
    if (!grown.contains(q) || !keep_point(q)) return true;
    for (const HalfedgeHandle h : mesh.voh_range(v)) {
      TrianglePoints t;
      std::array<int, 3> ids;
      if (!face_from_lowest_inside(mesh, h, grown, t, ids)) continue;
      if (longest_sqr_edge(t) > reach_sqr) continue;  // a long face: visited below
      if (!visit(mesh.face_handle(h), t, ids)) {
        stopped = true;
        return false;
      }
    }
    return true;
  });
  if (stopped) return;
  for (std::size_t i = 0; i < reach.long_faces.size(); ++i) {
    const FaceHandle g = reach.long_faces[i];
    if (!reach.long_boxes[i].intersects(box) || !g.is_valid() ||
        static_cast<std::size_t>(g.idx()) >= mesh.n_faces() || mesh.status(g).deleted())
      continue;
    TrianglePoints t;
    std::array<int, 3> ids;
    face_corners(mesh, g, t, ids);
    // A listed face that a move made short again was visited through its corners above.
    if (longest_sqr_edge(t) <= reach_sqr) continue;
    if (!visit(g, t, ids)) return;
  }
}

}  // namespace

Eigen::Vector3i VertexGrid::cell_of(const Eigen::Vector3d& q) const {
  Eigen::Vector3i c;
  for (int k = 0; k < 3; ++k) {
    // Clamped before the conversion, so a point far outside (or NaN) cannot overflow it.
    const double d = std::floor((q[k] - origin[k]) / cell);
    c[k] = !(d > -1) ? -1 : d >= cells[k] ? cells[k] : static_cast<int>(d);
  }
  return c;
}

std::size_t VertexGrid::bucket_of(const Eigen::Vector3i& c) const {
  const auto h = static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.x())) * 73856093u ^
                 static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.y())) * 19349663u ^
                 static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.z())) * 83492791u;
  return static_cast<std::size_t>((h ^ (h >> 29)) & (bucket_start.size() - 2));
}

void SearchReach::add(const Mesh& mesh, std::span<const FaceHandle> faces) {
  const double reach_sqr = longest_edge * longest_edge;
  for (const FaceHandle f : faces) {
    TrianglePoints t;
    std::array<int, 3> ids;
    face_corners(mesh, f, t, ids);
    if (longest_sqr_edge(t) > reach_sqr) {
      long_faces.push_back(f);
      long_boxes.push_back(triangle_box(t));
    }
  }
}

void SearchReach::note_moved(const Mesh& mesh, VertexHandle v) {
  if (!v.is_valid()) return;
  const auto i = static_cast<std::size_t>(v.idx());
  if (i < blocks_below && i / kVertexBlock < block_boxes.size()) {
    const Vec3& p = mesh.point(v);
    block_boxes[i / kVertexBlock].extend(Eigen::Vector3d(p[0], p[1], p[2]));
  }
  if (i < grid_below && !grid.empty()) {
    grid = VertexGrid{};
    scanned = 0;
  }
  // A face the move stretched past the reach is found through its corners no more, and a face
  // long before it is listed with the box it had (a search would miss it where it has moved to):
  // the faces around the vertex are reshaped ones.
  const std::vector<FaceHandle> around(mesh.vf_range(v).begin(), mesh.vf_range(v).end());
  note_reshaped(mesh, around);
}

void SearchReach::note_reshaped(const Mesh& mesh, std::span<const FaceHandle> faces) {
  const double reach_sqr = longest_edge * longest_edge;
  std::vector<std::pair<FaceHandle, Box3>> long_now;
  for (const FaceHandle f : faces) {
    if (!f.is_valid() || mesh.status(f).deleted()) continue;
    TrianglePoints t;
    std::array<int, 3> ids;
    face_corners(mesh, f, t, ids);
    // A listed face that is short now keeps its old box: the searches visit it through its
    // corners and pass over it on the list.
    if (longest_sqr_edge(t) > reach_sqr) long_now.emplace_back(f, triangle_box(t));
  }
  if (long_now.empty()) return;
  LocalMap<std::size_t> position(2 * long_faces.size() + 16);
  for (std::size_t i = 0; i < long_faces.size(); ++i) position[long_faces[i].idx()] = i;
  for (const auto& [f, box] : long_now) {
    if (const std::size_t* i = position.find(f.idx())) {
      long_boxes[*i] = box;
    } else {
      position[f.idx()] = long_faces.size();
      long_faces.push_back(f);
      long_boxes.push_back(box);
    }
  }
}

void SearchReach::box_new_vertices(const Mesh& mesh) {
  const std::size_t n = mesh.n_vertices();
  if (n <= blocks_below) return;
  const Vec3* points = mesh.points();
  const auto& status = mesh.property(mesh.vertex_status_pph()).data_vector();
  // New boxes are empty (Eigen's default box); the run that held the last vertices boxed before
  // grows. Each run's box is gathered in locals, one pass over the points.
  const std::size_t first = blocks_below / kVertexBlock;
  block_boxes.resize((n + kVertexBlock - 1) / kVertexBlock);
  for (std::size_t b = first; b < block_boxes.size(); ++b) {
    Eigen::Array3d lo = Eigen::Array3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Array3d hi = -lo;
    if (b == first && blocks_below % kVertexBlock != 0) {
      lo = block_boxes[b].min().array();
      hi = block_boxes[b].max().array();
    }
    const std::size_t end = std::min(n, (b + 1) * kVertexBlock);
    for (std::size_t v = std::max(b * kVertexBlock, blocks_below); v < end; ++v) {
      if (status[v].deleted()) continue;
      const Eigen::Array3d p(points[v][0], points[v][1], points[v][2]);
      lo = lo.min(p);
      hi = hi.max(p);
    }
    block_boxes[b] = Box3(lo.matrix(), hi.matrix());
  }
  blocks_below = n;
}

void SearchReach::cut_back(std::size_t n_vertices, std::size_t n_faces) {
  if (blocks_below > n_vertices) {
    // The run that holds the last kept vertex keeps its box (it may be larger than its vertices
    // now need); box_new_vertices grows it when new vertices fill the run again.
    blocks_below = n_vertices;
    block_boxes.resize((n_vertices + kVertexBlock - 1) / kVertexBlock);
  }
  if (grid_below > n_vertices) {
    grid_below = n_vertices;
    grid = VertexGrid{};
    scanned = 0;
  }
  std::size_t kept = 0;
  for (std::size_t i = 0; i < long_faces.size(); ++i) {
    if (static_cast<std::size_t>(long_faces[i].idx()) >= n_faces) continue;
    long_faces[kept] = long_faces[i];
    long_boxes[kept] = long_boxes[i];
    ++kept;
  }
  long_faces.resize(kept);
  long_boxes.resize(kept);
}

namespace {

//! The grid of \p mesh's vertices below index \p below with cells of (about) \p cell: one
//! counting sort by bucket.
VertexGrid file_vertices(const Mesh& mesh, double cell, std::size_t below) {
  VertexGrid grid;
  const std::size_t n = std::min(below, mesh.n_vertices());
  const Vec3* points = mesh.points();
  const auto& status = mesh.property(mesh.vertex_status_pph()).data_vector();
  const auto live = [&](std::size_t i) { return !status[i].deleted(); };
  Box3 bounds;
  for (std::size_t i = 0; i < n; ++i)
    if (live(i)) bounds.extend(Eigen::Vector3d(points[i][0], points[i][1], points[i][2]));
  if (bounds.isEmpty() || !(cell > 0)) return grid;
  // At most 2^20 cells along an axis (the cell coordinates stay far from int's range).
  grid.cell = std::max(cell, bounds.sizes().maxCoeff() / double(1 << 20));
  grid.origin = bounds.min();
  for (int k = 0; k < 3; ++k)
    grid.cells[k] =
        static_cast<int>(std::floor((bounds.max()[k] - grid.origin[k]) / grid.cell)) + 1;
  // A cell a few edges wide holds about ten vertices of a surface: a bucket per eight vertices
  // keeps the buckets about one cell each and their counts in cache while filing.
  std::size_t buckets = 1;
  while (8 * buckets < n) buckets *= 2;
  grid.bucket_start.assign(buckets + 1, 0);
  constexpr std::uint32_t kNone = ~std::uint32_t{0};
  std::vector<std::uint32_t> bucket(n, kNone);
  for (std::size_t i = 0; i < n; ++i) {
    if (!live(i)) continue;
    const Vec3& p = points[i];
    const auto b =
        static_cast<std::uint32_t>(grid.bucket_of(grid.cell_of(Eigen::Vector3d(p[0], p[1], p[2]))));
    bucket[i] = b;
    ++grid.bucket_start[b + 1];
  }
  for (std::size_t b = 0; b < buckets; ++b) grid.bucket_start[b + 1] += grid.bucket_start[b];
  grid.filed.resize(grid.bucket_start[buckets]);
  std::vector<std::uint32_t> next(grid.bucket_start.begin(), grid.bucket_start.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    if (bucket[i] != kNone) grid.filed[next[bucket[i]]++] = static_cast<std::uint32_t>(i);
  grid.filed_below = n;
  return grid;
}

}  // namespace

SearchReach make_search_reach(const Mesh& mesh, bool with_grid) {
  // Cost of a search: the points within longest_edge of its box, plus one box test per long
  // face. A few times the median edge keeps the first small on every mesh measured; on a
  // uniformly meshed surface nothing is listed (3x the median is above the longest edge).
  constexpr double kMedianFactor = 3.0;
  const std::size_t n_edges = mesh.n_edges();
  const Vec3* points = mesh.points();
  const auto& edge_status = mesh.property(mesh.edge_status_pph()).data_vector();
  // The arrays are read directly (an edge's halfedges are 2e and 2e + 1, each holding the
  // vertex it points to): the handle iterator looks the status property up per edge.
  const auto sqr_length = [&](std::size_t i) {
    const int a = mesh.to_vertex_handle(HalfedgeHandle(static_cast<int>(2 * i))).idx();
    const int b = mesh.to_vertex_handle(HalfedgeHandle(static_cast<int>(2 * i + 1))).idx();
    return (points[a] - points[b]).sqrnorm();
  };
  // The median from a sample of about a thousand edges, evenly spread over the edge array, is
  // as good a scale as the exact one (the fills were the same with 4,096) at a fraction of the
  // cost: reading the sampled edges out of cache and selecting the median were half of a small
  // mesh's preparation (the hand's 35 -> 19 us, the rocker arm's 186 -> 155).
  constexpr std::size_t kSampled = 1024;
  const std::size_t stride = std::max<std::size_t>(1, n_edges / kSampled);
  std::vector<double> sample;
  sample.reserve(n_edges / stride + 1);
  for (std::size_t i = 0; i < n_edges; i += stride)
    if (!edge_status[i].deleted()) sample.push_back(sqr_length(i));
  SearchReach reach;
  if (sample.empty()) return reach;
  const auto middle = sample.begin() + static_cast<std::ptrdiff_t>(sample.size() / 2);
  std::nth_element(sample.begin(), middle, sample.end());
  reach.longest_edge = kMedianFactor * std::sqrt(*middle);
  // One pass over the edges: the longest, and those longer than the reach ("longer" compares
  // squares, as the searches do), whose faces are listed in index order.
  double reach_sqr = reach.longest_edge * reach.longest_edge;
  double max_sqr = 0;
  std::vector<char> long_face;  // by face index, made at the first long edge
  for (std::size_t i = 0; i < n_edges; ++i) {
    if (edge_status[i].deleted()) continue;
    const double sqr = sqr_length(i);
    max_sqr = std::max(max_sqr, sqr);
    if (!(sqr > reach_sqr)) continue;
    if (long_face.empty()) long_face.assign(mesh.n_faces(), 0);
    for (int side = 0; side < 2; ++side)
      if (const FaceHandle f = mesh.face_handle(HalfedgeHandle(static_cast<int>(2 * i + side)));
          f.is_valid())
        long_face[static_cast<std::size_t>(f.idx())] = 1;
  }
  if (long_face.empty()) {
    // No edge is longer: the reach shrinks to the longest edge (rounded up, so that edge is
    // not longer than it either).
    reach.longest_edge = std::sqrt(max_sqr);
    while (reach.longest_edge * reach.longest_edge < max_sqr)
      reach.longest_edge = std::nextafter(reach.longest_edge, 2 * reach.longest_edge + 1);
    reach_sqr = reach.longest_edge * reach.longest_edge;
  }
  for (std::size_t i = 0; i < long_face.size(); ++i) {
    if (!long_face[i]) continue;
    const FaceHandle f(static_cast<int>(i));
    TrianglePoints t;
    std::array<int, 3> ids;
    face_corners(mesh, f, t, ids);
    reach.long_faces.push_back(f);
    reach.long_boxes.push_back(triangle_box(t));
  }
  // The boxes of the runs of vertices (SearchReach::block_boxes): one more pass, over the
  // points only (the edge pass above has just read them all). Taking them from the edge pass's
  // two points per edge cost more (six box updates per edge; rocker arm 0.18 -> 0.23 ms).
  reach.box_new_vertices(mesh);  // every vertex is new to it
  // A scan of a few thousand points costs less than filing them (the round trip of the
  // interactive fill is measured on such a mesh); on larger meshes the searches file them once
  // they have scanned as much as the filing costs (for_each_vertex_near).
  constexpr std::size_t kGridFrom = 8192;
  if (with_grid && mesh.n_vertices() >= kGridFrom) reach.grid_below = mesh.n_vertices();
  return reach;
}

double max_edge_length(const Mesh& mesh) {
  double longest = 0;
  for (const EdgeHandle e : mesh.edges()) longest = std::max(longest, mesh.calc_edge_sqr_length(e));
  return std::sqrt(longest);
}

std::vector<FaceHandle> faces_in_box(const Mesh& mesh, const Box3& box, double longest_edge) {
  SearchReach reach;
  reach.longest_edge = longest_edge;
  return faces_in_box(mesh, box, reach);
}

std::vector<FaceHandle> faces_in_box(const Mesh& mesh, const Box3& box, const SearchReach& reach) {
  std::vector<FaceHandle> out;
  for_each_face_near(
      mesh, box, reach, [](const Eigen::Vector3d&) { return true; },
      [&](FaceHandle f, const TrianglePoints& t, const std::array<int, 3>&) {
        if (triangle_box(t).intersects(box)) out.push_back(f);
        return true;
      });
  return out;
}

namespace {

//! The chosen faces against every face near them: one scan of the points within the longest
//! edge of the chosen faces' box (every face meeting the box has a corner there), each nearby
//! face's box looked up in a tree of the chosen triangles. The chosen set is usually a patch,
//! small next to the mesh, so the tree is built over it, not over the neighbourhood.
//! \p skip_within(i, j): whether chosen faces i and j need no test against each other.
template <typename SkipWithin>
std::vector<std::pair<FaceHandle, FaceHandle>> intersections_of(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::size_t stop_after,
    const SearchReach& reach, bool test_within, SkipWithin&& skip_within) {
  std::vector<std::pair<FaceHandle, FaceHandle>> out;
  if (faces.empty()) return out;
  std::vector<TrianglePoints> triangles(faces.size());
  std::vector<PreparedTriangle> prepared(faces.size());
  LocalSet chosen(faces.size() + 16);
  Box3 region;
  for (std::size_t i = 0; i < faces.size(); ++i) {
    chosen.insert(faces[i].idx());
    std::array<int, 3> ids;
    face_corners(mesh, faces[i], triangles[i], ids);
    prepared[i] = prepare_triangle(triangles[i], ids);
    region.extend(triangle_box(triangles[i]));
  }
  const double pad = 1e-9 * std::max(region.diagonal().norm(), 1e-300);
  region.min().array() -= pad;
  region.max().array() += pad;
  const TriangleBvh tree(triangles);
  const auto full = [&] { return stop_after != 0 && out.size() >= stop_after; };
  // Against the rest of the mesh. A face near the patch has every corner within the longest
  // edge of some patch triangle's box: a point farther from all of them (most of a large box
  // around a curved patch) is passed over without reading its faces.
  const double reach_edge = reach.longest_edge;
  for_each_face_near(
      mesh, region, reach,
      [&](const Eigen::Vector3d& q) {
        return tree.overlaps_any(Box3(q.array() - reach_edge, q.array() + reach_edge));
      },
      [&](FaceHandle g, const TrianglePoints& t, const std::array<int, 3>& g_ids) {
        if (chosen.contains(g.idx())) return true;
        const Box3 box = triangle_box(t);
        if (!box.intersects(region)) return true;
        std::optional<PreparedTriangle> other;  // worked out at its first candidate
        tree.query_box(box, [&](std::uint32_t c) {
          if (full()) return;
          if (!other) other = prepare_triangle(t, g_ids);
          if (triangles_intersect(prepared[c], *other)) out.emplace_back(faces[c], g);
        });
        return !full();
      });
  if (!test_within || full()) return out;
  // Among the chosen faces themselves, each pair once.
  for (std::size_t i = 0; i < faces.size() && !full(); ++i)
    tree.query_box(triangle_box(triangles[i]), [&](std::uint32_t j) {
      if (full() || j <= i || skip_within(i, j)) return;
      if (triangles_intersect(prepared[i], prepared[j])) out.emplace_back(faces[i], faces[j]);
    });
  return out;
}

std::vector<std::pair<FaceHandle, FaceHandle>> intersections_of(const Mesh& mesh,
                                                                std::span<const FaceHandle> faces,
                                                                std::size_t stop_after,
                                                                const SearchReach& reach,
                                                                bool test_within) {
  return intersections_of(mesh, faces, stop_after, reach, test_within,
                          [](std::size_t, std::size_t) { return false; });
}

}  // namespace

std::vector<std::size_t> triangles_crossing_mesh(const Mesh& mesh,
                                                 std::span<const TrianglePoints> triangles,
                                                 std::span<const std::array<int, 3>> ids,
                                                 const SearchReach& reach) {
  std::vector<std::size_t> out;
  if (triangles.empty()) return out;
  Box3 region;
  for (const TrianglePoints& t : triangles) region.extend(triangle_box(t));
  const TriangleBvh tree(std::vector<TrianglePoints>(triangles.begin(), triangles.end()));
  std::vector<char> crossing(triangles.size(), 0);
  // Each triangle prepared once, each face near them at its first candidate (the same tests as
  // triangles_intersect on the points; preparing both for every pair was half of a complex
  // hole's 3D triangulation, hand_sml #2).
  std::vector<std::optional<PreparedTriangle>> prepared(triangles.size());
  const double reach_edge = reach.longest_edge;
  for_each_face_near(
      mesh, region, reach,
      [&](const Eigen::Vector3d& q) {
        return tree.overlaps_any(Box3(q.array() - reach_edge, q.array() + reach_edge));
      },
      [&](FaceHandle, const TrianglePoints& t, const std::array<int, 3>& g_ids) {
        std::optional<PreparedTriangle> face;
        tree.query_box(triangle_box(t), [&](std::uint32_t c) {
          if (crossing[c]) return;
          if (!prepared[c]) prepared[c] = prepare_triangle(triangles[c], ids[c]);
          if (!face) face = prepare_triangle(t, g_ids);
          if (triangles_intersect(*prepared[c], *face)) crossing[c] = 1;
        });
        return true;
      });
  for (std::size_t c = 0; c < triangles.size(); ++c)
    if (crossing[c]) out.push_back(c);
  return out;
}

namespace {
SearchReach reach_of(const Mesh& mesh, double longest_edge) {
  if (!(longest_edge > 0)) return make_search_reach(mesh, false);
  SearchReach reach;
  reach.longest_edge = longest_edge;
  return reach;
}
}  // namespace

std::vector<std::pair<FaceHandle, FaceHandle>> find_face_intersections(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::size_t stop_after,
    double longest_edge) {
  return intersections_of(mesh, faces, stop_after, reach_of(mesh, longest_edge), true);
}

std::vector<std::pair<FaceHandle, FaceHandle>> find_face_intersections(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::size_t stop_after,
    const SearchReach& reach) {
  return intersections_of(mesh, faces, stop_after, reach, true);
}

std::vector<std::pair<FaceHandle, FaceHandle>> find_intersections_with_rest(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::size_t stop_after,
    double longest_edge) {
  return intersections_of(mesh, faces, stop_after, reach_of(mesh, longest_edge), false);
}

std::vector<std::pair<FaceHandle, FaceHandle>> find_intersections_with_rest(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::size_t stop_after,
    const SearchReach& reach) {
  return intersections_of(mesh, faces, stop_after, reach, false);
}

bool projects_injectively(const Mesh& mesh, std::span<const FaceHandle> faces,
                          const ReferenceFrame& frame) {
  // Degree argument: when the patch is a disk whose boundary projects onto a simple polygon,
  // the number of patch triangles covering a generic point of the plane, each counted with
  // the sign of its projected orientation, is the boundary's winding number there (0 or 1).
  // With every triangle of one strict sign no point is covered twice, so the patch is the
  // graph of a function over the polygon and no two of its triangles can meet in 3D beyond
  // their shared edges and vertices.
  double scale = 0;
  std::vector<std::array<Point2, 3>> projected;
  projected.reserve(faces.size());
  for (const FaceHandle f : faces) {
    std::array<Point2, 3> t;
    int k = 0;
    for (const VertexHandle v : mesh.fv_range(f))
      t[static_cast<std::size_t>(k++)] = frame.project(mesh.point(v));
    for (const Point2& p : t) scale = std::max({scale, std::abs(p.x()), std::abs(p.y())});
    projected.push_back(t);
  }
  const double min_area = 1e-12 * scale * scale;
  int sign = 0;
  for (const auto& t : projected) {
    const double a = orient2d(t[0], t[1], t[2]);
    if (std::abs(a) <= min_area || !std::isfinite(a)) return false;
    const int s = a > 0 ? 1 : -1;
    if (sign == 0) sign = s;
    if (s != sign) return false;
  }
  return true;
}

bool disk_projects_injectively(const Mesh& mesh, std::span<const FaceHandle> faces) {
  if (faces.empty()) return false;
  LocalSet members(2 * faces.size() + 16);
  for (const FaceHandle f : faces) members.insert(f.idx());
  // The boundary: halfedges of the faces whose opposite lies outside them, by start vertex.
  LocalMap<int> next_of(4 * faces.size() + 16);  // start vertex -> end vertex
  Vec3 normal(0, 0, 0);
  std::size_t boundary_edges = 0;
  int first = -1;
  for (const FaceHandle f : faces) {
    TrianglePoints t;
    std::array<int, 3> ids;
    face_corners(mesh, f, t, ids);
    normal += OpenMesh::cross(t[1] - t[0], t[2] - t[0]);
    for (const HalfedgeHandle h : mesh.fh_range(f)) {
      const FaceHandle across = mesh.opposite_face_handle(h);
      if (across.is_valid() && members.contains(across.idx())) continue;
      const int from = mesh.from_vertex_handle(h).idx();
      if (next_of.find(from)) return false;  // the loop passes a vertex twice
      next_of[from] = mesh.to_vertex_handle(h).idx();
      ++boundary_edges;
      first = from;
    }
  }
  if (boundary_edges < 3 || !(normal.norm() > 0)) return false;
  // One loop through every boundary edge.
  std::vector<Vec3> loop;
  loop.reserve(boundary_edges);
  int v = first;
  do {
    loop.push_back(mesh.point(VertexHandle(v)));
    const int* next = next_of.find(v);
    if (!next || loop.size() > boundary_edges) return false;
    v = *next;
  } while (v != first);
  if (loop.size() != boundary_edges) return false;
  const ReferenceFrame frame = ReferenceFrame::from_normal(normal.normalized(), loop.front());
  std::vector<Point2> polygon;
  polygon.reserve(loop.size());
  for (const Vec3& p : loop) polygon.push_back(frame.project(p));
  if (count_self_intersections(polygon) != 0) return false;
  return projects_injectively(mesh, faces, frame);
}

std::vector<std::pair<FaceHandle, FaceHandle>> find_intersections_between_groups(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::span<const int> group,
    std::span<const char> embedded, std::size_t stop_after, const SearchReach& reach) {
  const auto same_embedded_group = [&](std::size_t i, std::size_t j) {
    if (i >= group.size() || j >= group.size() || group[i] != group[j] || group[i] < 0)
      return false;
    const auto g = static_cast<std::size_t>(group[i]);
    return g < embedded.size() && embedded[g] != 0;
  };
  return intersections_of(mesh, faces, stop_after, reach, true, same_embedded_group);
}

std::vector<std::pair<FaceHandle, FaceHandle>> find_self_intersections(const Mesh& mesh,
                                                                       std::size_t stop_after) {
  std::vector<FaceHandle> all(mesh.faces().begin(), mesh.faces().end());
  return find_face_intersections(mesh, all, stop_after);
}

}  // namespace touchmend::geometry
