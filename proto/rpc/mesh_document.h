#pragma once

//! \file mesh_document.h
//! \brief A session's mesh as the wire sees it: vertex and face slots whose ids never change,
//! and the deltas that edit them. Shared by the server (its authoritative copy) and every
//! client (a replica kept current from the delta stream), so both apply edits with the same
//! code and end with identical arrays.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "proto/rpc/status.h"
#include "touchmend/v1/repair.pb.h"

namespace touchmend::rpc {

struct MeshDocument {
  std::uint64_t version = 0;
  std::vector<std::array<double, 3>> positions;
  std::vector<std::uint8_t> vertex_alive;
  std::vector<std::array<std::uint32_t, 3>> faces;
  std::vector<std::uint8_t> face_alive;

  std::size_t alive_vertices() const;
  std::size_t alive_faces() const;
  bool operator==(const MeshDocument&) const = default;
};

//! Applies \p delta (checked: base version, ids, finite coordinates, faces on alive vertices).
//! On error the document is unchanged.
//! \p removals_checked: the caller has made sure that every vertex the delta removes is used by
//! no face but those it removes (a session's mesh cache tells in O(delta)); that check is then
//! not made here, where it is a pass over every face (2 ms of an undo at 1.37M faces).
Status apply_delta(MeshDocument& document, const v1::MeshDelta& delta,
                   bool removals_checked = false);

//! The edit that undoes \p delta on \p document (whose version becomes the base). Elements
//! the delta removed come back with the contents their dead slots still hold. (A new edit may
//! reuse dead slots only above every slot the applied history refers to: those belong to
//! undone edits whose redo the new edit discards, so an undo never meets a reused slot.)
v1::MeshDelta invert_delta(const v1::MeshDelta& delta, const MeshDocument& document);

//! \p delta again, re-based onto \p base_version (redo).
v1::MeshDelta rebase_delta(const v1::MeshDelta& delta, std::uint64_t base_version);

void to_proto(const MeshDocument& document, v1::MeshDocument& out);
//! Checks sizes, finiteness and face indices.
Status from_proto(const v1::MeshDocument& in, MeshDocument& document);

}  // namespace touchmend::rpc
