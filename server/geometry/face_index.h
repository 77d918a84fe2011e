#pragma once

//! \file face_index.h
//! \brief A uniform grid over a set of a mesh's faces for local box queries (the intersection
//! checks of a fill look only at the faces near its hole).
//!
//! \details Each face is filed under every grid cell its bounding box overlaps (cells about the
//! size of a typical face, so most faces go into a few cells); the (cell, face) entries are
//! kept in two flat arrays grouped by a hash of the cell, so building costs two linear passes
//! and no allocation per cell, and a query reads the groups of the cells its box overlaps. A face
//! whose box would cover more than kMaxCells cells (a huge facet of a coarse CAD mesh) is on a list
//! every query checks. Deleted faces are skipped; faces added later with insert() are checked by
//! every query until the index is rebuilt (the fills add a patch at a time and rebuild per hole).

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "server/geometry/bvh.h"
#include "server/geometry/mesh.h"

namespace touchmend::geometry {

class FaceIndex {
 public:
  FaceIndex() = default;
  //! Files every non-deleted face of \p mesh. O(faces · log faces).
  explicit FaceIndex(const Mesh& mesh);
  //! Files just \p faces (a neighbourhood: a fill's checks only ever look near its hole).
  FaceIndex(const Mesh& mesh, std::span<const FaceHandle> faces);

  //! Files a face added after construction (a face already filed must not be filed again).
  void insert(const Mesh& mesh, FaceHandle f);

  //! Calls visit(face) once for every non-deleted filed face whose bounding box meets \p box.
  //! Not thread-safe (a visit stamp is kept per face).
  template <typename Visit>
  void for_each_in_box(const Mesh& mesh, const Box3& box, Visit&& visit) const {
    if (++query_ == 0) {  // the stamp wrapped around: start over
      std::fill(stamp_.begin(), stamp_.end(), 0);
      query_ = 1;
    }
    const auto consider = [&](std::uint32_t slot) {
      if (stamp_[slot] == query_) return;
      stamp_[slot] = query_;
      if (!boxes_[slot].meets(box)) return;
      const FaceHandle f(faces_[slot]);
      if (mesh.status(f).deleted()) return;
      visit(f);
    };
    for (const std::uint32_t slot : unsorted_) consider(slot);
    if (bucket_starts_.empty()) return;
    const Cell lo = cell_of(box.min()), hi = cell_of(box.max());
    const double span = static_cast<double>(hi[0] - lo[0] + 1) *
                        static_cast<double>(hi[1] - lo[1] + 1) *
                        static_cast<double>(hi[2] - lo[2] + 1);
    if (span > static_cast<double>(faces_.size())) {  // a query larger than the index
      for (std::uint32_t slot = 0; slot < faces_.size(); ++slot) consider(slot);
      return;
    }
    for (std::int64_t x = lo[0]; x <= hi[0]; ++x)
      for (std::int64_t y = lo[1]; y <= hi[1]; ++y)
        for (std::int64_t z = lo[2]; z <= hi[2]; ++z) {
          const std::size_t b = bucket_of(key_of({x, y, z}));
          for (std::uint32_t e = bucket_starts_[b]; e < bucket_starts_[b + 1]; ++e)
            consider(cell_slots_[e]);
        }
  }

  static Box3 face_box(const Mesh& mesh, FaceHandle f);

  static constexpr double kMaxCells = 64;

 private:
  using Cell = std::array<std::int64_t, 3>;
  //! A face's box in single precision, rounded outwards (a query may see a face whose box misses
  //! it by a rounding step, never miss one): 24 bytes a face instead of reading three vertices
  //! through the mesh at every query.
  struct FloatBox {
    float lo[3], hi[3];
    bool meets(const Box3& b) const {
      for (int k = 0; k < 3; ++k)
        if (static_cast<double>(hi[k]) < b.min()[k] || static_cast<double>(lo[k]) > b.max()[k])
          return false;
      return true;
    }
  };
  static FloatBox rounded(const Box3& box);
  Cell cell_of(const Eigen::Vector3d& p) const;
  static std::uint64_t key_of(const Cell& c);
  void build(const Mesh& mesh, std::span<const FaceHandle> faces);
  std::uint32_t add_slot(FaceHandle f, const Box3& box);

  double cell_size_ = 0;
  // Per filed face (its slot): the face, its box, the last query that saw it.
  std::vector<int> faces_;
  std::vector<FloatBox> boxes_;
  mutable std::vector<std::uint32_t> stamp_;
  // The grid: each (cell, face) entry filed under a bucket hashed from the cell, by one counting
  // sort (no comparison sort); a query reads the buckets of its cells. Other cells that hash to
  // the same bucket only add candidates, which the box test drops.
  std::size_t bucket_of(std::uint64_t key) const {
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> bucket_shift_);
  }
  int bucket_shift_ = 64;
  std::vector<std::uint32_t> bucket_starts_;  //!< a power of two plus one entries
  std::vector<std::uint32_t> cell_slots_;     //!< slots, ordered by bucket
  std::vector<std::uint32_t> unsorted_;       //!< huge faces, and faces inserted later
  mutable std::uint32_t query_ = 0;
};

}  // namespace touchmend::geometry
