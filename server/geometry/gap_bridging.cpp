#include "server/geometry/gap_bridging.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <set>

#include <fmt/format.h>

#include "server/geometry/holes.h"
#include "server/geometry/intersection.h"
#include "server/geometry/mesh_intersections.h"

namespace touchmend::geometry {
namespace {

//! \p options with a search reach: the caller's, or one made for \p mesh into \p own (which
//! must outlive the returned options).
StitchOptions with_reach(const Mesh& mesh, StitchOptions options, std::optional<SearchReach>& own) {
  if (!options.reach) {
    own = make_search_reach(mesh);
    options.reach = &*own;
  }
  return options;
}

StitchResult refuse(std::string why) {
  StitchResult r;
  r.reason = std::move(why);
  return r;
}

Vec3 vertex_normal(const Mesh& mesh, VertexHandle v) {
  Vec3 sum(0, 0, 0);
  for (const FaceHandle f : mesh.vf_range(v)) sum += mesh.calc_face_normal(f);
  const double len = sum.norm();
  return len > 0 ? sum / len : sum;
}

}  // namespace

StitchResult stitch_triangle(Mesh& mesh, VertexHandle a, VertexHandle b, VertexHandle t,
                             const StitchOptions& options) {
  const auto valid = [&](VertexHandle v) {
    return v.is_valid() && static_cast<std::size_t>(v.idx()) < mesh.n_vertices() &&
           !mesh.status(v).deleted();
  };
  if (!valid(a) || !valid(b) || !valid(t)) return refuse("a vertex does not exist");
  if (t == a || t == b || a == b) return refuse("the three vertices must be different");
  // The boundary edge and its free direction: the new face takes the direction no face uses,
  // so it is oriented like the face it joins (ALGORITHMS.md §4.1).
  HalfedgeHandle free;
  for (const HalfedgeHandle h : {mesh.find_halfedge(a, b), mesh.find_halfedge(b, a)}) {
    if (h.is_valid() && mesh.is_boundary(h) && !mesh.is_boundary(mesh.opposite_halfedge_handle(h)))
      free = h;
  }
  if (!free.is_valid())
    return refuse(fmt::format("{}-{} is not a boundary edge of the mesh", a.idx(), b.idx()));
  if (!mesh.is_boundary(t))
    return refuse(
        fmt::format("vertex {} is not on a boundary (stitches end on a boundary vertex)", t.idx()));
  const VertexHandle from = mesh.from_vertex_handle(free), to = mesh.to_vertex_handle(free);
  // The other two edges must be new, or boundary edges used in their free direction.
  for (const auto& [x, y] : {std::pair{to, t}, std::pair{t, from}}) {
    const HalfedgeHandle h = mesh.find_halfedge(x, y);
    if (h.is_valid() && !mesh.is_boundary(h))
      return refuse(
          fmt::format("edge {}-{} already has a face on this side: the result would be "
                      "non-manifold",
                      x.idx(), y.idx()));
  }
  const Vec3 p0 = mesh.point(from), p1 = mesh.point(to), p2 = mesh.point(t);
  const Vec3 cross = OpenMesh::cross(p1 - p0, p2 - p0);
  const double longest = std::max({(p1 - p0).sqrnorm(), (p2 - p1).sqrnorm(), (p0 - p2).sqrnorm()});
  if (!(cross.norm() > 1e-10 * longest)) return refuse("the triangle would be degenerate");
  const Vec3 normal = cross / cross.norm();
  const Vec3 joined = mesh.calc_face_normal(mesh.face_handle(mesh.opposite_halfedge_handle(free)));
  const Vec3 at_t = vertex_normal(mesh, t);
  // Opposite orientations: the stitch opposes both sides (ALGORITHMS.md §4.1), or the target
  // surface faces strongly away from it (more than 120°): one surface has to be flipped.
  if ((OpenMesh::dot(normal, joined) < 0 && OpenMesh::dot(normal, at_t) < 0) ||
      OpenMesh::dot(normal, at_t) < -0.5)
    return refuse("the surfaces have opposite orientations: flip one before bridging");
  if (options.check_intersections) {
    const TrianglePoints tri{p0, p1, p2};
    const std::array<int, 3> ids{from.idx(), to.idx(), t.idx()};
    Eigen::AlignedBox3d box;
    for (const Vec3& p : tri) box.extend(Eigen::Vector3d(p[0], p[1], p[2]));
    std::optional<SearchReach> own_reach;
    if (!options.reach) own_reach = make_search_reach(mesh, false);
    for (const FaceHandle f :
         faces_in_box(mesh, box, options.reach ? *options.reach : *own_reach)) {
      TrianglePoints other;
      std::array<int, 3> other_ids{};
      int k = 0;
      for (const VertexHandle v : mesh.fv_range(f)) {
        other[static_cast<std::size_t>(k)] = mesh.point(v);
        other_ids[static_cast<std::size_t>(k++)] = v.idx();
      }
      if (triangles_intersect(tri, ids, other, other_ids))
        return refuse(fmt::format("the triangle would intersect face {}", f.idx()));
    }
  }
  const FaceHandle face = mesh.add_face(from, to, t);
  if (!face.is_valid())
    return refuse("the mesh cannot take this face there (it would make a complex vertex)");
  if (options.reach) options.reach->add(mesh, std::span<const FaceHandle>(&face, 1));
  StitchResult r;
  r.ok = true;
  r.face = face;
  return r;
}

GapBridgeResult bridge_gap(Mesh& mesh, const GapEnd& first, const GapEnd& second,
                           const FillOptions& fill, const StitchOptions& stitch) {
  GapBridgeResult result;
  const StitchResult one = stitch_triangle(mesh, first.a, first.b, first.t, stitch);
  if (!one.ok) {
    result.reason = "first end: " + one.reason;
    return result;
  }
  const StitchResult two = stitch_triangle(mesh, second.a, second.b, second.t, stitch);
  if (!two.ok) {
    mesh.delete_face(one.face, false);  // refused as a whole: take the first stitch back
    result.reason = "second end: " + two.reason;
    return result;
  }
  result.stitches = {one.face, two.face};
  // The gap is now a closed loop through a boundary edge of each stitch. Each stitch also has
  // an edge on the outer boundary; of the loops touching both stitches the gap is the
  // shorter one (ALGORITHMS.md §4.2 leaves the choice open).
  const auto touches = [&](const Hole& hole, FaceHandle f) {
    return std::any_of(hole.halfedges.begin(), hole.halfedges.end(), [&](HalfedgeHandle h) {
      return mesh.face_handle(mesh.opposite_halfedge_handle(h)) == f;
    });
  };
  HoleSearchResult holes = find_holes(mesh);
  const Hole* gap = nullptr;
  for (const Hole& hole : holes.holes) {
    if (!touches(hole, one.face) || !touches(hole, two.face)) continue;
    if (!gap || hole.perimeter < gap->perimeter) gap = &hole;
  }
  if (!gap) {
    result.ok = true;  // the stitches closed it already (a gap of one triangle's width)
    return result;
  }
  HoleFillReport report = fill_hole(mesh, *gap, fill);
  const bool filled = report.filled;
  if (!filled) result.reason = "the gap loop could not be filled: " + report.reason;
  result.fills.push_back(std::move(report));
  result.ok = filled;
  return result;
}

}  // namespace touchmend::geometry

namespace touchmend::geometry {
namespace {

//! Outward direction at a boundary vertex: in the surface's tangent plane, perpendicular to
//! the boundary, away from the faces (across the gap).
Vec3 outward_direction(const Mesh& mesh, const Hole& hole, std::size_t i) {
  const std::size_t n = hole.loop.size();
  const Vec3 tangent = mesh.point(hole.loop[(i + 1) % n]) - mesh.point(hole.loop[(i + n - 1) % n]);
  Vec3 normal(0, 0, 0);
  for (const FaceHandle f : mesh.vf_range(hole.loop[i])) normal += mesh.calc_face_normal(f);
  // The hole is on the left of the loop direction seen from outside (normal up): left =
  // normal x tangent.
  Vec3 out = OpenMesh::cross(normal, tangent);
  const double len = out.norm();
  return len > 0 ? out / len : out;
}

}  // namespace

std::vector<Gap> find_gaps(const Mesh& mesh, const std::vector<Hole>& holes,
                           const GapOptions& options) {
  std::vector<Gap> gaps;
  double edge_sum = 0;
  std::size_t edge_count = 0;
  for (const Hole& h : holes) {
    edge_sum += h.perimeter;
    edge_count += h.loop.size();
  }
  if (edge_count == 0) return gaps;
  const double width =
      options.max_width > 0 ? options.max_width : 3.0 * edge_sum / static_cast<double>(edge_count);
  const double facing = std::cos(options.facing_angle_deg * std::numbers::pi / 180.0);
  // Every boundary vertex with its outward direction, in a flat list.
  struct Entry {
    std::size_t hole, index;
    Vec3 point, out;
    double arc;  //!< arc length from the loop's first vertex
  };
  std::vector<Entry> entries;
  std::vector<std::size_t> first_entry(holes.size() + 1, 0);
  for (std::size_t h = 0; h < holes.size(); ++h) {
    first_entry[h] = entries.size();
    double arc = 0;
    for (std::size_t i = 0; i < holes[h].loop.size(); ++i) {
      if (i > 0) arc += (mesh.point(holes[h].loop[i]) - mesh.point(holes[h].loop[i - 1])).norm();
      entries.push_back(
          {h, i, mesh.point(holes[h].loop[i]), outward_direction(mesh, holes[h], i), arc});
    }
  }
  first_entry[holes.size()] = entries.size();
  // Partner of each boundary vertex: the nearest facing boundary vertex within the width on
  // another loop, or on the same loop but 2.5x farther along it than across.
  const double cell = std::max(width, 1e-12);
  std::map<std::array<long long, 3>, std::vector<std::size_t>> grid;
  auto key = [&](const Vec3& p) {
    return std::array<long long, 3>{static_cast<long long>(std::floor(p[0] / cell)),
                                    static_cast<long long>(std::floor(p[1] / cell)),
                                    static_cast<long long>(std::floor(p[2] / cell))};
  };
  for (std::size_t i = 0; i < entries.size(); ++i) grid[key(entries[i].point)].push_back(i);
  std::vector<long long> partner(entries.size(), -1);
  std::vector<double> partner_distance(entries.size(), 0);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const Entry& e = entries[i];
    const auto k = key(e.point);
    double best = width;
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz) {
          const auto it = grid.find({k[0] + dx, k[1] + dy, k[2] + dz});
          if (it == grid.end()) continue;
          for (const std::size_t j : it->second) {
            const Entry& o = entries[j];
            if (j == i) continue;
            const Vec3 across = o.point - e.point;
            const double d = across.norm();
            if (o.hole == e.hole) {
              // Same loop: only a part far along the loop compared with the way across (the
              // two sides of a long thin hole), never a neighbour or a corner.
              const double perimeter = holes[e.hole].perimeter;
              const double along = std::abs(o.arc - e.arc);
              if (std::min(along, perimeter - along) < 2.5 * d) continue;
            }
            if (!(d > 0) || d > best) continue;
            if (OpenMesh::dot(e.out, across) < facing * d ||
                OpenMesh::dot(o.out, -across) < facing * d)
              continue;
            best = d;
            partner[i] = static_cast<long long>(j);
          }
        }
    partner_distance[i] = best;
  }
  // Runs: consecutive vertices of one loop whose partners lie on one other loop (or part).
  for (std::size_t ha = 0; ha < holes.size(); ++ha) {
    const std::size_t n = holes[ha].loop.size();
    const std::size_t base = first_entry[ha];
    // Group by partner loop.
    std::map<std::size_t, std::vector<std::size_t>> by_partner;  // hb -> loop indices of ha
    for (std::size_t i = 0; i < n; ++i)
      if (partner[base + i] >= 0)
        by_partner[entries[static_cast<std::size_t>(partner[base + i])].hole].push_back(i);
    for (const auto& [hb, indices] : by_partner) {
      if (hb < ha) continue;  // each pair of loops once, from the lower index
      std::vector<char> matched(n, 0);
      for (const std::size_t i : indices) matched[i] = 1;
      const bool whole = indices.size() == n;
      // Maximal runs of matched vertices along loop a (cyclically).
      std::vector<std::vector<std::size_t>> runs;
      if (whole) {
        std::vector<std::size_t> all_indices(n);
        for (std::size_t i = 0; i < n; ++i) all_indices[i] = i;
        runs.push_back(all_indices);
      } else {
        std::size_t start = 0;
        while (start < n && matched[start]) ++start;  // an unmatched vertex to begin after
        for (std::size_t step = 1; step <= n; ++step) {
          const std::size_t i = (start + step) % n;
          if (matched[i]) {
            if (runs.empty() || !matched[(i + n - 1) % n]) runs.emplace_back();
            runs.back().push_back(i);
          }
        }
      }
      for (const auto& run : runs) {
        if (run.size() < options.min_run_edges + 1) continue;
        // The partners' span on loop b: from the partner of the last to the partner of the
        // first (b runs the other way).
        const std::size_t nb = holes[hb].loop.size();
        const std::size_t bfirst =
            entries[static_cast<std::size_t>(partner[base + run.back()])].index;
        const std::size_t blast =
            entries[static_cast<std::size_t>(partner[base + run.front()])].index;
        Gap gap;
        gap.hole_a = holes[ha].id;
        gap.hole_b = holes[hb].id;
        for (const std::size_t i : run) gap.run_a.push_back(holes[ha].loop[i]);
        const bool whole_b = whole && hb != ha && [&] {
          for (std::size_t j = 0; j < nb; ++j)
            if (partner[first_entry[hb] + j] < 0 ||
                entries[static_cast<std::size_t>(partner[first_entry[hb] + j])].hole != ha)
              return false;
          return true;
        }();
        if (whole && whole_b) {
          gap.cyclic = true;
          // Start b at the partner of run_a's last vertex and go once around.
          for (std::size_t j = 0; j < nb; ++j)
            gap.run_b.push_back(holes[hb].loop[(bfirst + j) % nb]);
        } else {
          if (whole) continue;  // a whole loop facing part of another: not a clean gap
          for (std::size_t j = bfirst;; j = (j + 1) % nb) {
            gap.run_b.push_back(holes[hb].loop[j]);
            if (j == blast || gap.run_b.size() > nb) break;
          }
          if (gap.run_b.size() < options.min_run_edges + 1 || gap.run_b.size() > nb) continue;
          // Facing runs have comparable lengths; a run facing a much longer stretch is a
          // partner mix-up (a corner of the other boundary), not a gap.
          if (gap.run_b.size() > 3 * gap.run_a.size() + 2 ||
              gap.run_a.size() > 3 * gap.run_b.size() + 2)
            continue;
          // On one loop the two runs must not overlap.
          if (ha == hb) {
            std::set<int> a_ids;
            for (const VertexHandle v : gap.run_a) a_ids.insert(v.idx());
            bool overlap = false;
            for (const VertexHandle v : gap.run_b) overlap = overlap || a_ids.count(v.idx());
            if (overlap) continue;
            // Each gap of one loop is found from both of its runs: keep the one starting lower.
            if (gap.run_b.front().idx() < gap.run_a.front().idx()) continue;
          }
        }
        double sum = 0;
        for (const std::size_t i : run) {
          sum += partner_distance[base + i];
          gap.max_width = std::max(gap.max_width, partner_distance[base + i]);
        }
        gap.mean_width = sum / static_cast<double>(run.size());
        for (std::size_t i = 1; i < gap.run_a.size(); ++i)
          gap.length += (mesh.point(gap.run_a[i]) - mesh.point(gap.run_a[i - 1])).norm();
        gap.id = static_cast<std::uint32_t>(gaps.size());
        gaps.push_back(std::move(gap));
      }
    }
  }
  return gaps;
}

ZipResult zip_gap(Mesh& mesh, const Gap& gap, const StitchOptions& stitch_options) {
  ZipResult result;
  // One reach for the whole zipper (each stitch is filed in it as it is added).
  std::optional<SearchReach> own_reach;
  const StitchOptions options = stitch_options.check_intersections
                                    ? with_reach(mesh, stitch_options, own_reach)
                                    : stitch_options;
  const auto fail = [&](std::string why) {
    for (const FaceHandle f : result.faces)
      if (!mesh.status(f).deleted()) mesh.delete_face(f, false);
    result.faces.clear();
    result.reason = std::move(why);
    return result;
  };
  // A runs forward, B backward: a_0 faces b_last. Advance along both, each step adding the
  // triangle over the next boundary edge of A (to the current b) or of B (to the current a),
  // whichever new diagonal is shorter (a greedy zipper, no vertex added).
  std::vector<VertexHandle> a = gap.run_a;
  std::vector<VertexHandle> b(gap.run_b.rbegin(), gap.run_b.rend());  // now b_0 faces a_0
  if (gap.cyclic) {
    // Close the runs: start where a_0 is nearest to b_0's candidates, then go once around.
    std::size_t best = 0;
    double best_d = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < b.size(); ++j) {
      const double d = (mesh.point(b[j]) - mesh.point(a[0])).sqrnorm();
      if (d < best_d) {
        best_d = d;
        best = j;
      }
    }
    std::rotate(b.begin(), b.begin() + static_cast<std::ptrdiff_t>(best), b.end());
    a.push_back(a.front());
    b.push_back(b.front());
  }
  std::size_t i = 0, j = 0;
  // One step: over the next boundary edge of A (a_i -> a_{i+1}) to b_j, or of B (b_{j+1} ->
  // b_j, B runs backward here) to a_i. The shorter new diagonal first; if its triangle is
  // refused (a fold where the runs are uneven), the other one.
  const auto step_a = [&] {
    if (a[i + 1] == b[j]) return StitchResult{true, {}, FaceHandle()};  // runs meet
    return stitch_triangle(mesh, a[i], a[i + 1], b[j], options);
  };
  const auto step_b = [&] {
    if (b[j + 1] == a[i]) return StitchResult{true, {}, FaceHandle()};
    return stitch_triangle(mesh, b[j + 1], b[j], a[i], options);
  };
  while (i + 1 < a.size() || j + 1 < b.size()) {
    const bool can_a = i + 1 < a.size(), can_b = j + 1 < b.size();
    bool prefer_a = can_a;
    if (can_a && can_b)
      prefer_a = (mesh.point(a[i + 1]) - mesh.point(b[j])).sqrnorm() <=
                 (mesh.point(b[j + 1]) - mesh.point(a[i])).sqrnorm();
    StitchResult s = prefer_a ? step_a() : step_b();
    bool took_a = prefer_a;
    if (!s.ok && can_a && can_b) {
      StitchResult other = prefer_a ? step_b() : step_a();
      if (other.ok) {
        s = other;
        took_a = !prefer_a;
      }
    }
    if (!s.ok)
      return fail(
          fmt::format("zipper stopped after {} triangles: {}", result.faces.size(), s.reason));
    (took_a ? i : j) += 1;
    if (s.face.is_valid()) result.faces.push_back(s.face);
  }
  result.ok = true;
  return result;
}

DetectedGapBridge bridge_detected_gap(Mesh& mesh, const Gap& gap, const FillOptions& fill,
                                      const StitchOptions& stitch_options) {
  DetectedGapBridge out;
  // One reach for the zipper and the fills after it.
  std::optional<SearchReach> own_reach;
  const StitchOptions options = with_reach(mesh, stitch_options, own_reach);
  out.zip = zip_gap(mesh, gap, options);
  if (!out.zip.ok || gap.cyclic) return out;
  std::set<int> zipped;
  for (const FaceHandle f : out.zip.faces) zipped.insert(f.idx());
  double end_edges = 0;
  for (const auto* run : {&gap.run_a, &gap.run_b})
    if (run->size() >= 2)
      end_edges =
          std::max({end_edges, (mesh.point((*run)[1]) - mesh.point((*run)[0])).norm(),
                    (mesh.point(run->back()) - mesh.point((*run)[run->size() - 2])).norm()});
  const double limit = 4.0 * gap.max_width + 4.0 * end_edges;
  const HoleSearchResult holes = find_holes(mesh);
  for (const Hole& hole : holes.holes) {
    if (hole.perimeter > limit) continue;
    const bool at_zipper =
        std::any_of(hole.halfedges.begin(), hole.halfedges.end(), [&](HalfedgeHandle h) {
          return zipped.count(mesh.face_handle(mesh.opposite_halfedge_handle(h)).idx()) > 0;
        });
    if (!at_zipper) continue;
    out.end_fills.push_back(fill_hole(mesh, hole, fill, *options.reach));
  }
  return out;
}

std::size_t DetectedGapsBridge::bridged() const {
  return static_cast<std::size_t>(
      std::count_if(gaps.begin(), gaps.end(), [](const DetectedGapBridge& b) { return b.zip.ok; }));
}

DetectedGapsBridge bridge_detected_gaps(Mesh& mesh, const std::vector<const Gap*>& gaps,
                                        const FillOptions& fill,
                                        const StitchOptions& stitch_options) {
  DetectedGapsBridge out;
  std::optional<SearchReach> own_reach;
  const StitchOptions options = with_reach(mesh, stitch_options, own_reach);
  std::set<int> zipped;
  double widest = 0;
  for (const Gap* gap : gaps) {
    out.gaps.push_back(bridge_detected_gap(mesh, *gap, fill, options));
    const DetectedGapBridge& b = out.gaps.back();
    if (!b.zip.ok) continue;
    widest = std::max(widest, gap->max_width);
    for (const FaceHandle f : b.zip.faces) zipped.insert(f.idx());
  }
  if (zipped.empty()) return out;
  const HoleSearchResult holes = find_holes(mesh);
  for (const Hole& hole : holes.holes) {
    if (!(hole.perimeter > 0) || hole.area > widest * hole.perimeter) continue;
    const bool at_zipper =
        std::any_of(hole.halfedges.begin(), hole.halfedges.end(), [&](HalfedgeHandle h) {
          const FaceHandle f = mesh.face_handle(mesh.opposite_halfedge_handle(h));
          return f.is_valid() && zipped.count(f.idx()) > 0;
        });
    if (at_zipper) out.leftover_fills.push_back(fill_hole(mesh, hole, fill, *options.reach));
  }
  return out;
}

}  // namespace touchmend::geometry
