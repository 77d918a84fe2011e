#include "server/geometry/fairing.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>

#include "server/geometry/local_map.h"

namespace touchmend::geometry {
namespace {

//! The thin plate's system (k = 2 below) for a small patch, assembled dense and solved by a
//! dense Cholesky factorisation: A = the free block of C M^-1 C, rhs = -(its fixed block) known
//! (with a column of ones for the offset bump). \p triplets: the rows of C, row by row in
//! ascending order. Each entry sums its terms in the order the sparse product does (over the
//! middle index, ascending; C's duplicates in triplet order), so the result is the sparse
//! path's bit for bit, without its matrix copies (most of a small fairing's time). False when
//! the factorisation fails (the caller's general path then falls back to LU).
bool solve_thin_plate_dense(const std::vector<Eigen::Triplet<double>>& triplets,
                            const std::vector<double>& inverse_mass, int n, int n_free,
                            const Eigen::MatrixXd& known, bool offset_bump, Eigen::MatrixXd& x) {
  // known: the points' 3 columns, and a base surface's deviation.
  constexpr Eigen::Index kMaxKnownColumns = 4;
  if (known.cols() > kMaxKnownColumns) return false;
  // C by rows: each row's entries sorted by column, duplicates summed in triplet order.
  std::vector<int> row_start(static_cast<std::size_t>(n) + 1, 0);
  for (const auto& t : triplets) ++row_start[static_cast<std::size_t>(t.row()) + 1];
  for (int r = 0; r < n; ++r)
    row_start[static_cast<std::size_t>(r) + 1] += row_start[static_cast<std::size_t>(r)];
  std::vector<std::pair<int, double>> entries(triplets.size());
  {
    std::vector<int> next(row_start.begin(), row_start.end() - 1);
    for (const auto& t : triplets)
      entries[static_cast<std::size_t>(next[static_cast<std::size_t>(t.row())]++)] = {t.col(),
                                                                                      t.value()};
  }
  std::vector<int> row_end(static_cast<std::size_t>(n));
  for (int r = 0; r < n; ++r) {
    const auto first = entries.begin() + row_start[static_cast<std::size_t>(r)];
    const auto last = entries.begin() + row_start[static_cast<std::size_t>(r) + 1];
    std::stable_sort(first, last, [](const auto& a, const auto& b) { return a.first < b.first; });
    auto out = first;
    for (auto it = first; it != last; ++it) {
      if (out != first && std::prev(out)->first == it->first)
        std::prev(out)->second += it->second;
      else
        *out++ = *it;
    }
    row_end[static_cast<std::size_t>(r)] = static_cast<int>(out - entries.begin());
  }
  const int n_fixed = n - n_free;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n_free, n_free);
  // Row-major: the right-hand side below reads it row by row.
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> B =
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>::Zero(n_free, n_fixed);
  for (int i = 0; i < n_free; ++i)
    for (int e = row_start[static_cast<std::size_t>(i)]; e < row_end[static_cast<std::size_t>(i)];
         ++e) {
      const auto [middle, c_im] = entries[static_cast<std::size_t>(e)];
      const double m = inverse_mass[static_cast<std::size_t>(middle)];
      for (int f = row_start[static_cast<std::size_t>(middle)];
           f < row_end[static_cast<std::size_t>(middle)]; ++f) {
        const auto [column, c_mc] = entries[static_cast<std::size_t>(f)];
        const double term = c_im * (m * c_mc);
        if (column < n_free) {
          A(i, column) += term;
        } else {
          B(i, column - n_free) += term;
        }
      }
    }
  const Eigen::LLT<Eigen::MatrixXd> cholesky(A);
  if (cholesky.info() != Eigen::Success) return false;
  Eigen::MatrixXd rhs(n_free, known.cols() + (offset_bump ? 1 : 0));
  // The sparse product sums only B's entries, in column order; a zero of the dense B (not an
  // entry, or, never seen, one that cancelled to zero) adds a signed zero to the sum, which
  // leaves it as it is, so skipping zeros is the same sum.
  const Eigen::Index columns = known.cols();
  std::array<double, kMaxKnownColumns> sums;
  for (int i = 0; i < n_free; ++i) {
    sums.fill(0.0);
    for (int j = 0; j < n_fixed; ++j) {
      const double b = B(i, j);
      if (b == 0.0) continue;
      for (Eigen::Index c = 0; c < columns; ++c)
        sums[static_cast<std::size_t>(c)] += b * known(j, c);
    }
    for (Eigen::Index c = 0; c < columns; ++c) rhs(i, c) = -sums[static_cast<std::size_t>(c)];
  }
  if (offset_bump) rhs.col(known.cols()).setOnes();
  x = cholesky.solve(rhs);
  return x.allFinite();
}

double cotangent(const Vec3& a, const Vec3& b, const Vec3& c) {  // angle at a
  const Vec3 u = b - a, w = c - a;
  const double s = OpenMesh::cross(u, w).norm();
  return s > 0 ? OpenMesh::dot(u, w) / s : 0.0;
}

//! The surface the surroundings of a patch suggest: a sphere, or a quadratic height field
//! z = f(u, v) over the points' least-squares plane. The patch is faired as a deviation from it
//! (fair_vertices), so surroundings that lie on it are continued exactly.
struct BaseSurface {
  enum class Kind { Sphere, Quadric } kind = Kind::Quadric;
  Vec3 origin{0, 0, 0};  //!< sphere: centre; quadric: the points' centroid
  double radius = 0;
  Vec3 axis_u{1, 0, 0}, axis_v{0, 1, 0}, normal{0, 0, 1};  //!< quadric frame
  double scale = 1;  //!< u, v are divided by it (a well-conditioned fit)
  Eigen::Matrix<double, 6, 1> coefficients = Eigen::Matrix<double, 6, 1>::Zero();

  static Eigen::Matrix<double, 6, 1> monomials(double u, double v) {
    return {1, u, v, u * u, u * v, v * v};
  }
  //! Signed distance of \p p from the surface along the direction lifted() moves points.
  double deviation(const Vec3& p) const {
    const Vec3 d = p - origin;
    if (kind == Kind::Sphere) return d.norm() - radius;
    const double u = OpenMesh::dot(d, axis_u) / scale, v = OpenMesh::dot(d, axis_v) / scale;
    return OpenMesh::dot(d, normal) - coefficients.dot(monomials(u, v));
  }
  //! \p p moved to deviation \p height: along the radius (sphere) or the normal (quadric).
  Vec3 lifted(const Vec3& p, double height) const {
    if (kind == Kind::Quadric) return p + (height - deviation(p)) * normal;
    const Vec3 d = p - origin;
    const double length = d.norm();
    return length > 0 ? origin + d * ((radius + height) / length) : p;
  }
};

double rms_deviation(const BaseSurface& base, const std::vector<Vec3>& points) {
  double sum = 0;
  for (const Vec3& p : points) {
    const double d = base.deviation(p);
    sum += d * d;
  }
  return std::sqrt(sum / static_cast<double>(points.size()));
}

//! Least-squares sphere through \p points (|p - c|^2 = r^2 is linear in c and r^2 - |c|^2),
//! in coordinates centred on \p centroid and divided by \p scale.
std::optional<BaseSurface> fit_sphere(const std::vector<Vec3>& points, const Vec3& centroid,
                                      double scale) {
  // Normal equations, accumulated in fixed-size matrices (no allocation: this runs for every
  // faired patch); the coordinates are centred and scaled, so they are well conditioned.
  Eigen::Matrix4d normal_matrix = Eigen::Matrix4d::Zero();
  Eigen::Vector4d rhs = Eigen::Vector4d::Zero();
  for (const Vec3& p : points) {
    const Vec3 q = (p - centroid) / scale;
    const Eigen::Vector4d row(2 * q[0], 2 * q[1], 2 * q[2], 1);
    normal_matrix.selfadjointView<Eigen::Lower>().rankUpdate(row);
    rhs += q.sqrnorm() * row;
  }
  normal_matrix.triangularView<Eigen::StrictlyUpper>() = normal_matrix.transpose();
  const Eigen::ColPivHouseholderQR<Eigen::Matrix4d> qr(normal_matrix);
  if (qr.rank() < 4) return std::nullopt;
  const Eigen::Vector4d x = qr.solve(rhs);
  const double radius_squared = x[3] + x.head<3>().squaredNorm();
  if (!x.allFinite() || !(radius_squared > 0)) return std::nullopt;
  BaseSurface sphere;
  sphere.kind = BaseSurface::Kind::Sphere;
  sphere.origin = centroid + scale * Vec3(x[0], x[1], x[2]);
  sphere.radius = scale * std::sqrt(radius_squared);
  return sphere;
}

//! Least-squares quadratic height field over the plane of \p points' covariance.
std::optional<BaseSurface> fit_quadric(const std::vector<Vec3>& points, const Vec3& centroid,
                                       const Eigen::Matrix3d& axes, double scale) {
  const auto column = [&](int c) { return Vec3(axes(0, c), axes(1, c), axes(2, c)); };
  BaseSurface quadric;
  quadric.origin = centroid;
  quadric.normal = column(0);  // the eigenvalues ascend: the least spread is the normal
  quadric.axis_u = column(2);
  quadric.axis_v = OpenMesh::cross(quadric.normal, quadric.axis_u);
  quadric.scale = scale;
  Eigen::Matrix<double, 6, 6> normal_matrix = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
  for (const Vec3& p : points) {
    const Vec3 d = p - centroid;
    const Eigen::Matrix<double, 6, 1> row = BaseSurface::monomials(
        OpenMesh::dot(d, quadric.axis_u) / scale, OpenMesh::dot(d, quadric.axis_v) / scale);
    normal_matrix.selfadjointView<Eigen::Lower>().rankUpdate(row);
    rhs += OpenMesh::dot(d, quadric.normal) * row;
  }
  normal_matrix.triangularView<Eigen::StrictlyUpper>() = normal_matrix.transpose();
  const Eigen::ColPivHouseholderQR<Eigen::Matrix<double, 6, 6>> qr(normal_matrix);
  if (qr.rank() < 6) return std::nullopt;
  quadric.coefficients = qr.solve(rhs);
  if (!quadric.coefficients.allFinite()) return std::nullopt;
  return quadric;
}

//! The base surface of the fixed vertices in rings 1..\p rings around the free ones: whichever
//! of the sphere and the quadric fits them better, if its RMS deviation is within \p tolerance
//! times the points' spread; nothing otherwise (the surroundings are no such surface: plain
//! fairing).
std::optional<BaseSurface> fit_base_surface(const Mesh& mesh,
                                            const std::vector<VertexHandle>& vertices,
                                            const std::vector<int>& ring_of, int rings,
                                            double tolerance) {
  std::vector<Vec3> points;
  for (std::size_t i = 0; i < vertices.size(); ++i)
    if (ring_of[i] >= 1 && ring_of[i] <= rings) points.push_back(mesh.point(vertices[i]));
  if (points.size() < 12) return std::nullopt;  // twice the quadric's unknowns
  Vec3 centroid(0, 0, 0);
  for (const Vec3& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Vec3& p : points) {
    const Eigen::Vector3d d(p[0] - centroid[0], p[1] - centroid[1], p[2] - centroid[2]);
    covariance += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance);
  if (eigen.info() != Eigen::Success) return std::nullopt;
  const double spread =
      std::sqrt(std::max(eigen.eigenvalues().sum(), 0.0) / static_cast<double>(points.size()));
  if (!(spread > 0)) return std::nullopt;
  const double limit = tolerance * spread;
  std::optional<BaseSurface> sphere = fit_sphere(points, centroid, spread);
  std::optional<BaseSurface> quadric = fit_quadric(points, centroid, eigen.eigenvectors(), spread);
  const double sphere_rms = sphere ? rms_deviation(*sphere, points) : HUGE_VAL;
  const double quadric_rms = quadric ? rms_deviation(*quadric, points) : HUGE_VAL;
  // The sphere has 4 parameters, the quadric 6: the quadric must fit clearly better (points
  // on two circles of a sphere also lie on a paraboloid, which departs from it in between).
  if (sphere_rms <= limit && !(quadric_rms < 0.5 * sphere_rms - 1e-9 * spread)) return sphere;
  if (quadric_rms <= limit) return quadric;
  return std::nullopt;
}

//! Mean deviation from \p base of a triangle's corners.
double corner_deviation(const BaseSurface& base, const std::array<Vec3, 3>& p) {
  return (base.deviation(p[0]) + base.deviation(p[1]) + base.deviation(p[2])) / 3.0;
}

//! Mean deviation from \p base over triangle (a, b, c): the mean of its edge midpoints'
//! (exact for a quadratic function over the triangle, which a deviation is to second order).
double mean_deviation(const BaseSurface& base, const Vec3& a, const Vec3& b, const Vec3& c) {
  return (base.deviation(0.5 * (a + b)) + base.deviation(0.5 * (b + c)) +
          base.deviation(0.5 * (c + a))) /
         3.0;
}

//! Area-weighted sums over triangles of their deviation from a base surface: the triangles'
//! mean (by their edge midpoints) and their sag (that mean beyond their corners' mean).
struct FacetOffsets {
  double area = 0, facets = 0, sag = 0;
  //! Adds triangle \p p; returns its area.
  double add(const BaseSurface& base, const std::array<Vec3, 3>& p) {
    const double a = 0.5 * OpenMesh::cross(p[1] - p[0], p[2] - p[0]).norm();
    const double mean = mean_deviation(base, p[0], p[1], p[2]);
    area += a;
    facets += a * mean;
    sag += a * (mean - corner_deviation(base, p));
    return a;
  }
};

//! The base surface is fitted to the surroundings' vertices, but their triangles are chords
//! that lie inside a convex surface (outside a concave one) by up to an edge's sag: the surface
//! the mesh shows is offset from the fit by its triangles' mean deviation. A patch on the fit
//! shows its own triangles' offset instead, which depends on its edge lengths. The free
//! vertices are moved along the base surface's normal, by a multiple of \p bump (zero, with
//! its slope, at the fixed rings), until the patch's triangles lie where the surroundings'
//! would (below). Measured (mean distance to the ground truth): sphere966 #2 0.60 -> 0.56‰,
//! spot #0 0.46 -> 0.30‰, the subdivided sphere's 736 and 448 holes 1.08 -> 0.45‰ and
//! 1.59 -> 0.63‰; sphere966 #0 0.24 -> 0.26‰ and the subdivided 288 hole 0.43 -> 0.47‰.
template <typename Counts>
void match_facet_offset(Mesh& mesh, const BaseSurface& base,
                        const std::vector<VertexHandle>& vertices, const std::vector<int>& ring_of,
                        const std::vector<double>& bump, int fit_rings, const Counts& counts,
                        const std::function<bool(FaceHandle)>& in_patch) {
  LocalMap<int> ring(2 * vertices.size() + 16);
  for (std::size_t i = 0; i < vertices.size(); ++i) ring[vertices[i].idx()] = ring_of[i] + 1;
  // The surroundings' triangles (they do not move): how far they lie from the base surface
  // beyond their corners (the sag; the corners' own deviation is the fit's residual).
  FacetOffsets ring_offsets;
  double largest_fixed_deviation = 0;  // over the fixed vertices of the fit rings
  for (std::size_t i = 0; i < vertices.size(); ++i)
    if (ring_of[i] >= 1 && ring_of[i] <= fit_rings)
      largest_fixed_deviation =
          std::max(largest_fixed_deviation, std::abs(base.deviation(mesh.point(vertices[i]))));
  const int n_free = static_cast<int>(bump.size());
  LocalMap<double> bump_of(2 * bump.size() + 16);
  for (int i = 0; i < n_free; ++i)
    bump_of[vertices[static_cast<std::size_t>(i)].idx()] = bump[static_cast<std::size_t>(i)];
  struct PatchFace {
    std::array<VertexHandle, 3> corners;
    double bump = 0;  //!< the corners' mean bump
  };
  std::vector<PatchFace> patch;
  const auto points_of = [&mesh](const PatchFace& face) {
    return std::array<Vec3, 3>{mesh.point(face.corners[0]), mesh.point(face.corners[1]),
                               mesh.point(face.corners[2])};
  };
  LocalSet seen(4 * vertices.size() + 16);
  for (const VertexHandle v : vertices)
    for (const HalfedgeHandle h : mesh.voh_range(v)) {
      if (!counts(h)) continue;
      const FaceHandle f = mesh.face_handle(h);
      if (!seen.insert(f.idx())) continue;
      PatchFace face;
      face.corners = {v, mesh.to_vertex_handle(h),
                      mesh.to_vertex_handle(mesh.next_halfedge_handle(h))};
      int free = 0, in_rings = 0, outside_rim = 0;
      for (const VertexHandle w : face.corners) {
        const int* r = ring.find(w.idx());
        if (r && *r == 1) ++free;
        if (r && *r >= 2 && *r <= fit_rings + 1) ++in_rings;
        if (r && *r >= 3) ++outside_rim;
        if (const double* b = bump_of.find(w.idx())) face.bump += *b / 3.0;
      }
      if (free > 0 || (in_patch && in_patch(f))) {
        patch.push_back(face);
      } else if (in_rings == 3 && (in_patch || outside_rim > 0)) {
        // A face of the surroundings. Without in_patch, one with every corner on the hole's
        // rim may be the patch's own (a triangle across the rim): left out.
        ring_offsets.add(base, points_of(face));
      }
    }
  if (!(ring_offsets.area > 0)) return;
  const double ring_sag = ring_offsets.sag / ring_offsets.area;
  const double ring_facets = ring_offsets.facets / ring_offsets.area;
  // The patch's triangles lie their corners' deviation plus their own sag off the base
  // surface. The corners' deviation is the fairing's continuation of the fixed vertices'
  // deviations (real shape where the base surface departs from the surface: a sphere through
  // the two rims of a cylinder window bulges out of it), and only the sag differs from the
  // surroundings': the triangles are to lie their corners' deviation plus the surroundings' sag
  // off it. But the thin plate has no maximum principle: where the fixed vertices' deviations
  // are a tessellation's pattern (a subdivided coarse sphere's vertices lie on its flat facets,
  // inside the sphere), their slopes at the rim carry the patch out past all of them. Corners
  // deviating on average more than any fixed vertex does are such an overshoot, and then the
  // triangles are to lie as far off as the surroundings' triangles do on average.
  FacetOffsets patch_offsets;
  double slope = 0;
  for (const PatchFace& face : patch) slope += patch_offsets.add(base, points_of(face)) * face.bump;
  const double patch_area = patch_offsets.area, patch_facets = patch_offsets.facets,
               patch_sag = patch_offsets.sag;
  if (!(patch_area > 0) || !(std::abs(slope) > 0)) return;
  const double patch_corners = (patch_facets - patch_sag) / patch_area;
  const double target = std::abs(patch_corners) > largest_fixed_deviation
                            ? ring_facets
                            : (patch_facets + ring_sag * patch_area - patch_sag) / patch_area;
  // Moving the free vertices by s * bump along the base surface's normal moves a face's
  // midpoint mean by s times its corners' mean bump: exactly for the quadric (the normal is
  // fixed), to first order for the sphere, whose second step takes up the rest.
  const int steps = base.kind == BaseSurface::Kind::Sphere ? 2 : 1;
  double area_sum = patch_area, mean_sum = patch_facets;
  for (int step = 0; step < steps; ++step) {
    if (step > 0) {
      FacetOffsets moved;
      for (const PatchFace& face : patch) moved.add(base, points_of(face));
      area_sum = moved.area;
      mean_sum = moved.facets;
    }
    const double scale = (target * area_sum - mean_sum) / slope;
    if (!std::isfinite(scale)) return;
    for (int i = 0; i < n_free; ++i) {
      const VertexHandle v = vertices[static_cast<std::size_t>(i)];
      mesh.set_point(v, base.lifted(mesh.point(v), base.deviation(mesh.point(v)) +
                                                       scale * bump[static_cast<std::size_t>(i)]));
    }
  }
}

}  // namespace

FairingReport fair_vertices(Mesh& mesh, std::span<const VertexHandle> free_vertices,
                            const FairingOptions& options) {
  FairingReport report;
  report.free_vertices = free_vertices.size();
  if (free_vertices.empty()) {
    report.ok = true;
    return report;
  }
  const int k = std::clamp(options.continuity, 0, 2) + 1;
  const auto counts = [&](HalfedgeHandle side) {
    return !mesh.is_boundary(side) &&
           !(options.ignore_face && options.ignore_face(mesh.face_handle(side)));
  };
  // An edge exists for the operator when one of its faces does.
  const auto edge_counts = [&](HalfedgeHandle h) {
    return counts(h) || counts(mesh.opposite_halfedge_handle(h));
  };
  // Vertices within distance k of the free set: rows of L are needed up to distance k-1.
  LocalMap<int> local(4 * free_vertices.size() + 16);  // vertex index -> local index
  std::vector<VertexHandle> vertices;
  std::vector<int> ring_of;
  for (const VertexHandle v : free_vertices) {
    if (local.insert(v.idx(), static_cast<int>(vertices.size()))) {
      vertices.push_back(v);
      ring_of.push_back(0);
    }
  }
  std::size_t ring_begin = 0;
  const int fit_rings = std::max(options.base_fit_rings, 0);
  for (int ring = 1; ring <= std::max(k, fit_rings); ++ring) {
    const std::size_t ring_end = vertices.size();
    for (std::size_t i = ring_begin; i < ring_end; ++i)
      for (const HalfedgeHandle h : mesh.voh_range(vertices[i])) {
        if (!edge_counts(h)) continue;
        const VertexHandle w = mesh.to_vertex_handle(h);
        if (local.insert(w.idx(), static_cast<int>(vertices.size()))) {
          vertices.push_back(w);
          ring_of.push_back(ring);
        }
      }
    ring_begin = ring_end;
  }
  // The operator's stencil is the prefix of vertices within k rings; farther ones (gathered
  // for the base surface fit only) are not in the system.
  const int n = static_cast<int>(
      std::count_if(ring_of.begin(), ring_of.end(), [k](int ring) { return ring <= k; }));
  const int n_free = static_cast<int>(free_vertices.size());
  const std::optional<BaseSurface> base =
      fit_rings > 0
          ? fit_base_surface(mesh, vertices, ring_of, fit_rings, options.base_fit_tolerance)
          : std::nullopt;
  // L(v_i) = (1/A_i) Σ_j w_ij (x_j - x_i): rows for vertices of ring < k.
  std::vector<Eigen::Triplet<double>> triplets;
  std::vector<double> inverse_mass(static_cast<std::size_t>(n), 1.0);
  for (int i = 0; i < n; ++i) {
    if (ring_of[static_cast<std::size_t>(i)] >= k) continue;
    const VertexHandle v = vertices[static_cast<std::size_t>(i)];
    const Vec3& pv = mesh.point(v);
    double area = 0;
    double diagonal = 0;
    for (const HalfedgeHandle h : mesh.voh_range(v)) {
      if (!edge_counts(h)) continue;
      const VertexHandle w = mesh.to_vertex_handle(h);
      double weight = 1.0;
      if (options.weights == FairingWeights::Cotangent) {
        weight = 0;
        for (const HalfedgeHandle side : {h, mesh.opposite_halfedge_handle(h)}) {
          if (!counts(side)) continue;
          const VertexHandle o = mesh.to_vertex_handle(mesh.next_halfedge_handle(side));
          weight += 0.5 * cotangent(mesh.point(o), pv, mesh.point(w));
        }
        weight = std::clamp(weight, 1e-3, 1e3);  // obtuse slivers: keep the system well posed
      }
      const int* it = local.find(w.idx());
      if (!it) continue;  // cannot happen for rows of ring < k
      triplets.emplace_back(i, *it, weight);
      diagonal -= weight;
      if (counts(h)) {
        const Vec3& pw = mesh.point(w);
        const Vec3& po = mesh.point(mesh.to_vertex_handle(mesh.next_halfedge_handle(h)));
        area += OpenMesh::cross(pw - pv, po - pv).norm() / 6.0;  // a third of the face area
      }
    }
    triplets.emplace_back(i, i, diagonal);
    // L = M^-1 C: C holds the (symmetric) weights, M the vertex areas (uniform: valences).
    inverse_mass[static_cast<std::size_t>(i)] = options.weights == FairingWeights::Cotangent
                                                    ? 1.0 / std::max(area, 1e-300)
                                                    : 1.0 / std::max(-diagonal, 1.0);
  }
  Eigen::MatrixXd fixed(n - n_free, 3);
  for (int i = n_free; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      fixed(i - n_free, c) = mesh.point(vertices[static_cast<std::size_t>(i)])[c];
  // With a base surface, a fourth column carries the fixed vertices' deviations from it: its
  // solution is the faired deviation the free vertices get from it.
  Eigen::MatrixXd known(n - n_free, base ? 4 : 3);
  known.leftCols(3) = fixed;
  if (base)
    for (int i = n_free; i < n; ++i)
      known(i - n_free, 3) = base->deviation(mesh.point(vertices[static_cast<std::size_t>(i)]));
  // Matching the surroundings' facet offset (match_facet_offset) moves the patch by a multiple
  // of a bump that vanishes, with its slope, at the fixed rings: the same operator under a
  // uniform load (a clamped plate under pressure), a fifth column of the same solve. A uniform
  // shift instead would stand the triangles between the fixed rim and the moved vertices on
  // edge where a coarse patch meets a fine rim (measured: folds on the subdivided sphere).
  const bool offset_bump = base && options.match_facet_offset;
  Eigen::MatrixXd x;
  bool solved = k == 2 && n_free <= options.dense_up_to && options.direct_dense_assembly &&
                solve_thin_plate_dense(triplets, inverse_mass, n, n_free, known, offset_bump, x);
  // The general path: sparse, any k (and the LU fallback).
  if (!solved) {
    Eigen::SparseMatrix<double> C(n, n);
    C.setFromTriplets(triplets.begin(), triplets.end());
    // The free rows of C, made from their triplets: a block of rows of a column-major matrix is
    // copied entry by entry (with the copy of the product below, a third of a small fairing).
    // The same triplets in the same order: the same sums.
    std::erase_if(triplets,
                  [n_free](const Eigen::Triplet<double>& t) { return t.row() >= n_free; });
    Eigen::SparseMatrix<double> Lk(n_free, n);
    Lk.setFromTriplets(triplets.begin(), triplets.end());
    // The free rows of L^k x = 0, multiplied by the (invertible) free part of M, are the free rows
    // of C (M^-1 C)^(k-1) x = 0: same solution, and the free block of that matrix is symmetric
    // positive definite, so a Cholesky factorisation solves it (faster than LU on large
    // patches). LU remains the fallback.
    const Eigen::VectorXd minv = Eigen::Map<const Eigen::VectorXd>(inverse_mass.data(), n);
    if (k > 1) {
      const Eigen::SparseMatrix<double> MinvC = minv.asDiagonal() * C;  // scaled rows, one pass
      for (int p = 1; p < k; ++p) {
        Eigen::SparseMatrix<double> next = Lk * MinvC;
        Lk = std::move(next);
      }
    }
    Eigen::SparseMatrix<double> A = Lk.leftCols(n_free);
    const Eigen::SparseMatrix<double> B = Lk.rightCols(n - n_free);
    Eigen::MatrixXd rhs(n_free, known.cols() + (offset_bump ? 1 : 0));
    rhs.leftCols(known.cols()) = -(B * known);
    if (offset_bump) rhs.col(known.cols()).setOnes();
    A.makeCompressed();
    if (n_free <= options.dense_up_to) {
      // A small patch: a dense Cholesky factorisation costs less than the sparse one's ordering
      // and symbolic analysis (most holes of a scan are this small).
      const Eigen::LLT<Eigen::MatrixXd> cholesky{Eigen::MatrixXd(A)};
      if (cholesky.info() == Eigen::Success) {
        x = cholesky.solve(rhs);
        solved = x.allFinite();
      }
    } else {
      const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> cholesky(A);
      if (cholesky.info() == Eigen::Success) {
        x = cholesky.solve(rhs);
        solved = cholesky.info() == Eigen::Success && x.allFinite();
      }
    }
    if (!solved) {
      Eigen::SparseLU<Eigen::SparseMatrix<double>> lu;
      lu.analyzePattern(A);
      lu.factorize(A);
      if (lu.info() != Eigen::Success) {
        report.failure = "fairing system is singular";
        return report;
      }
      x = lu.solve(rhs);
      if (lu.info() != Eigen::Success || !x.allFinite()) {
        report.failure = "fairing solve failed";
        return report;
      }
    }
  }
  for (int i = 0; i < n_free; ++i) {
    Vec3 p(x(i, 0), x(i, 1), x(i, 2));
    if (base) p = base->lifted(p, x(i, 3));
    mesh.set_point(vertices[static_cast<std::size_t>(i)], p);
  }
  if (offset_bump) {
    std::vector<double> bump(static_cast<std::size_t>(n_free));
    for (int i = 0; i < n_free; ++i) bump[static_cast<std::size_t>(i)] = x(i, 4);
    match_facet_offset(mesh, *base, vertices, ring_of, bump, fit_rings, counts, options.in_patch);
  }
  if (base) report.base_surface = base->kind == BaseSurface::Kind::Sphere ? "sphere" : "quadric";
  report.ok = true;
  return report;
}

}  // namespace touchmend::geometry
