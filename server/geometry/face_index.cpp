#include "server/geometry/face_index.h"

#include <algorithm>
#include <cmath>

namespace touchmend::geometry {

Box3 FaceIndex::face_box(const Mesh& mesh, FaceHandle f) {
  Box3 box;
  for (const VertexHandle v : mesh.fv_range(f)) {
    const Vec3& p = mesh.point(v);
    box.extend(Eigen::Vector3d(p[0], p[1], p[2]));
  }
  return box;
}

FaceIndex::FaceIndex(const Mesh& mesh) {
  std::vector<double> extents;
  extents.reserve(mesh.n_faces());
  for (const FaceHandle f : mesh.faces()) extents.push_back(face_box(mesh, f).sizes().maxCoeff());
  if (extents.empty()) return;
  const auto middle = extents.begin() + static_cast<std::ptrdiff_t>(extents.size() / 2);
  std::nth_element(extents.begin(), middle, extents.end());
  // Cells the size of a typical face's box: most faces fall into one to eight of them.
  cell_size_ = std::max(*middle, 1e-300);
  stamp_.assign(mesh.n_faces(), 0);
  boxes_.resize(mesh.n_faces());
  cells_.reserve(2 * mesh.n_faces() + 1);
  for (const FaceHandle f : mesh.faces()) file(face_box(mesh, f), f.idx());
}

void FaceIndex::insert(const Mesh& mesh, FaceHandle f) {
  const Box3 box = face_box(mesh, f);
  if (!(cell_size_ > 0)) cell_size_ = std::max(box.sizes().maxCoeff(), 1e-300);  // was empty
  file(box, f.idx());
}

FaceIndex::FloatBox FaceIndex::rounded(const Box3& box) {
  FloatBox out;
  for (int k = 0; k < 3; ++k) {
    float lo = static_cast<float>(box.min()[k]), hi = static_cast<float>(box.max()[k]);
    if (static_cast<double>(lo) > box.min()[k]) lo = std::nextafter(lo, -HUGE_VALF);
    if (static_cast<double>(hi) < box.max()[k]) hi = std::nextafter(hi, HUGE_VALF);
    out.lo[k] = lo;
    out.hi[k] = hi;
  }
  return out;
}

void FaceIndex::file(const Box3& box, int face) {
  const auto i = static_cast<std::size_t>(face);
  if (i >= boxes_.size()) boxes_.resize(i + 1 + boxes_.size() / 2);
  boxes_[i] = rounded(box);
  const Cell lo = cell_of(box.min()), hi = cell_of(box.max());
  const double cells = static_cast<double>(hi[0] - lo[0] + 1) *
                       static_cast<double>(hi[1] - lo[1] + 1) *
                       static_cast<double>(hi[2] - lo[2] + 1);
  if (!(cells <= kMaxCells)) {  // also NaN
    large_.push_back(face);
    return;
  }
  for (std::int64_t x = lo[0]; x <= hi[0]; ++x)
    for (std::int64_t y = lo[1]; y <= hi[1]; ++y)
      for (std::int64_t z = lo[2]; z <= hi[2]; ++z) cells_[key_of({x, y, z})].push_back(face);
}

FaceIndex::Cell FaceIndex::cell_of(const Eigen::Vector3d& p) const {
  Cell c;
  for (int k = 0; k < 3; ++k) {
    const double x = std::floor(p[k] / cell_size_);
    // Far outside any real model: clamp (collisions only add candidates, never lose any).
    c[static_cast<std::size_t>(k)] = static_cast<std::int64_t>(std::clamp(x, -1e15, 1e15));
  }
  return c;
}

std::uint64_t FaceIndex::key_of(const Cell& c) {
  const auto bits = [](std::int64_t v) { return static_cast<std::uint64_t>(v) & 0x1FFFFFu; };
  return (bits(c[0]) << 42) | (bits(c[1]) << 21) | bits(c[2]);
}

}  // namespace touchmend::geometry
