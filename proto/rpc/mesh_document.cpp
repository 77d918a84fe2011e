#include "proto/rpc/mesh_document.h"

#include <algorithm>
#include <cmath>
#include <unordered_set>

namespace touchmend::rpc {

std::size_t MeshDocument::alive_vertices() const {
  return static_cast<std::size_t>(std::count(vertex_alive.begin(), vertex_alive.end(), 1));
}
std::size_t MeshDocument::alive_faces() const {
  return static_cast<std::size_t>(std::count(face_alive.begin(), face_alive.end(), 1));
}

namespace {

Status invalid(std::string message) {
  return {StatusCode::InvalidArgument, std::move(message)};
}

bool finite3(const double* p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

}  // namespace

Status apply_delta(MeshDocument& document, const v1::MeshDelta& delta, bool removals_checked) {
  if (delta.base_version() != document.version || delta.version() != document.version + 1) {
    return {StatusCode::FailedPrecondition, "delta " + std::to_string(delta.base_version()) + "->" +
                                                std::to_string(delta.version()) +
                                                " does not follow version " +
                                                std::to_string(document.version)};
  }
  if (delta.added_positions_size() != 3 * delta.added_vertex_ids_size() ||
      delta.moved_positions_size() != 3 * delta.moved_vertex_ids_size() ||
      (delta.moved_from_size() != 0 && delta.moved_from_size() != delta.moved_positions_size()) ||
      delta.added_faces_size() != 3 * delta.added_face_ids_size()) {
    return invalid("delta arrays have inconsistent lengths");
  }
  // Validate against the document plus what the delta itself adds or removes (so a bad delta
  // changes nothing), then apply in place: no copy of the whole document per edit.
  const std::size_t nv = document.positions.size();
  const std::size_t nf = document.faces.size();
  std::unordered_set<std::uint32_t> removed_f, removed_v, revived_v, revived_f;
  for (std::uint32_t f : delta.removed_faces()) {
    if (f >= nf || !document.face_alive[f] || !removed_f.insert(f).second) {
      return invalid("delta removes face " + std::to_string(f) + " which is not alive");
    }
  }
  for (std::uint32_t v : delta.removed_vertices()) {
    if (v >= nv || !document.vertex_alive[v] || !removed_v.insert(v).second) {
      return invalid("delta removes vertex " + std::to_string(v) + " which is not alive");
    }
  }
  std::size_t appended_v = 0;
  for (int i = 0; i < delta.added_vertex_ids_size(); ++i) {
    const std::uint32_t v = delta.added_vertex_ids(i);
    if (!finite3(delta.added_positions().data() + 3 * i)) {
      return invalid("delta adds vertex " + std::to_string(v) + " at NaN/inf");
    }
    const bool append = v == nv + appended_v;
    const bool revive =
        v < nv && (!document.vertex_alive[v] || removed_v.count(v)) && revived_v.insert(v).second;
    if (!append && !revive) {
      return invalid("delta adds vertex " + std::to_string(v) + " into a used or far slot");
    }
    if (append) ++appended_v;
  }
  const auto alive_after = [&](std::uint32_t v) {
    if (v >= nv) return v < nv + appended_v;
    if (revived_v.count(v)) return true;
    return document.vertex_alive[v] != 0 && !removed_v.count(v);
  };
  for (int i = 0; i < delta.moved_vertex_ids_size(); ++i) {
    const std::uint32_t v = delta.moved_vertex_ids(i);
    if (!alive_after(v))
      return invalid("delta moves vertex " + std::to_string(v) + " which is not alive");
    if (!finite3(delta.moved_positions().data() + 3 * i)) {
      return invalid("delta moves vertex " + std::to_string(v) + " to NaN/inf");
    }
  }
  std::size_t appended_f = 0;
  for (int i = 0; i < delta.added_face_ids_size(); ++i) {
    const std::uint32_t f = delta.added_face_ids(i);
    const std::uint32_t c0 = delta.added_faces(3 * i), c1 = delta.added_faces(3 * i + 1),
                        c2 = delta.added_faces(3 * i + 2);
    for (std::uint32_t c : {c0, c1, c2}) {
      if (!alive_after(c)) {
        return invalid("delta adds face " + std::to_string(f) + " on vertex " + std::to_string(c) +
                       " which is not alive");
      }
    }
    if (c0 == c1 || c1 == c2 || c0 == c2) {
      return invalid("delta adds face " + std::to_string(f) + " with a repeated corner");
    }
    const bool append = f == nf + appended_f;
    const bool revive =
        f < nf && (!document.face_alive[f] || removed_f.count(f)) && revived_f.insert(f).second;
    if (!append && !revive) {
      return invalid("delta adds face " + std::to_string(f) + " into a used or far slot");
    }
    if (append) ++appended_f;
  }
  // A removed vertex may not keep alive faces (those of the document not removed here). One
  // pass over the faces against a flat mark per vertex: looking every corner up in the hash sets
  // made the undo of a fill on a 1.37M-face mesh take 40 ms.
  if (!removed_v.empty() && !removals_checked) {
    std::vector<std::uint8_t> dying(nv, 0);
    for (const std::uint32_t v : removed_v)
      if (!revived_v.count(v)) dying[v] = 1;
    for (std::size_t f = 0; f < nf; ++f) {
      if (!document.face_alive[f]) continue;
      for (std::uint32_t c : document.faces[f]) {
        if (dying[c] && !removed_f.count(static_cast<std::uint32_t>(f))) {
          return invalid("delta removes vertex " + std::to_string(c) + " still used by face " +
                         std::to_string(f));
        }
      }
    }
  }
  // Apply.
  for (std::uint32_t f : delta.removed_faces()) document.face_alive[f] = 0;
  for (std::uint32_t v : delta.removed_vertices()) document.vertex_alive[v] = 0;
  for (int i = 0; i < delta.added_vertex_ids_size(); ++i) {
    const std::uint32_t v = delta.added_vertex_ids(i);
    const double* p = delta.added_positions().data() + 3 * i;
    if (v == document.positions.size()) {
      document.positions.push_back({p[0], p[1], p[2]});
      document.vertex_alive.push_back(1);
    } else {
      document.positions[v] = {p[0], p[1], p[2]};
      document.vertex_alive[v] = 1;
    }
  }
  for (int i = 0; i < delta.moved_vertex_ids_size(); ++i) {
    const double* p = delta.moved_positions().data() + 3 * i;
    document.positions[delta.moved_vertex_ids(i)] = {p[0], p[1], p[2]};
  }
  for (int i = 0; i < delta.added_face_ids_size(); ++i) {
    const std::uint32_t f = delta.added_face_ids(i);
    const std::array<std::uint32_t, 3> corners{
        delta.added_faces(3 * i), delta.added_faces(3 * i + 1), delta.added_faces(3 * i + 2)};
    if (f == document.faces.size()) {
      document.faces.push_back(corners);
      document.face_alive.push_back(1);
    } else {
      document.faces[f] = corners;
      document.face_alive[f] = 1;
    }
  }
  document.version = delta.version();
  return {};
}

v1::MeshDelta invert_delta(const v1::MeshDelta& delta, const MeshDocument& document) {
  v1::MeshDelta inverse;
  inverse.set_session_id(delta.session_id());
  inverse.set_base_version(document.version);
  inverse.set_version(document.version + 1);
  for (std::uint32_t f : delta.added_face_ids()) inverse.add_removed_faces(f);
  for (std::uint32_t v : delta.added_vertex_ids()) inverse.add_removed_vertices(v);
  for (std::uint32_t v : delta.removed_vertices()) {
    if (v >= document.positions.size()) continue;  // apply_delta will refuse the inverse
    inverse.add_added_vertex_ids(v);
    for (double c : document.positions[v]) inverse.add_added_positions(c);
  }
  for (std::uint32_t f : delta.removed_faces()) {
    if (f >= document.faces.size()) continue;
    inverse.add_added_face_ids(f);
    for (std::uint32_t c : document.faces[f]) inverse.add_added_faces(c);
  }
  for (int i = 0; i < delta.moved_vertex_ids_size(); ++i) {
    inverse.add_moved_vertex_ids(delta.moved_vertex_ids(i));
    for (int k = 0; k < 3; ++k) {
      inverse.add_moved_positions(delta.moved_from_size() ? delta.moved_from(3 * i + k)
                                                          : delta.moved_positions(3 * i + k));
      inverse.add_moved_from(delta.moved_positions(3 * i + k));
    }
  }
  return inverse;
}

v1::MeshDelta rebase_delta(const v1::MeshDelta& delta, std::uint64_t base_version) {
  v1::MeshDelta again = delta;
  again.set_base_version(base_version);
  again.set_version(base_version + 1);
  return again;
}

void to_proto(const MeshDocument& document, v1::MeshDocument& out) {
  out.Clear();
  out.set_version(document.version);
  out.mutable_positions()->Reserve(static_cast<int>(3 * document.positions.size()));
  for (const auto& p : document.positions) {
    for (double c : p) out.add_positions(c);
  }
  for (auto a : document.vertex_alive) out.add_vertex_alive(a != 0);
  out.mutable_faces()->Reserve(static_cast<int>(3 * document.faces.size()));
  for (const auto& f : document.faces) {
    for (std::uint32_t c : f) out.add_faces(c);
  }
  for (auto a : document.face_alive) out.add_face_alive(a != 0);
}

Status from_proto(const v1::MeshDocument& in, MeshDocument& document) {
  if (in.positions_size() % 3 != 0 || in.vertex_alive_size() * 3 != in.positions_size() ||
      in.faces_size() % 3 != 0 || in.face_alive_size() * 3 != in.faces_size()) {
    return invalid("mesh document arrays have inconsistent lengths");
  }
  MeshDocument doc;
  doc.version = in.version();
  const std::size_t nv = static_cast<std::size_t>(in.vertex_alive_size());
  doc.positions.resize(nv);
  doc.vertex_alive.resize(nv);
  for (std::size_t i = 0; i < nv; ++i) {
    const double* p = in.positions().data() + 3 * i;
    if (!finite3(p)) return invalid("vertex " + std::to_string(i) + " is NaN/inf");
    doc.positions[i] = {p[0], p[1], p[2]};
    doc.vertex_alive[i] = in.vertex_alive(static_cast<int>(i)) ? 1 : 0;
  }
  const std::size_t nf = static_cast<std::size_t>(in.face_alive_size());
  doc.faces.resize(nf);
  doc.face_alive.resize(nf);
  for (std::size_t i = 0; i < nf; ++i) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t c = in.faces(static_cast<int>(3 * i) + k);
      if (c >= nv) return invalid("face " + std::to_string(i) + " has an out-of-range vertex");
      doc.faces[i][k] = c;
    }
    doc.face_alive[i] = in.face_alive(static_cast<int>(i)) ? 1 : 0;
  }
  document = std::move(doc);
  return {};
}

}  // namespace touchmend::rpc
