#include "server/geometry/piecewise_split.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <unordered_set>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include "server/geometry/liepa_triangulation.h"
#include "server/geometry/projection.h"

namespace touchmend::geometry {
namespace {

constexpr Vec3 kNoOpposite{std::numeric_limits<double>::quiet_NaN(), 0, 0};

struct Piece {
  std::vector<int> loop;  // pool indices
  int depth = 0;
  //! The frame the split that made this piece found it simple in (tested without the chord's
  //! points, which lie on the chord and project onto the same segment): not searched again.
  std::optional<ReferenceFrame> frame;
};

class PiecewiseFiller {
 public:
  PiecewiseFiller(const PiecewiseInput& in, const PiecewiseOptions& opt) : in_(in), opt_(opt) {
    pool_.assign(in.loop.begin(), in.loop.end());
    normals_.assign(in.vertex_normals.begin(), in.vertex_normals.end());
    const int n = static_cast<int>(in.loop.size());
    for (int i = 0; i < n; ++i) {
      opposite_[edge_key(i, (i + 1) % n)] = in.opposite[static_cast<std::size_t>(i)];
    }
    for (const auto& [a, b] : in.blocked) used_.insert(undirected(a, b));
  }

  PiecewiseResult run() {
    std::vector<Piece> stack;
    Piece root;
    root.loop.resize(in_.loop.size());
    std::iota(root.loop.begin(), root.loop.end(), 0);
    stack.push_back(std::move(root));
    while (!stack.empty()) {
      Piece piece = std::move(stack.back());
      stack.pop_back();
      if (!fill_piece(piece, stack)) return std::move(result_);
    }
    result_.new_points.assign(pool_.begin() + static_cast<std::ptrdiff_t>(in_.loop.size()),
                              pool_.end());
    result_.ok = true;
    return std::move(result_);
  }

 private:
  static std::uint64_t edge_key(int a, int b) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) |
           static_cast<std::uint32_t>(b);
  }
  static std::uint64_t undirected(int a, int b) { return a < b ? edge_key(a, b) : edge_key(b, a); }

  Vec3 opposite_of(int a, int b) const {
    const auto it = opposite_.find(edge_key(a, b));
    return it == opposite_.end() ? kNoOpposite : it->second;
  }

  static Vec3 newell(std::span<const Vec3> pts) {
    Vec3 n(0, 0, 0);
    for (std::size_t i = 0; i < pts.size(); ++i)
      n += OpenMesh::cross(pts[i], pts[(i + 1) % pts.size()]);
    const double len = n.norm();
    return len > 0 ? n / len : Vec3(0, 0, 1);
  }

  //! ψ: smallest eigenvalue over trace of the covariance (0 for a planar loop).
  static double flatness_penalty(std::span<const Vec3> pts) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const Vec3& p : pts) mean += Eigen::Vector3d(p[0], p[1], p[2]);
    mean /= static_cast<double>(pts.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const Vec3& p : pts) {
      const Eigen::Vector3d d = Eigen::Vector3d(p[0], p[1], p[2]) - mean;
      cov += d * d.transpose();
    }
    const double trace = cov.trace();
    if (!(trace > 0)) return 0;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov, Eigen::EigenvaluesOnly);
    return eig.eigenvalues()(0) / trace;
  }

  //! Tries the normals of the projectability chain on a piece; returns the frame if simple.
  bool find_simple_frame(const std::vector<int>& loop, ReferenceFrame& frame) const {
    std::vector<Vec3> pts, outside;
    for (int v : loop) pts.push_back(pool_[static_cast<std::size_t>(v)]);
    Vec3 centroid(0, 0, 0);
    for (const Vec3& p : pts) centroid += p;
    centroid /= static_cast<double>(pts.size());
    Vec3 avg(0, 0, 0);
    const std::size_t n = loop.size();
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3 o = opposite_of(loop[i], loop[(i + 1) % n]);
      if (std::isnan(o[0])) continue;
      outside.push_back(o);
      const Vec3& a = pts[i];
      const Vec3& b = pts[(i + 1) % n];
      avg += OpenMesh::cross(a - b, o - b).normalize_cond();
    }
    const Vec3 nw = newell(pts);
    std::vector<Vec3> candidates;
    if (avg.norm() > 0.1 * static_cast<double>(outside.size()) && avg.norm() > 0)
      candidates.push_back(avg.normalized());
    candidates.push_back(nw);
    candidates.push_back(pca_normal(pts, nw));
    for (const Vec3& c : candidates) {
      frame = ReferenceFrame::from_normal(c, centroid);
      if (test_projectable(pts, outside, frame, 0.05 * in_.mean_edge_length).projectable)
        return true;
    }
    return false;
  }

  void emit(int a, int b, int c) {
    result_.triangles.push_back({a, b, c});
    used_.insert(undirected(a, b));
    used_.insert(undirected(b, c));
    used_.insert(undirected(c, a));
  }

  std::vector<std::pair<int, int>> local_blocked(const std::vector<int>& loop) const {
    // Pairs of this piece's vertices already joined by an edge that is not one of its own
    // boundary edges.
    std::vector<std::pair<int, int>> out;
    const std::size_t n = loop.size();
    std::unordered_set<std::uint64_t> own;
    for (std::size_t i = 0; i < n; ++i) own.insert(undirected(loop[i], loop[(i + 1) % n]));
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = i + 2; j < n; ++j) {
        const std::uint64_t k = undirected(loop[i], loop[j]);
        if (used_.count(k) && !own.count(k))
          out.emplace_back(static_cast<int>(i), static_cast<int>(j));
      }
    return out;
  }

  bool close_with_dp(const std::vector<int>& loop) {
    std::vector<Vec3> pts, opp;
    const std::size_t n = loop.size();
    for (int v : loop) pts.push_back(pool_[static_cast<std::size_t>(v)]);
    const Vec3 nw = newell(pts);
    for (std::size_t i = 0; i < n; ++i) {
      Vec3 o = opposite_of(loop[i], loop[(i + 1) % n]);
      if (std::isnan(o[0])) {  // chord edge: pretend a neighbour in the piece's own plane
        const Vec3& a = pts[i];
        const Vec3& b = pts[(i + 1) % n];
        o = 0.5 * (a + b) + OpenMesh::cross(nw, a - b);
      }
      opp.push_back(o);
    }
    LiepaTriangulationOptions dp;
    dp.max_vertices = opt_.max_dp_vertices;
    const auto blocked = local_blocked(loop);
    const LiepaTriangulation t = triangulate_min_dihedral(pts, opp, blocked, dp);
    if (!t.ok) {
      result_.failure = "piece of " + std::to_string(n) + " vertices: " + t.failure;
      return false;
    }
    for (const auto& tri : t.triangles) emit(loop[tri[0]], loop[tri[1]], loop[tri[2]]);
    ++result_.pieces;
    return true;
  }

  bool fill_piece(const Piece& piece, std::vector<Piece>& stack) {
    const std::vector<int>& loop = piece.loop;
    const std::size_t n = loop.size();
    if (n == 3) {
      emit(loop[0], loop[1], loop[2]);
      ++result_.pieces;
      ++result_.planar_pieces;
      return true;
    }
    ReferenceFrame frame;
    if (piece.frame) frame = *piece.frame;
    if (piece.frame || find_simple_frame(loop, frame)) {
      std::vector<Point2> polygon;
      for (int v : loop) polygon.push_back(frame.project(pool_[static_cast<std::size_t>(v)]));
      const auto blocked = local_blocked(loop);
      const PlanarTriangulation t = triangulate_planar(polygon, blocked, opt_.planar);
      if (t.ok) {
        for (const auto& tri : t.triangles) emit(loop[tri[0]], loop[tri[1]], loop[tri[2]]);
        ++result_.pieces;
        ++result_.planar_pieces;
        result_.angles_closed += t.angles_closed;
        return true;
      }
    }
    if (n <= 5 || piece.depth >= opt_.max_depth) return close_with_dp(loop);
    std::vector<Piece> halves;
    if (!split(piece, halves)) return close_with_dp(loop);
    for (Piece& h : halves) stack.push_back(std::move(h));
    return true;
  }

  //! Angle of direction d around normal nrm measured from direction ref (counter-clockwise).
  static double angle_around(const Vec3& nrm, const Vec3& ref, const Vec3& d) {
    const Vec3 r = ref - OpenMesh::dot(ref, nrm) * nrm;
    const Vec3 q = d - OpenMesh::dot(d, nrm) * nrm;
    double a = std::atan2(OpenMesh::dot(OpenMesh::cross(r, q), nrm), OpenMesh::dot(r, q));
    if (a < 0) a += 2 * std::numbers::pi;
    return a;
  }

  bool chord_enters_hole(const std::vector<int>& loop, std::size_t i, std::size_t j) const {
    const std::size_t n = loop.size();
    const int v = loop[i];
    const Vec3& p = pool_[static_cast<std::size_t>(v)];
    const Vec3& nrm = normals_[static_cast<std::size_t>(v)];
    const Vec3 to_next = pool_[static_cast<std::size_t>(loop[(i + 1) % n])] - p;
    const Vec3 to_prev = pool_[static_cast<std::size_t>(loop[(i + n - 1) % n])] - p;
    const Vec3 to_other = pool_[static_cast<std::size_t>(loop[j])] - p;
    const double wedge = angle_around(nrm, to_next, to_prev);  // interior angle of the hole
    const double chord = angle_around(nrm, to_next, to_other);
    return chord > 1e-6 && chord < wedge - 1e-6;
  }

  bool split(const Piece& piece, std::vector<Piece>& halves) {
    const std::vector<int>& loop = piece.loop;
    const std::size_t n = loop.size();
    std::vector<double> arc(n + 1, 0.0);  // arc length from loop[0] to loop[i]
    for (std::size_t i = 0; i < n; ++i)
      arc[i + 1] = arc[i] + (pool_[static_cast<std::size_t>(loop[(i + 1) % n])] -
                             pool_[static_cast<std::size_t>(loop[i])])
                                .norm();
    const double total = arc[n];
    struct Candidate {
      double cost;
      std::size_t i, j;
    };
    std::vector<Candidate> candidates;
    std::optional<Candidate> chosen;
    std::optional<std::array<ReferenceFrame, 2>> chosen_frames;
    // A chord that may split the loop: not an edge yet, entering the hole at both ends, clear
    // of the mesh.
    const auto valid = [&](const Candidate& c) {
      const int a = loop[c.i], b = loop[c.j];
      if (used_.count(undirected(a, b))) return false;
      if (!chord_enters_hole(loop, c.i, c.j) || !chord_enters_hole(loop, c.j, c.i)) return false;
      return !in_.chord_clearance ||
             in_.chord_clearance(a, b, pool_[static_cast<std::size_t>(a)],
                                 pool_[static_cast<std::size_t>(b)]) >= 0.25 * in_.mean_edge_length;
    };
    // \p wide: the invalid chords are dropped before the best by length are scored (a loop whose
    // shortest chords all cross the mesh has hundreds of them, which would fill the scored list).
    const auto choose = [&](std::size_t per_vertex, bool wide) {
      candidates.clear();
      // Candidates: for each vertex its nearest loop vertices in 3D among those at least a
      // tenth of the loop away (the nearest ones otherwise are always its loop neighbours,
      // whose chords only shave off tiny ears).
      const std::size_t min_gap = std::max<std::size_t>(2, n / 10);
      std::vector<std::pair<double, std::size_t>> nearest;
      for (std::size_t i = 0; i < n; ++i) {
        nearest.clear();
        const Vec3& pi = pool_[static_cast<std::size_t>(loop[i])];
        for (std::size_t j = 0; j < n; ++j) {
          const std::size_t gap = j >= i ? j - i : j + n - i;  // (j - i) mod n, no division
          if (gap < min_gap || gap > n - min_gap) continue;
          nearest.emplace_back((pool_[static_cast<std::size_t>(loop[j])] - pi).sqrnorm(), j);
        }
        const std::size_t keep = std::min(per_vertex, nearest.size());
        std::partial_sort(nearest.begin(), nearest.begin() + static_cast<std::ptrdiff_t>(keep),
                          nearest.end());
        for (std::size_t c = 0; c < keep; ++c) {
          const std::size_t j = nearest[c].second;
          if (j < i) continue;  // each pair once
          const double len = std::sqrt(nearest[c].first);
          const double arc_ij = arc[j] - arc[i];
          const double shorter = std::min(arc_ij, total - arc_ij);
          if (!(len < shorter)) continue;  // must shorten both halves
          candidates.push_back({len / shorter, i, j});
        }
      }
      if (wide) std::erase_if(candidates, [&](const Candidate& c) { return !valid(c); });
      // The flatness penalty needs an eigen-solve per half: only for the best chords by length.
      constexpr std::size_t kScored = 32;
      std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
        return a.cost < b.cost || (a.cost == b.cost && std::tie(a.i, a.j) < std::tie(b.i, b.j));
      });
      if (candidates.size() > kScored) candidates.resize(kScored);
      std::vector<Vec3> h1, h2;
      for (Candidate& c : candidates) {
        h1.clear();
        h2.clear();
        for (std::size_t k = c.i; k <= c.j; ++k)
          h1.push_back(pool_[static_cast<std::size_t>(loop[k])]);
        for (std::size_t k = c.j; k != c.i; k = (k + 1) % n)
          h2.push_back(pool_[static_cast<std::size_t>(loop[k])]);
        h2.push_back(pool_[static_cast<std::size_t>(loop[c.i])]);
        c.cost += flatness_penalty(h1) + flatness_penalty(h2);
      }
      std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
        return a.cost < b.cost || (a.cost == b.cost && std::tie(a.i, a.j) < std::tie(b.i, b.j));
      });
      // The first valid candidate whose halves are both simple wins; else the best valid one.
      // Halves are tested without their chord points: those lie on the straight chord, which
      // projects to the same segment.
      chosen.reset();
      chosen_frames.reset();
      int valid_seen = 0;
      for (const Candidate& c : candidates) {
        if (!wide && !valid(c)) continue;
        const int a = loop[c.i];
        if (!chosen) chosen = c;
        std::vector<int> half1(loop.begin() + static_cast<std::ptrdiff_t>(c.i),
                               loop.begin() + static_cast<std::ptrdiff_t>(c.j) + 1);
        std::vector<int> half2;
        for (std::size_t k = c.j; k != c.i; k = (k + 1) % n) half2.push_back(loop[k]);
        half2.push_back(a);
        std::array<ReferenceFrame, 2> frames;
        if (find_simple_frame(half1, frames[0]) && find_simple_frame(half2, frames[1])) {
          chosen = c;
          chosen_frames = frames;
          break;
        }
        if (++valid_seen >= 5) break;
      }
    };
    choose(opt_.candidates_per_vertex, false);
    // None of the nearest few is clear of the mesh and enters the hole at both ends (a long
    // hole around a body, whose nearest vertices lie across it), and the piece is too large for
    // the 3D triangulation that closes unsplit pieces: a wider search (a 437-edge cut around the
    // shark's body, left open before, then closes). Smaller pieces keep going to the DP.
    if (!chosen && n > opt_.max_dp_vertices &&
        opt_.wide_candidates_per_vertex > opt_.candidates_per_vertex)
      choose(opt_.wide_candidates_per_vertex, true);
    if (!chosen) return false;
    halves = make_halves(piece, chosen->i, chosen->j);
    if (chosen_frames) {
      halves[0].frame = (*chosen_frames)[0];
      halves[1].frame = (*chosen_frames)[1];
    }
    return true;
  }

  //! Builds the two halves for chord (loop[i], loop[j]); chord points are appended to the pool.
  std::vector<Piece> make_halves(const Piece& piece, std::size_t i, std::size_t j) {
    const std::vector<int>& loop = piece.loop;
    const std::size_t n = loop.size();
    const int a = loop[i], b = loop[j];
    const Vec3 pa = pool_[static_cast<std::size_t>(a)], pb = pool_[static_cast<std::size_t>(b)];
    const double len = (pb - pa).norm();
    const int m = std::max(0, static_cast<int>(std::ceil(len / in_.mean_edge_length)) - 1);
    std::vector<int> chord;  // from a to b
    const Vec3 nrm = (normals_[static_cast<std::size_t>(a)] + normals_[static_cast<std::size_t>(b)])
                         .normalize_cond();
    for (int k = 1; k <= m; ++k) {
      chord.push_back(static_cast<int>(pool_.size()));
      pool_.push_back(pa + (pb - pa) * (static_cast<double>(k) / (m + 1)));
      normals_.push_back(nrm);
    }
    Piece h1, h2;
    h1.depth = h2.depth = piece.depth + 1;
    for (std::size_t k = i; k <= j; ++k) h1.loop.push_back(loop[k]);                  // a .. b
    for (auto it = chord.rbegin(); it != chord.rend(); ++it) h1.loop.push_back(*it);  // back to a
    for (std::size_t k = j; k != i; k = (k + 1) % n) h2.loop.push_back(loop[k]);  // b .. (before a)
    h2.loop.push_back(a);
    for (int c : chord) h2.loop.push_back(c);  // a -> b
    return {std::move(h1), std::move(h2)};
  }

  const PiecewiseInput& in_;
  const PiecewiseOptions& opt_;
  std::vector<Vec3> pool_;
  std::vector<Vec3> normals_;
  std::unordered_map<std::uint64_t, Vec3> opposite_;
  std::unordered_set<std::uint64_t> used_;
  PiecewiseResult result_;
};

}  // namespace

PiecewiseResult triangulate_piecewise(const PiecewiseInput& input,
                                      const PiecewiseOptions& options) {
  if (input.loop.size() < 3) {
    PiecewiseResult r;
    r.failure = "fewer than 3 boundary vertices";
    return r;
  }
  return PiecewiseFiller(input, options).run();
}

}  // namespace touchmend::geometry
