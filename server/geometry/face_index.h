#pragma once

//! \file face_index.h
//! \brief A uniform grid over a mesh's faces for local box queries (the intersection checks of
//! every fill), built once per mesh and kept current as faces are added.
//!
//! \details Each face is filed under every grid cell its bounding box overlaps (cells about the
//! size of a typical face, so most faces go into a few cells), and a query looks at the cells its
//! box overlaps. A face whose box would cover more than kMaxCells cells (a huge facet of a coarse
//! CAD mesh) is kept on a separate list that every query checks. Deleted faces are skipped; faces
//! added later are filed with insert().

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "server/geometry/bvh.h"
#include "server/geometry/mesh.h"

namespace touchmend::geometry {

class FaceIndex {
 public:
  FaceIndex() = default;
  //! Files every non-deleted face of \p mesh. O(faces).
  explicit FaceIndex(const Mesh& mesh);

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
    const auto consider = [&](int face) {
      const auto i = static_cast<std::size_t>(face);
      if (i >= stamp_.size()) stamp_.resize(i + 1 + stamp_.size() / 2, 0);
      if (stamp_[i] == query_) return;
      stamp_[i] = query_;
      const FaceHandle f(face);
      if (!boxes_[i].meets(box) || mesh.status(f).deleted()) return;
      visit(f);
    };
    for (const int face : large_) consider(face);
    if (cells_.empty()) return;
    const auto lo = cell_of(box.min()), hi = cell_of(box.max());
    const double span = static_cast<double>(hi[0] - lo[0] + 1) *
                        static_cast<double>(hi[1] - lo[1] + 1) *
                        static_cast<double>(hi[2] - lo[2] + 1);
    if (span > 2.0 * static_cast<double>(cells_.size())) {
      for (const auto& [key, faces] : cells_)
        for (const int face : faces) consider(face);
      return;
    }
    for (std::int64_t x = lo[0]; x <= hi[0]; ++x)
      for (std::int64_t y = lo[1]; y <= hi[1]; ++y)
        for (std::int64_t z = lo[2]; z <= hi[2]; ++z) {
          const auto it = cells_.find(key_of({x, y, z}));
          if (it == cells_.end()) continue;
          for (const int face : it->second) consider(face);
        }
  }

  static Box3 face_box(const Mesh& mesh, FaceHandle f);

  static constexpr double kMaxCells = 64;

 private:
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
  void file(const Box3& box, int face);
  std::vector<FloatBox> boxes_;  //!< by face index
  using Cell = std::array<std::int64_t, 3>;
  Cell cell_of(const Eigen::Vector3d& p) const;
  static std::uint64_t key_of(const Cell& c);

  double cell_size_ = 0;
  std::unordered_map<std::uint64_t, std::vector<int>> cells_;
  std::vector<int> large_;
  mutable std::vector<std::uint32_t> stamp_;
  mutable std::uint32_t query_ = 0;
};

}  // namespace touchmend::geometry
