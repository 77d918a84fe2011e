#pragma once

//! \file face_set.h
//! \brief Membership of faces in a patch (local_map.h: costs what the patch costs, not the mesh).

#include <vector>

#include "server/geometry/local_map.h"
#include "server/geometry/mesh.h"

namespace touchmend::geometry {

class FaceSet {
 public:
  explicit FaceSet(const std::vector<FaceHandle>& faces) : member_(faces.size() + 16) {
    for (const FaceHandle f : faces) insert(f);
  }
  void insert(FaceHandle f) { member_.insert(f.idx()); }
  bool contains(FaceHandle f) const { return f.is_valid() && member_.contains(f.idx()); }

 private:
  LocalSet member_;
};

}  // namespace touchmend::geometry
