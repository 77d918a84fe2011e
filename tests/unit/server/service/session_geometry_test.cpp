#include "server/service/session_geometry.h"

#include <fstream>
#include <iterator>
#include <random>

#include <gtest/gtest.h>

#include "server/geometry/mesh_io.h"
#include "tests/support/cases.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::service {
namespace {

std::string sample() {
  std::string bytes;
  std::ifstream in(TOUCHMEND_SAMPLE_MESH, std::ios::binary);
  bytes.assign(std::istreambuf_iterator<char>(in), {});
  return bytes;
}

//! The sample (Spot with three holes) as a session's document.
rpc::MeshDocument sample_document() {
  LoadedMesh loaded;
  EXPECT_TRUE(load_document(sample(), geometry::MeshFormat::Off, {}, loaded).is_ok());
  return loaded.document;
}

std::vector<std::uint32_t> hole_ids(SessionGeometry& g, const rpc::MeshDocument& d) {
  std::vector<std::uint32_t> ids;
  for (const auto& h : g.holes(d)) ids.push_back(h.id());
  return ids;
}

//! Every property of the holes \p g lists, as bytes (loops, ids, measures).
std::vector<std::string> hole_listing(SessionGeometry& g, const rpc::MeshDocument& d) {
  std::vector<std::string> out;
  for (const auto& h : g.holes(d)) out.push_back(h.SerializeAsString());
  return out;
}

TEST(SessionGeometry, UndoAndRedoUpdateTheCacheLikeARebuild) {
  rpc::MeshDocument doc = sample_document();
  ASSERT_FALSE(doc.faces.empty());
  SessionGeometry cache;
  const auto before = hole_ids(cache, doc);
  ASSERT_EQ(before.size(), 3u);

  v1::HoleSelection selection;
  selection.mutable_ids()->add_ids(before[0]);
  auto filled = cache.fill(doc, selection, {}, {});
  ASSERT_TRUE(filled.status.is_ok()) << filled.status.to_string();
  ASSERT_TRUE(rpc::apply_delta(doc, filled.delta).is_ok());
  cache.commit_pending();
  EXPECT_EQ(hole_ids(cache, doc).size(), 2u);

  // Undo: the cache follows the inverse delta without a rebuild, and agrees with one.
  const v1::MeshDelta undo = rpc::invert_delta(filled.delta, doc);
  // The cache tells that the vertices the undo removes are free (apply_delta need not scan every
  // face for them), and that they are not when the delta keeps their faces.
  EXPECT_GT(undo.removed_vertices_size(), 0);
  EXPECT_TRUE(cache.removals_free(undo));
  v1::MeshDelta keeps_faces = undo;
  keeps_faces.clear_removed_faces();
  keeps_faces.clear_added_face_ids();
  keeps_faces.clear_added_faces();
  EXPECT_FALSE(cache.removals_free(keeps_faces));
  {
    rpc::MeshDocument copy = doc;
    EXPECT_FALSE(rpc::apply_delta(copy, keeps_faces).is_ok());  // the full check agrees
  }
  ASSERT_TRUE(rpc::apply_delta(doc, undo).is_ok());
  cache.apply(undo);
  EXPECT_TRUE(cache.cached());
  SessionGeometry rebuilt;
  EXPECT_EQ(hole_ids(cache, doc), hole_ids(rebuilt, doc));
  EXPECT_EQ(hole_ids(cache, doc), before);

  // Redo brings the same faces back in their old slots.
  const v1::MeshDelta redo = rpc::rebase_delta(filled.delta, doc.version);
  ASSERT_TRUE(rpc::apply_delta(doc, redo).is_ok());
  cache.apply(redo);
  EXPECT_TRUE(cache.cached());
  SessionGeometry rebuilt_again;
  EXPECT_EQ(hole_ids(cache, doc), hole_ids(rebuilt_again, doc));
  EXPECT_EQ(hole_ids(cache, doc).size(), 2u);

  // And the cache still fills: the next hole, then the export is closed where filled.
  v1::HoleSelection next;
  next.mutable_ids()->add_ids(before[1]);
  auto second = cache.fill(doc, next, {}, {});
  ASSERT_TRUE(second.status.is_ok()) << second.status.to_string();
  ASSERT_EQ(second.report.holes_size(), 1);
  EXPECT_TRUE(second.report.holes(0).filled());
  ASSERT_TRUE(rpc::apply_delta(doc, second.delta).is_ok());
  cache.commit_pending();
  EXPECT_EQ(hole_ids(cache, doc).size(), 1u);

  // A delta that does not follow the cached version makes it rebuild, not guess.
  v1::MeshDelta stale = redo;
  cache.apply(stale);
  EXPECT_FALSE(cache.cached());
  EXPECT_EQ(hole_ids(cache, doc).size(), 1u);
}

// Fill and undo, again and again, as an operator trying a hole does: the undo gives the cache
// mesh's arrays back (its elements are the last added), so they do not grow until a compaction
// (which read the whole mesh and made the holes and the search reach be found again), and each
// fill of the hole is the same as the first.
TEST(SessionGeometry, UndoGivesBackTheSlotsOfTheEditItUndoes) {
  rpc::MeshDocument doc = sample_document();
  ASSERT_FALSE(doc.faces.empty());
  SessionGeometry cache;
  const auto ids = hole_ids(cache, doc);
  ASSERT_EQ(ids.size(), 3u);
  const std::size_t vertices = cache.mesh_vertex_slots();
  const std::size_t faces = cache.mesh_face_slots();
  v1::MeshDelta first;
  for (int round = 0; round < 6; ++round) {
    v1::HoleSelection selection;
    selection.mutable_ids()->add_ids(ids[1]);
    auto filled = cache.fill(doc, selection, {}, {});
    ASSERT_TRUE(filled.status.is_ok()) << filled.status.to_string();
    ASSERT_GT(filled.delta.added_face_ids_size(), 0);
    ASSERT_TRUE(rpc::apply_delta(doc, filled.delta).is_ok());
    cache.commit_pending();
    EXPECT_GT(cache.mesh_face_slots(), faces);
    if (round == 0) {
      first = filled.delta;
    } else {
      EXPECT_EQ(filled.delta.added_positions().size(), first.added_positions().size());
      EXPECT_TRUE(std::equal(filled.delta.added_positions().begin(),
                             filled.delta.added_positions().end(), first.added_positions().begin(),
                             first.added_positions().end()))
          << "round " << round;
      EXPECT_EQ(filled.delta.added_faces_size(), first.added_faces_size());
    }
    const v1::MeshDelta undo = rpc::invert_delta(filled.delta, doc);
    ASSERT_TRUE(rpc::apply_delta(doc, undo).is_ok());
    cache.apply(undo);
    ASSERT_TRUE(cache.cached());
    ASSERT_EQ(cache.mirror_mismatch(doc), "") << "round " << round;
    EXPECT_LE(cache.mesh_vertex_slots(), vertices) << "round " << round;
    EXPECT_LE(cache.mesh_face_slots(), faces) << "round " << round;
    SessionGeometry rebuilt;
    ASSERT_EQ(hole_listing(cache, doc), hole_listing(rebuilt, doc)) << "round " << round;
    // A redo brings the faces back, as new elements of the cache; its undo takes them again.
    const v1::MeshDelta redo = rpc::rebase_delta(filled.delta, doc.version);
    ASSERT_TRUE(rpc::apply_delta(doc, redo).is_ok());
    cache.apply(redo);
    ASSERT_EQ(hole_ids(cache, doc).size(), 2u);
    const v1::MeshDelta undo_again = rpc::invert_delta(redo, doc);
    ASSERT_TRUE(rpc::apply_delta(doc, undo_again).is_ok());
    cache.apply(undo_again);
    ASSERT_TRUE(cache.cached());
    EXPECT_LE(cache.mesh_face_slots(), faces) << "round " << round;
  }
}

// Edits in a row as a session makes them: fills of random holes, undos and redos, the holes
// listed between them. The cache updates its holes from the vertices each edit touched
// (geometry::update_holes) instead of searching the mesh again; after every edit its listing is
// that of a cache built from the document.
TEST(SessionGeometry, HolesAfterEditsInARowAreThoseOfARebuild) {
  const geometry::MeshSoup soup =
      testing::remove_faces(testing::grid(24, 24), [](const geometry::Vec3& c) {
        const auto in = [&](double x, double y, double r) {
          return (c[0] - x) * (c[0] - x) + (c[1] - y) * (c[1] - y) < r * r;
        };
        return in(5, 5, 2.2) || in(12, 6, 1.6) || in(18, 17, 2.6) || in(6, 16, 1.2) ||
               (c[0] > 14 && c[0] < 15 && c[1] > 10 && c[1] < 11) ||
               (c[0] > 15 && c[0] < 16 && c[1] > 11 && c[1] < 12);
      });
  LoadedMesh loaded;
  ASSERT_TRUE(load_document(testing::to_off(soup), geometry::MeshFormat::Off, {}, loaded).is_ok());
  rpc::MeshDocument doc = loaded.document;
  SessionGeometry cache;
  std::vector<v1::MeshDelta> done, undone;
  std::mt19937 random(11);
  std::size_t fills = 0, undos = 0, redos = 0;
  for (int step = 0; step < 60; ++step) {
    const auto listing = hole_listing(cache, doc);
    const int kind = static_cast<int>(random() % 3);
    if (kind == 0 && !undone.empty()) {  // redo
      const v1::MeshDelta redo = rpc::rebase_delta(undone.back(), doc.version);
      undone.pop_back();
      ASSERT_TRUE(rpc::apply_delta(doc, redo).is_ok());
      cache.apply(redo);
      done.push_back(redo);
      ++redos;
    } else if (kind == 1 && !done.empty()) {  // undo
      const v1::MeshDelta undo = rpc::invert_delta(done.back(), doc);
      undone.push_back(done.back());
      done.pop_back();
      ASSERT_TRUE(rpc::apply_delta(doc, undo).is_ok());
      cache.apply(undo);
      ++undos;
    } else {  // fill one hole other than the grid's outer border
      const auto holes = cache.holes(doc);
      std::vector<std::uint32_t> inner;
      for (const auto& h : holes)
        if (h.boundary_edges() < 90) inner.push_back(h.id());
      if (inner.empty()) continue;
      v1::HoleSelection selection;
      selection.mutable_ids()->add_ids(inner[random() % inner.size()]);
      auto filled = cache.fill(doc, selection, {}, {});
      ASSERT_TRUE(filled.status.is_ok()) << filled.status.to_string();
      if (filled.delta.added_face_ids_size() == 0) {
        cache.discard_pending();  // left open, as Session::fill answers it
        continue;
      }
      ASSERT_TRUE(rpc::apply_delta(doc, filled.delta).is_ok());
      cache.commit_pending();
      done.push_back(filled.delta);
      undone.clear();
      ++fills;
    }
    ASSERT_TRUE(cache.cached()) << "step " << step;
    ASSERT_EQ(cache.mirror_mismatch(doc), "") << "step " << step;
    SessionGeometry rebuilt;
    ASSERT_EQ(hole_listing(cache, doc), hole_listing(rebuilt, doc)) << "step " << step;
    EXPECT_NE(hole_listing(cache, doc), listing) << "step " << step << ": the edit changed no hole";
  }
  EXPECT_GT(fills, 10u);
  EXPECT_GT(undos, 5u);
  EXPECT_GT(redos, 3u);
}

// A fill that leaves its hole open (the outline of a lone triangle: a fragment, not a hole) adds
// nothing; the cache stays (discard_pending), its holes those of a rebuild, and the next fill
// works on it.
TEST(SessionGeometry, AFillThatAddsNothingKeepsTheCache) {
  const geometry::MeshSoup soup = testing::with_lone_triangle(
      testing::remove_faces(
          testing::grid(10, 10),
          [](const geometry::Vec3& c) { return c[0] > 3 && c[0] < 6 && c[1] > 3 && c[1] < 6; }),
      {30, 0, 0});
  LoadedMesh loaded;
  ASSERT_TRUE(load_document(testing::to_off(soup), geometry::MeshFormat::Off, {}, loaded).is_ok());
  rpc::MeshDocument doc = loaded.document;
  SessionGeometry cache;
  std::uint32_t fragment = kNoId, hole = kNoId;
  for (const auto& h : cache.holes(doc)) {
    if (h.fragment_faces() > 0) fragment = h.id();
    if (h.boundary_edges() == 12) hole = h.id();
  }
  ASSERT_NE(fragment, kNoId);
  ASSERT_NE(hole, kNoId);
  v1::HoleSelection selection;
  selection.mutable_ids()->add_ids(fragment);
  auto left = cache.fill(doc, selection, {}, {});
  ASSERT_TRUE(left.status.is_ok()) << left.status.to_string();
  ASSERT_EQ(left.report.holes_size(), 1);
  EXPECT_FALSE(left.report.holes(0).filled());
  EXPECT_EQ(left.delta.added_face_ids_size(), 0);
  cache.discard_pending();
  EXPECT_TRUE(cache.cached());
  SessionGeometry rebuilt;
  EXPECT_EQ(hole_listing(cache, doc), hole_listing(rebuilt, doc));

  v1::HoleSelection next;
  next.mutable_ids()->add_ids(hole);
  auto filled = cache.fill(doc, next, {}, {});
  ASSERT_TRUE(filled.status.is_ok()) << filled.status.to_string();
  ASSERT_TRUE(rpc::apply_delta(doc, filled.delta).is_ok());
  cache.commit_pending();
  EXPECT_TRUE(cache.cached());
  SessionGeometry rebuilt_after;
  EXPECT_EQ(hole_listing(cache, doc), hole_listing(rebuilt_after, doc));
  EXPECT_EQ(hole_listing(cache, doc).size(), 2u);  // the grid's border and the fragment
}

}  // namespace
}  // namespace touchmend::service
