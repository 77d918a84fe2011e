#include "server/geometry/fairing.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>

#include "server/geometry/local_map.h"

namespace touchmend::geometry {
namespace {

double cotangent(const Vec3& a, const Vec3& b, const Vec3& c) {  // angle at a
  const Vec3 u = b - a, w = c - a;
  const double s = OpenMesh::cross(u, w).norm();
  return s > 0 ? OpenMesh::dot(u, w) / s : 0.0;
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
  for (int ring = 1; ring <= k; ++ring) {
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
  const int n = static_cast<int>(vertices.size());
  const int n_free = static_cast<int>(free_vertices.size());
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
  Eigen::SparseMatrix<double> C(n, n);
  C.setFromTriplets(triplets.begin(), triplets.end());
  // The free rows of L^k x = 0, multiplied by the (invertible) free part of M, are the free rows
  // of C (M^-1 C)^(k-1) x = 0: same solution, and the free block of that matrix is symmetric
  // positive definite, so a Cholesky factorisation solves it (faster than LU on large
  // patches). LU remains the fallback.
  const Eigen::VectorXd minv = Eigen::Map<const Eigen::VectorXd>(inverse_mass.data(), n);
  Eigen::SparseMatrix<double> Lk = C.topRows(n_free);
  if (k > 1) {
    const Eigen::SparseMatrix<double> MinvC = minv.asDiagonal() * C;  // scaled rows, one pass
    for (int p = 1; p < k; ++p) {
      const Eigen::SparseMatrix<double> next = Lk * MinvC;
      Lk = next;
    }
  }
  Eigen::SparseMatrix<double> A = Lk.leftCols(n_free);
  const Eigen::SparseMatrix<double> B = Lk.rightCols(n - n_free);
  Eigen::MatrixXd fixed(n - n_free, 3);
  for (int i = n_free; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      fixed(i - n_free, c) = mesh.point(vertices[static_cast<std::size_t>(i)])[c];
  const Eigen::MatrixXd rhs = -(B * fixed);
  A.makeCompressed();
  Eigen::MatrixXd x;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> cholesky(A);
  if (cholesky.info() == Eigen::Success) {
    x = cholesky.solve(rhs);
  }
  if (cholesky.info() != Eigen::Success || !x.allFinite()) {
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
  for (int i = 0; i < n_free; ++i)
    mesh.set_point(vertices[static_cast<std::size_t>(i)], Vec3(x(i, 0), x(i, 1), x(i, 2)));
  report.ok = true;
  return report;
}

}  // namespace touchmend::geometry
