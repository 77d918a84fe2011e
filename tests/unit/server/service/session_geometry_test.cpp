#include "server/service/session_geometry.h"

#include <fstream>
#include <iterator>

#include <gtest/gtest.h>

#include "server/geometry/mesh_io.h"
#include "tests/support/cases.h"

namespace touchmend::service {
namespace {

std::string sample() {
  std::string bytes;
  std::ifstream in(TOUCHMEND_SAMPLE_MESH, std::ios::binary);
  bytes.assign(std::istreambuf_iterator<char>(in), {});
  return bytes;
}

std::vector<std::uint32_t> hole_ids(SessionGeometry& g, const rpc::MeshDocument& d) {
  std::vector<std::uint32_t> ids;
  for (const auto& h : g.holes(d)) ids.push_back(h.id());
  return ids;
}

TEST(SessionGeometry, UndoAndRedoUpdateTheCacheLikeARebuild) {
  LoadedMesh loaded;
  ASSERT_TRUE(load_document(sample(), geometry::MeshFormat::Off, {}, loaded).is_ok());
  rpc::MeshDocument doc = loaded.document;
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

}  // namespace
}  // namespace touchmend::service
