#include "proto/rpc/mesh_document.h"

#include <cmath>

#include <gtest/gtest.h>

namespace touchmend::rpc {
namespace {

MeshDocument quad() {
  MeshDocument d;
  d.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  d.vertex_alive.assign(4, 1);
  d.faces = {{0, 1, 2}};
  d.face_alive = {1};
  return d;
}

v1::MeshDelta add_triangle(const MeshDocument& d) {
  v1::MeshDelta delta;
  delta.set_base_version(d.version);
  delta.set_version(d.version + 1);
  delta.add_added_vertex_ids(4);
  for (double c : {0.5, 0.5, 1.0}) delta.add_added_positions(c);
  delta.add_added_face_ids(1);
  for (std::uint32_t c : {0u, 2u, 3u}) delta.add_added_faces(c);
  delta.add_added_face_ids(2);
  for (std::uint32_t c : {0u, 3u, 4u}) delta.add_added_faces(c);
  return delta;
}

TEST(MeshDocument, AppliesAndUndoesAndRedoesADelta) {
  MeshDocument d = quad();
  const MeshDocument original = d;
  const v1::MeshDelta delta = add_triangle(d);
  ASSERT_TRUE(apply_delta(d, delta).is_ok());
  EXPECT_EQ(d.version, 1u);
  EXPECT_EQ(d.alive_faces(), 3u);
  EXPECT_EQ(d.alive_vertices(), 5u);
  const MeshDocument edited = d;

  ASSERT_TRUE(apply_delta(d, invert_delta(delta, d)).is_ok());
  EXPECT_EQ(d.alive_faces(), 1u);
  EXPECT_EQ(d.alive_vertices(), 4u);
  EXPECT_EQ(d.faces.size(), 3u);  // dead slots stay

  ASSERT_TRUE(apply_delta(d, rebase_delta(delta, d.version)).is_ok());
  MeshDocument expected = edited;
  expected.version = 3;
  EXPECT_EQ(d, expected);
  (void)original;
}

TEST(MeshDocument, UndoOfARemovalBringsTheContentsBack) {
  MeshDocument d = quad();
  v1::MeshDelta remove;
  remove.set_base_version(0);
  remove.set_version(1);
  remove.add_removed_faces(0);
  ASSERT_TRUE(apply_delta(d, remove).is_ok());
  EXPECT_EQ(d.alive_faces(), 0u);
  ASSERT_TRUE(apply_delta(d, invert_delta(remove, d)).is_ok());
  EXPECT_EQ(d.alive_faces(), 1u);
  EXPECT_EQ(d.faces[0], (std::array<std::uint32_t, 3>{0, 1, 2}));
}

TEST(MeshDocument, ABadDeltaChangesNothing) {
  MeshDocument d = quad();
  const MeshDocument before = d;
  v1::MeshDelta stale = add_triangle(d);
  stale.set_base_version(5);
  stale.set_version(6);
  EXPECT_EQ(apply_delta(d, stale).code, StatusCode::FailedPrecondition);

  v1::MeshDelta bad = add_triangle(d);
  bad.set_added_faces(5, 99);  // a corner that does not exist
  EXPECT_EQ(apply_delta(d, bad).code, StatusCode::InvalidArgument);

  v1::MeshDelta nan = add_triangle(d);
  nan.set_added_positions(0, std::nan(""));
  EXPECT_EQ(apply_delta(d, nan).code, StatusCode::InvalidArgument);

  v1::MeshDelta gap = add_triangle(d);
  gap.set_added_vertex_ids(0, 9);  // not the next slot
  EXPECT_EQ(apply_delta(d, gap).code, StatusCode::InvalidArgument);

  v1::MeshDelta in_use;
  in_use.set_base_version(0);
  in_use.set_version(1);
  in_use.add_removed_vertices(0);  // face 0 still uses it
  EXPECT_EQ(apply_delta(d, in_use).code, StatusCode::InvalidArgument);

  v1::MeshDelta ragged = add_triangle(d);
  ragged.add_added_positions(1.0);
  EXPECT_EQ(apply_delta(d, ragged).code, StatusCode::InvalidArgument);
  EXPECT_EQ(d, before);
}

TEST(MeshDocument, ProtoRoundTripAndValidation) {
  MeshDocument d = quad();
  d.version = 7;
  v1::MeshDocument proto;
  to_proto(d, proto);
  MeshDocument back;
  ASSERT_TRUE(from_proto(proto, back).is_ok());
  EXPECT_EQ(back, d);
  proto.set_faces(2, 40);
  EXPECT_EQ(from_proto(proto, back).code, StatusCode::InvalidArgument);
  to_proto(d, proto);
  proto.set_positions(4, std::numeric_limits<double>::infinity());
  EXPECT_EQ(from_proto(proto, back).code, StatusCode::InvalidArgument);
}

}  // namespace
}  // namespace touchmend::rpc
