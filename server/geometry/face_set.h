#pragma once

//! \file face_set.h
//! \brief Membership of faces in a patch, indexed by face index (grows as faces are added).

#include <vector>

#include "server/geometry/mesh.h"

namespace touchmend::geometry {

class FaceSet {
 public:
  explicit FaceSet(const std::vector<FaceHandle>& faces) {
    for (const FaceHandle f : faces) insert(f);
  }
  void insert(FaceHandle f) {
    const auto i = static_cast<std::size_t>(f.idx());
    if (i >= member_.size()) member_.resize(i + 1 + member_.size() / 2, 0);
    member_[i] = 1;
  }
  bool contains(FaceHandle f) const {
    const auto i = static_cast<std::size_t>(f.idx());
    return f.is_valid() && i < member_.size() && member_[i] != 0;
  }

 private:
  std::vector<char> member_;
};

}  // namespace touchmend::geometry
