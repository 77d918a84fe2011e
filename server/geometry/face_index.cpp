#include "server/geometry/face_index.h"

#include <algorithm>
#include <cmath>
#include <utility>

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
  std::vector<FaceHandle> all(mesh.faces().begin(), mesh.faces().end());
  build(mesh, all);
}

FaceIndex::FaceIndex(const Mesh& mesh, std::span<const FaceHandle> faces) {
  build(mesh, faces);
}

void FaceIndex::build(const Mesh& mesh, std::span<const FaceHandle> faces) {
  if (faces.empty()) return;
  std::vector<Box3> boxes;
  boxes.reserve(faces.size());
  std::vector<double> extents;
  extents.reserve(faces.size());
  for (const FaceHandle f : faces) {
    boxes.push_back(face_box(mesh, f));
    extents.push_back(boxes.back().sizes().maxCoeff());
  }
  // Cells the size of a typical face's box: most faces fall into one to eight of them.
  const auto middle = extents.begin() + static_cast<std::ptrdiff_t>(extents.size() / 2);
  std::nth_element(extents.begin(), middle, extents.end());
  cell_size_ = std::max(*middle, 1e-300);
  faces_.reserve(faces.size());
  boxes_.reserve(faces.size());
  stamp_.reserve(faces.size());
  // Pass 1: each face's cells (or the unsorted list), counted per bucket; pass 2 files them.
  std::vector<std::array<Cell, 2>> ranges(faces.size());
  std::vector<char> gridded(faces.size(), 0);
  std::size_t entries = 0;
  for (std::size_t i = 0; i < faces.size(); ++i) {
    const std::uint32_t slot = add_slot(faces[i], boxes[i]);
    const Cell lo = cell_of(boxes[i].min()), hi = cell_of(boxes[i].max());
    const double cells = static_cast<double>(hi[0] - lo[0] + 1) *
                         static_cast<double>(hi[1] - lo[1] + 1) *
                         static_cast<double>(hi[2] - lo[2] + 1);
    if (!(cells <= kMaxCells)) {  // also NaN
      unsorted_.push_back(slot);
      continue;
    }
    ranges[i] = {lo, hi};
    gridded[i] = 1;
    entries += static_cast<std::size_t>(cells);
  }
  std::size_t buckets = 16;
  bucket_shift_ = 60;
  while (buckets < entries) {
    buckets *= 2;
    --bucket_shift_;
  }
  bucket_starts_.assign(buckets + 1, 0);
  const auto for_each_entry = [&](auto&& file) {
    for (std::size_t i = 0; i < faces.size(); ++i) {
      if (!gridded[i]) continue;
      const auto& [lo, hi] = ranges[i];
      for (std::int64_t x = lo[0]; x <= hi[0]; ++x)
        for (std::int64_t y = lo[1]; y <= hi[1]; ++y)
          for (std::int64_t z = lo[2]; z <= hi[2]; ++z)
            file(bucket_of(key_of({x, y, z})), static_cast<std::uint32_t>(i));
    }
  };
  for_each_entry([&](std::size_t b, std::uint32_t) { ++bucket_starts_[b + 1]; });
  for (std::size_t b = 0; b < buckets; ++b) bucket_starts_[b + 1] += bucket_starts_[b];
  cell_slots_.resize(entries);
  std::vector<std::uint32_t> next(bucket_starts_.begin(), bucket_starts_.end() - 1);
  // Slots are the faces' positions here: build() files every face before any insert().
  for_each_entry([&](std::size_t b, std::uint32_t slot) { cell_slots_[next[b]++] = slot; });
}

void FaceIndex::insert(const Mesh& mesh, FaceHandle f) {
  unsorted_.push_back(add_slot(f, face_box(mesh, f)));
}

std::uint32_t FaceIndex::add_slot(FaceHandle f, const Box3& box) {
  const auto slot = static_cast<std::uint32_t>(faces_.size());
  faces_.push_back(f.idx());
  boxes_.push_back(rounded(box));
  stamp_.push_back(0);
  return slot;
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
