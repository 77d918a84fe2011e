// touchmend-cut-bench: random holes in the shared meshes, filled and scored against the faces
// they replace. Each cut removes the faces whose centroids lie in 1–5 overlapping balls (radii
// up to --max-radius of the bounding-box diagonal, centred on random vertices), which makes the
// holes a user meets beyond the shared cases: several at once, pinched loops, islands, loose
// fragments, cuts across creases and corners. Every hole is filled (like `fill --all`); the holes
// the cut made are scored (the mesh's own openings have no ground truth): closed, the fill
// invariants of tests/support/invariants.h, the smallest angle (and whether the rim's own
// corners allow 15°), and the one-sided mean and Hausdorff distance from the patch to the removed
// faces in per mille of the diagonal. The cut sequence depends on the seeds only, so two builds
// can be compared fill by fill (--per-hole).
//
// --along-creases cuts slots along the meshes' creases instead: where a scanner loses data at
// sharp edges. Each cut removes the faces whose centroids lie within a random radius of 1-3
// runs of crease edges (dihedral over 60°, as BASELINE.md counts creases), and is scored also by
// its crease distance: the largest distance from the removed crease edges to the cut's patches.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <OpenMesh/Core/System/omstream.hh>
#include <fmt/format.h>

#include "server/geometry/bvh.h"
#include "server/geometry/hole_filling.h"
#include "server/geometry/holes.h"
#include "server/geometry/intersection.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_io.h"
#include "server/geometry/metrics.h"
#include "server/geometry/patch_quality.h"
#include "tests/support/cases.h"
#include "tests/support/invariants.h"
#include "tests/support/mesh_factory.h"

namespace tmd = touchmend;
namespace geo = touchmend::geometry;

namespace {

using PointKey = std::array<double, 3>;
using EdgeKey = std::pair<PointKey, PointKey>;

PointKey key_of(const geo::Vec3& p) {
  return {p[0], p[1], p[2]};
}

EdgeKey edge_key(const geo::Vec3& a, const geo::Vec3& b) {
  const PointKey ka = key_of(a), kb = key_of(b);
  return ka < kb ? EdgeKey{ka, kb} : EdgeKey{kb, ka};
}

//! The boundary edges of \p mesh by their corners' positions (the cut mesh renumbers vertices).
std::set<EdgeKey> boundary_edges(const geo::Mesh& mesh) {
  std::set<EdgeKey> out;
  for (const geo::HalfedgeHandle h : mesh.halfedges())
    if (mesh.is_boundary(h))
      out.insert(
          edge_key(mesh.point(mesh.from_vertex_handle(h)), mesh.point(mesh.to_vertex_handle(h))));
  return out;
}

double angle_deg(const geo::Vec3& a, const geo::Vec3& b) {
  return std::atan2(OpenMesh::cross(a, b).norm(), OpenMesh::dot(a, b)) * 180.0 / std::numbers::pi;
}

//! The smallest corner the patch has at a rim vertex (the sum of its triangles' angles there) or
//! between two rim edges: under 15°, no triangulation of that rim reaches 15° (DESIGN's goal).
double smallest_rim_corner(const geo::Mesh& mesh, const geo::Hole& hole,
                           const std::vector<geo::FaceHandle>& patch) {
  std::set<int> in_patch;
  for (const geo::FaceHandle f : patch) in_patch.insert(f.idx());
  double smallest = 360;
  const std::size_t n = hole.loop.size();
  for (std::size_t i = 0; i < n; ++i) {
    const geo::VertexHandle v = hole.loop[i];
    const geo::Vec3 p = mesh.point(v);
    smallest = std::min(smallest, angle_deg(mesh.point(hole.loop[(i + n - 1) % n]) - p,
                                            mesh.point(hole.loop[(i + 1) % n]) - p));
    double sum = 0;
    for (const geo::HalfedgeHandle h : mesh.voh_range(v)) {
      const geo::FaceHandle f = mesh.face_handle(h);
      if (!f.is_valid() || !in_patch.count(f.idx())) continue;
      sum += angle_deg(mesh.point(mesh.to_vertex_handle(h)) - p,
                       mesh.point(mesh.to_vertex_handle(mesh.next_halfedge_handle(h))) - p);
    }
    if (sum > 0) smallest = std::min(smallest, sum);
  }
  return smallest;
}

//! A crease edge for --along-creases: dihedral over this (BASELINE.md's "sharp edges").
constexpr double kCreaseDeg = 60.0;

bool is_crease(const geo::Mesh& mesh, geo::EdgeHandle e) {
  if (mesh.is_boundary(e)) return false;
  const geo::HalfedgeHandle h = mesh.halfedge_handle(e, 0);
  const geo::Vec3 a = mesh.calc_face_normal(mesh.face_handle(h));
  const geo::Vec3 b = mesh.calc_face_normal(mesh.face_handle(mesh.opposite_halfedge_handle(h)));
  return OpenMesh::dot(a, b) < std::cos(kCreaseDeg * std::numbers::pi / 180);
}

//! The crease run through crease edge \p start: followed both ways, at each vertex along the
//! crease edge that turns least (under 45°), until it is \p length long in all, ends, or closes.
std::vector<geo::Vec3> crease_run(const geo::Mesh& mesh, geo::EdgeHandle start, double length) {
  const double straight_enough = std::cos(std::numbers::pi / 4);
  std::set<int> taken{start.idx()};
  double walked = (mesh.point(mesh.to_vertex_handle(mesh.halfedge_handle(start, 0))) -
                   mesh.point(mesh.from_vertex_handle(mesh.halfedge_handle(start, 0))))
                      .norm();
  std::array<std::vector<geo::Vec3>, 2> sides;
  for (int side = 0; side < 2; ++side) {
    geo::HalfedgeHandle h = mesh.halfedge_handle(start, static_cast<unsigned>(side));
    sides[static_cast<std::size_t>(side)].push_back(mesh.point(mesh.to_vertex_handle(h)));
    while (walked < length) {
      const geo::Vec3 heading =
          (mesh.point(mesh.to_vertex_handle(h)) - mesh.point(mesh.from_vertex_handle(h)))
              .normalize_cond();
      geo::HalfedgeHandle next;
      double best = straight_enough;
      for (const geo::HalfedgeHandle o : mesh.voh_range(mesh.to_vertex_handle(h))) {
        const geo::EdgeHandle e = mesh.edge_handle(o);
        if (taken.count(e.idx()) || !is_crease(mesh, e)) continue;
        const geo::Vec3 d =
            (mesh.point(mesh.to_vertex_handle(o)) - mesh.point(mesh.from_vertex_handle(o)))
                .normalize_cond();
        if (const double c = OpenMesh::dot(d, heading); c > best) {
          best = c;
          next = o;
        }
      }
      if (!next.is_valid()) break;
      taken.insert(mesh.edge_handle(next).idx());
      walked += mesh.calc_edge_length(next);
      h = next;
      sides[static_cast<std::size_t>(side)].push_back(mesh.point(mesh.to_vertex_handle(h)));
    }
  }
  std::vector<geo::Vec3> run(sides[1].rbegin(), sides[1].rend());
  run.insert(run.end(), sides[0].begin(), sides[0].end());
  return run;
}

double distance_to_run(const geo::Vec3& p, const std::vector<geo::Vec3>& run) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < run.size(); ++i)
    best = std::min(best, geo::segment_segment_distance2(p, p, run[i], run[i + 1]));
  return std::sqrt(best);
}

//! The crease edges among \p removed triangles: edges both of whose faces were removed, with a
//! dihedral over kCreaseDeg.
std::vector<std::array<geo::Vec3, 2>> removed_creases(
    const std::vector<geo::TrianglePoints>& removed) {
  std::map<EdgeKey, std::vector<geo::Vec3>> normals;
  for (const geo::TrianglePoints& t : removed) {
    const geo::Vec3 n = OpenMesh::cross(t[1] - t[0], t[2] - t[0]).normalize_cond();
    for (std::size_t k = 0; k < 3; ++k) normals[edge_key(t[k], t[(k + 1) % 3])].push_back(n);
  }
  std::vector<std::array<geo::Vec3, 2>> out;
  const double limit = std::cos(kCreaseDeg * std::numbers::pi / 180);
  for (const auto& [edge, n] : normals)
    if (n.size() == 2 && OpenMesh::dot(n[0], n[1]) < limit)
      out.push_back({geo::Vec3(edge.first[0], edge.first[1], edge.first[2]),
                     geo::Vec3(edge.second[0], edge.second[1], edge.second[2])});
  return out;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

struct Tally {
  std::size_t cuts = 0, holes = 0, own_openings = 0, merged = 0, closed = 0, open = 0,
              fragments = 0, invariant_failures = 0, degenerate = 0, under_15 = 0,
              under_15_rim_allows = 0;
  std::vector<double> mean, hausdorff, ms;
  //! --along-creases: per cut, the crease distance (‰); cuts with a hole left open have none.
  std::vector<double> crease;
  std::vector<std::string> open_holes;  //!< where and why, one line each
  //! Every closed fill's time (ms) and what it was (where, method), for --slowest.
  std::vector<std::pair<double, std::string>> timed_fills;

  void add(const Tally& o) {
    cuts += o.cuts;
    holes += o.holes;
    own_openings += o.own_openings;
    merged += o.merged;
    closed += o.closed;
    open += o.open;
    fragments += o.fragments;
    invariant_failures += o.invariant_failures;
    degenerate += o.degenerate;
    under_15 += o.under_15;
    under_15_rim_allows += o.under_15_rim_allows;
    mean.insert(mean.end(), o.mean.begin(), o.mean.end());
    hausdorff.insert(hausdorff.end(), o.hausdorff.begin(), o.hausdorff.end());
    ms.insert(ms.end(), o.ms.begin(), o.ms.end());
    crease.insert(crease.end(), o.crease.begin(), o.crease.end());
    open_holes.insert(open_holes.end(), o.open_holes.begin(), o.open_holes.end());
    timed_fills.insert(timed_fills.end(), o.timed_fills.begin(), o.timed_fills.end());
  }
};

void print_row(const std::string& name, const Tally& t, bool crease_column) {
  fmt::print(
      "| {} | {} | {} | {} | {} | {} | {} | {} | {} ({}) | {:.2f} / {:.2f} | {:.2f} / {:.2f} | "
      "{:.2f} / {:.2f} |",
      name, t.cuts, t.holes, t.closed, t.open, t.fragments, t.invariant_failures, t.degenerate,
      t.under_15, t.under_15_rim_allows, quantile(t.mean, 0.5), quantile(t.mean, 0.9),
      quantile(t.hausdorff, 0.5), quantile(t.hausdorff, 0.9), quantile(t.ms, 0.5),
      quantile(t.ms, 1.0));
  if (crease_column)
    fmt::print(" {:.2f} / {:.2f} / {:.2f} ({}) |", quantile(t.crease, 0.5), quantile(t.crease, 0.9),
               quantile(t.crease, 1.0), t.crease.size());
  fmt::print("\n");
}

}  // namespace

int main(int argc, char** argv) {
  omerr().disable();
  omout().disable();
  omlog().disable();
  CLI::App app{
      "Random holes cut into the shared meshes (1-5 overlapping balls each), every hole filled, "
      "the cut's holes scored against the removed faces"};
  int first_seed = 1, last_seed = 3, cuts_per_mesh = 10;
  double max_radius = 0.15;
  bool mix = false, per_hole = false;
  std::string shape = "auto", sharp = "auto";
  int refine_iterations = 3;
  bool remove_fragments = false;
  std::vector<std::string> meshes{
      "couplingdown.off", "fandisk.obj",   "hand.off", "mech-holes-shark.off",
      "rocker-arm.obj",   "sphere966.off", "spot.obj", "stanford-bunny.obj"};
  app.add_option("--first-seed", first_seed, "First random seed")->check(CLI::Range(0, 1 << 30));
  app.add_option("--last-seed", last_seed, "Last random seed (inclusive)")
      ->check(CLI::Range(0, 1 << 30));
  app.add_option("--cuts", cuts_per_mesh, "Cuts per mesh and seed")->check(CLI::Range(1, 1000));
  app.add_option("--max-radius", max_radius, "Largest ball radius, in bounding-box diagonals")
      ->check(CLI::Range(0.006, 0.5));
  app.add_option("--meshes", meshes, "Meshes of ../shared/data/meshes to cut");
  app.add_option("--shape", shape, "touchmend --shape")
      ->check(CLI::IsMember({"flat", "fair", "auto"}));
  app.add_option("--sharp", sharp, "touchmend --sharp")->check(CLI::IsMember({"off", "auto"}));
  app.add_option("--refine-iterations", refine_iterations, "touchmend --refine-iterations")
      ->check(CLI::Range(1, 5));
  app.add_flag("--remove-fragments", remove_fragments, "touchmend --remove-fragments");
  app.add_flag("--mix", mix,
               "Fill each cut with one of six option sets drawn at random (defaults, --shape "
               "flat, --shape fair, --sharp off, --refine-iterations 1, 5) instead of the "
               "options given");
  std::string only, save_dir;
  app.add_option("--only", only,
                 "Fill only this cut, as MESH:SEED:CUT (e.g. fandisk.obj:2:3; the others are "
                 "still drawn, so the cut is the same), and print its balls");
  app.add_option("--save", save_dir,
                 "Write each filled cut's holed mesh to this directory (MESH-sSEED-cCUT.off), to "
                 "fill it again with the touchmend command line");
  app.add_flag("--per-hole", per_hole,
               "Also print one line per hole (for comparing two builds fill by fill)");
  int slowest = 0;
  app.add_option("--slowest", slowest,
                 "Also list the N slowest fills (time, where, method, shape, faces)")
      ->check(CLI::Range(0, 100000));
  bool along_creases = false;
  app.add_flag("--along-creases", along_creases,
               "Cut slots along the meshes' creases (dihedral over 60°) instead of balls: 1-3 "
               "crease runs per cut, each 2-20% of the diagonal long, the faces within 0.2-2% of "
               "it removed; also scores the crease distance (meshes without creases are skipped)");
  CLI11_PARSE(app, argc, argv);
  if (last_seed < first_seed) {
    fmt::print(stderr, "--last-seed {} is before --first-seed {}\n", last_seed, first_seed);
    return 2;
  }

  geo::FillOptions base;
  geo::parse_patch_shape(shape, base.shape);
  geo::parse_sharp_mode(sharp, base.sharp);
  base.refine_iterations = refine_iterations;
  base.remove_fragments = remove_fragments;

  const std::string dir = tmd::testing::shared_data_dir() + "/meshes";
  fmt::print("cuts: seeds {}-{}, {} per mesh and seed, {}; {}\n\n", first_seed, last_seed,
             cuts_per_mesh,
             along_creases ? std::string("slots along 1-3 crease runs")
                           : fmt::format("1-5 balls of radius up to {} diagonals", max_radius),
             mix ? "options drawn per cut (--mix)"
                 : fmt::format("--shape {} --sharp {} --refine-iterations {}{}", shape, sharp,
                               refine_iterations, remove_fragments ? " --remove-fragments" : ""));
  fmt::print(
      "| mesh | cuts | holes cut | closed | left open | fragments removed | invariant failures | "
      "degenerate | under 15° (rim allows) | mean ‰ p50 / p90 | H ‰ p50 / p90 | fill ms p50 / max "
      "|{}\n|---|---|---|---|---|---|---|---|---|---|---|---|{}\n",
      along_creases ? " crease ‰ p50 / p90 / max (cuts) |" : "", along_creases ? "---|" : "");
  Tally total;
  std::vector<std::string> hole_lines;
  for (const std::string& name : meshes) {
    const geo::ReadResult read = geo::read_mesh_file(dir + "/" + name);
    if (!read.ok) {
      fmt::print(stderr, "skip {}: {}\n", name, read.error);
      continue;
    }
    geo::Box3 box;
    for (const geo::Vec3& p : read.soup.points) box.extend(Eigen::Vector3d(p[0], p[1], p[2]));
    const double diagonal = box.diagonal().norm();
    const geo::Mesh original = geo::build_mesh(read.soup).mesh;
    const std::set<EdgeKey> own_boundary = boundary_edges(original);
    std::vector<geo::EdgeHandle> creases;
    if (along_creases) {
      for (const geo::EdgeHandle e : original.edges())
        if (is_crease(original, e)) creases.push_back(e);
      if (creases.empty()) {
        fmt::print(stderr, "skip {}: no crease edges\n", name);
        continue;
      }
    }
    Tally tally;
    for (int seed = first_seed; seed <= last_seed; ++seed) {
      // One stream per mesh and seed: adding a mesh or changing --cuts leaves the others' cuts.
      std::uint32_t name_hash = 2166136261u;  // FNV-1a: the same streams on every platform
      for (const char ch : name)
        name_hash = (name_hash ^ static_cast<unsigned char>(ch)) * 16777619u;
      std::mt19937 random(static_cast<std::uint32_t>(seed) * 7919u + name_hash);
      for (int cut = 0; cut < cuts_per_mesh; ++cut) {
        const int balls = along_creases ? 0 : std::uniform_int_distribution<int>(1, 5)(random);
        std::vector<std::pair<std::vector<geo::Vec3>, double>> slots;
        if (along_creases) {
          const int runs = std::uniform_int_distribution<int>(1, 3)(random);
          for (int k = 0; k < runs; ++k) {
            const geo::EdgeHandle start =
                creases[std::uniform_int_distribution<std::size_t>(0, creases.size() - 1)(random)];
            const double length =
                diagonal * std::uniform_real_distribution<double>(0.02, 0.2)(random);
            const double radius =
                diagonal * std::uniform_real_distribution<double>(0.002, 0.02)(random);
            slots.emplace_back(crease_run(original, start, length), radius);
          }
        }
        std::vector<std::pair<geo::Vec3, double>> spheres;
        for (int b = 0; b < balls; ++b) {
          const geo::Vec3 centre = read.soup.points[std::uniform_int_distribution<std::size_t>(
              0, read.soup.points.size() - 1)(random)];
          spheres.emplace_back(
              centre, diagonal * std::uniform_real_distribution<double>(0.005, max_radius)(random));
        }
        const int variant = std::uniform_int_distribution<int>(0, 5)(random);
        geo::FillOptions options = base;
        if (mix) {
          options = geo::FillOptions{};
          switch (variant) {
            case 1:
              options.shape = geo::PatchShape::Flat;
              break;
            case 2:
              options.shape = geo::PatchShape::Fair;
              break;
            case 3:
              options.sharp = geo::SharpMode::Off;
              break;
            case 4:
              options.refine_iterations = 1;
              break;
            case 5:
              options.refine_iterations = 5;
              break;
            default:
              break;
          }
        }
        const std::string where = fmt::format("{} seed {} cut {}", name, seed, cut);
        if (!only.empty() && only != fmt::format("{}:{}:{}", name, seed, cut)) continue;
        // One cut asked for: its balls, to rebuild it elsewhere (a test, a bug report).
        if (!only.empty()) {
          for (const auto& [centre, radius] : spheres)
            fmt::print("ball centre ({:.9g}, {:.9g}, {:.9g}) radius {:.9g}\n", centre[0], centre[1],
                       centre[2], radius);
          for (const auto& [run, radius] : slots) {
            fmt::print("slot of radius {:.9g} along {} crease points:", radius, run.size());
            for (const geo::Vec3& p : run)
              fmt::print(" ({:.9g}, {:.9g}, {:.9g})", p[0], p[1], p[2]);
            fmt::print("\n");
          }
        }
        const auto in_cut = [&](const geo::Vec3& c) {
          return std::any_of(spheres.begin(), spheres.end(),
                             [&](const auto& s) { return (c - s.first).norm() < s.second; }) ||
                 std::any_of(slots.begin(), slots.end(),
                             [&](const auto& s) { return distance_to_run(c, s.first) < s.second; });
        };
        std::vector<geo::TrianglePoints> removed;
        const geo::MeshSoup holed = tmd::testing::remove_faces(read.soup, in_cut, &removed);
        geo::Mesh mesh = geo::build_mesh(holed).mesh;
        if (!save_dir.empty()) {
          const std::string path = fmt::format("{}/{}-s{}-c{}.off", save_dir, name, seed, cut);
          if (const geo::WriteResult w = geo::write_mesh_file(mesh, path); !w.ok) {
            fmt::print(stderr, "cannot write {}: {}\n", path, w.error);
            return 1;
          }
        }
        const std::vector<geo::Hole> holes = geo::find_holes(mesh).holes;
        const tmd::testing::Snapshot before = tmd::testing::take_snapshot(mesh);
        const geo::FillReport report = geo::fill_holes(mesh, {}, options);
        ++tally.cuts;
        if (const std::string problems =
                tmd::testing::check_fill_invariants(before, mesh, report.holes, holes);
            !problems.empty()) {
          ++tally.invariant_failures;
          fmt::print(stderr, "invariants broken ({}): {}\n", where, problems);
        }
        std::vector<geo::TrianglePoints> cut_patches;  // every new face of the cut
        bool cut_left_open = false;
        for (const geo::HoleFillReport& r : report.holes) {
          const auto found = geo::find_hole_by_id(holes, r.hole_id);
          if (!found) continue;
          if (r.filled) {
            const auto patch = geo::face_triangles(mesh, r.new_faces);
            cut_patches.insert(cut_patches.end(), patch.begin(), patch.end());
          }
          const geo::Hole& hole = holes[*found];
          std::size_t own_edges = 0;
          for (std::size_t i = 0; i < hole.loop.size(); ++i)
            own_edges += own_boundary.count(edge_key(
                mesh.point(hole.loop[i]), mesh.point(hole.loop[(i + 1) % hole.loop.size()])));
          if (own_edges == hole.loop.size()) {
            ++tally.own_openings;
            continue;
          }
          // A cut that met one of the mesh's own openings: the removed faces cover only part of
          // what the patch spans, so its distance to them says nothing.
          const bool merged = own_edges > 0;
          tally.merged += merged ? 1 : 0;
          ++tally.holes;
          std::string line = fmt::format("{} hole {} bnd {} variant {}: ", where, r.hole_id,
                                         r.boundary_vertices, mix ? variant : 0);
          if (r.fragment_removed()) {
            ++tally.fragments;
            line += fmt::format("fragment of {} faces removed", r.removed_faces.size());
          } else if (!r.filled) {
            ++tally.open;
            cut_left_open = true;
            tally.open_holes.push_back(fmt::format("{} hole {} ({} edges): {}", where, r.hole_id,
                                                   r.boundary_vertices, r.reason));
            line += "open: " + r.reason;
          } else if (r.new_faces.empty()) {
            // Closed by another hole's patch (the borders of one ring): scored with that one.
            ++tally.closed;
            line += "closed with another hole: " +
                    (r.warnings.empty() ? std::string() : r.warnings.front());
          } else {
            ++tally.closed;
            const double angle = geo::min_angle_deg(mesh, r.new_faces);
            if (angle < geo::kDegenerateAngleDeg) ++tally.degenerate;
            const bool rim_allows = smallest_rim_corner(mesh, hole, r.new_faces) >= 15.0;
            if (angle < 15.0) {
              ++tally.under_15;
              if (rim_allows) ++tally.under_15_rim_allows;
            }
            tally.ms.push_back(1e3 * r.seconds);
            tally.timed_fills.emplace_back(
                1e3 * r.seconds,
                fmt::format("{} hole {} ({} edges): {}/{}, {} faces", where, r.hole_id,
                            r.boundary_vertices, geo::to_string(r.method), geo::to_string(r.shape),
                            r.new_faces.size()));
            line += fmt::format(
                "{}/{} min {:.2f}°{} faces {}", geo::to_string(r.method), geo::to_string(r.shape),
                angle, angle < 15.0 && rim_allows ? " (rim allows 15°)" : "", r.new_faces.size());
            if (merged) {
              line += " (met an opening of the mesh: not scored)";
            } else {
              const auto patch = geo::face_triangles(mesh, r.new_faces);
              const geo::SurfaceDistance d = geo::surface_distance(patch, removed, 1e-3 * diagonal);
              tally.mean.push_back(1e3 * d.mean_a_to_b / diagonal);
              tally.hausdorff.push_back(1e3 * d.h_a_to_b / diagonal);
              line +=
                  fmt::format(" mean {:.3f}‰ H {:.3f}‰", tally.mean.back(), tally.hausdorff.back());
            }
            if (!r.creases.empty()) line += " [" + r.creases + "]";
          }
          if (per_hole) hole_lines.push_back(std::move(line));
        }
        if (along_creases && !cut_left_open) {
          const auto gt = removed_creases(removed);
          const geo::SegmentDistance d = geo::segment_distance(gt, cut_patches, 2e-3 * diagonal);
          if (d.valid) {
            tally.crease.push_back(1e3 * d.max / diagonal);
            if (per_hole)
              hole_lines.push_back(fmt::format("{}: crease H {:.3f}‰ over {} crease edges", where,
                                               tally.crease.back(), gt.size()));
          }
        }
      }
    }
    print_row(name, tally, along_creases);
    total.add(tally);
  }
  print_row("all", total, along_creases);
  fmt::print(
      "\nthe meshes' own openings, filled too and not scored: {}; cut holes that met one (closed "
      "and angles counted, distances not): {}\n",
      total.own_openings, total.merged);
  for (const std::string& line : total.open_holes) fmt::print("left open: {}\n", line);
  if (slowest > 0) {
    auto& fills = total.timed_fills;
    const auto n = std::min(fills.size(), static_cast<std::size_t>(slowest));
    std::partial_sort(fills.begin(), fills.begin() + static_cast<std::ptrdiff_t>(n), fills.end(),
                      [](const auto& a, const auto& b) { return a.first > b.first; });
    fmt::print("\nslowest fills:\n");
    for (std::size_t i = 0; i < n; ++i)
      fmt::print("{:9.2f} ms  {}\n", fills[i].first, fills[i].second);
  }
  if (per_hole) {
    fmt::print("\n");
    for (const std::string& line : hole_lines) fmt::print("{}\n", line);
  }
  return total.invariant_failures == 0 && total.degenerate == 0 ? 0 : 1;
}
