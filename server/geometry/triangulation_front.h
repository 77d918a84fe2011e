#pragma once

//! \file triangulation_front.h
//! \brief The advancing front shared by the hole triangulators (internal).
//!
//! \details The front is a set of directed hole halfedges (hole on the left). Adding face
//! (a, b, c) adds its face-edges a->b, b->c, c->a; each either consumes the front halfedge
//! with the same direction or creates the reverse one (ALGORITHMS.md §0.1). That one rule
//! keeps every new face oriented like its neighbours. A face-edge whose undirected edge
//! already has a face (in the mesh or the patch) and is not on the front would become a
//! non-manifold edge and is refused.

#include <cstdint>
#include <span>
#include <unordered_set>
#include <utility>
#include <vector>

namespace touchmend::geometry::detail {

class TriangulationFront {
 public:
  //! \p n_vertices loop/pool size; \p loop_size the first loop_size vertices form the
  //! initial front 0->1->...->loop_size-1->0. \p blocked undirected vertex pairs that are
  //! already edges of the mesh outside the hole.
  TriangulationFront(std::size_t n_vertices, std::span<const int> loop,
                     std::span<const std::pair<int, int>> blocked);

  bool has_front_edge(int a, int b) const { return front_.count(key(a, b)) != 0; }
  //! Whether a face may contain face-edge a->b.
  bool can_add_face_edge(int a, int b) const {
    return has_front_edge(a, b) || used_.count(undirected(a, b)) == 0;
  }
  bool can_add_face(int a, int b, int c) const {
    return can_add_face_edge(a, b) && can_add_face_edge(b, c) && can_add_face_edge(c, a);
  }
  //! Adds face (a, b, c); returns the front halfedges it created (to queue them).
  std::vector<std::pair<int, int>> add_face(int a, int b, int c);

  bool empty() const { return front_.empty(); }
  std::size_t size() const { return front_.size(); }
  bool is_active(int v) const { return degree_[static_cast<std::size_t>(v)] > 0; }
  //! All current front halfedges (unordered).
  std::vector<std::pair<int, int>> edges() const;
  std::vector<int> active_vertices() const;
  //! Faces emitted so far, in order.
  const std::vector<std::array<int, 3>>& faces() const { return faces_; }

  static std::uint64_t key(int a, int b) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) |
           static_cast<std::uint32_t>(b);
  }
  static std::uint64_t undirected(int a, int b) { return a < b ? key(a, b) : key(b, a); }

 private:
  std::unordered_set<std::uint64_t> front_;
  std::unordered_set<std::uint64_t> used_;
  std::vector<int> degree_;
  std::vector<std::array<int, 3>> faces_;
};

}  // namespace touchmend::geometry::detail
