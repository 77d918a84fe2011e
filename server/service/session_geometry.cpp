#include "server/service/session_geometry.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <unordered_map>

#include <fmt/format.h>

#include "server/geometry/gap_bridging.h"
#include "server/geometry/intersection.h"
#include "server/geometry/local_map.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_intersections.h"
#include "server/geometry/metrics.h"

namespace touchmend::service {

using geometry::FaceHandle;
using geometry::HalfedgeHandle;
using geometry::VertexHandle;
using rpc::StatusCode;

Status load_document(std::string_view bytes, geometry::MeshFormat format, const MeshLimits& limits,
                     LoadedMesh& out) {
  if (bytes.size() > limits.max_upload_bytes) {
    return {StatusCode::ResourceExhausted, "mesh of " + std::to_string(bytes.size()) +
                                               " bytes exceeds the limit of " +
                                               std::to_string(limits.max_upload_bytes)};
  }
  geometry::ReadOptions read_options;
  read_options.max_elements = std::max(limits.max_vertices, limits.max_faces);
  geometry::ReadResult read = geometry::parse_mesh(bytes, format, read_options);
  if (!read.ok) return {StatusCode::InvalidArgument, read.error};
  if (read.soup.triangles.empty()) return {StatusCode::InvalidArgument, "the mesh has no faces"};
  if (read.soup.points.size() > limits.max_vertices ||
      read.soup.triangles.size() > limits.max_faces) {
    return {StatusCode::ResourceExhausted,
            "mesh of " + std::to_string(read.soup.points.size()) + " vertices and " +
                std::to_string(read.soup.triangles.size()) + " faces exceeds the limits (" +
                std::to_string(limits.max_vertices) + " vertices, " +
                std::to_string(limits.max_faces) + " faces)"};
  }
  geometry::BuildResult built = geometry::build_mesh(read.soup);
  rpc::MeshDocument doc;
  doc.positions.reserve(built.mesh.n_vertices());
  for (const auto v : built.mesh.vertices()) {
    const auto& p = built.mesh.point(v);
    doc.positions.push_back({p[0], p[1], p[2]});
  }
  doc.vertex_alive.assign(doc.positions.size(), 1);
  doc.faces.reserve(built.mesh.n_faces());
  for (const auto f : built.mesh.faces()) {
    std::array<std::uint32_t, 3> corners{};
    int k = 0;
    for (const auto v : built.mesh.fv_range(f)) corners[k++] = static_cast<std::uint32_t>(v.idx());
    doc.faces.push_back(corners);
  }
  doc.face_alive.assign(doc.faces.size(), 1);
  out.document = std::move(doc);
  out.validation = built.report;
  return {};
}

bool to_geometry_format(v1::MeshFormat format, geometry::MeshFormat& out) {
  switch (format) {
    case v1::OFF:
      out = geometry::MeshFormat::Off;
      return true;
    case v1::OBJ:
      out = geometry::MeshFormat::Obj;
      return true;
    case v1::PLY:
      out = geometry::MeshFormat::Ply;
      return true;
    case v1::STL:
      out = geometry::MeshFormat::Stl;
      return true;
    default:
      return false;
  }
}

bool to_push_finish(v1::PushFinish finish, geometry::PushFinish& out) {
  switch (finish) {
    case v1::PUSH_FINISH_FAIR:
      out = geometry::PushFinish::Fair;
      return true;
    case v1::PUSH_FINISH_SMOOTH:
      out = geometry::PushFinish::Smooth;
      return true;
    case v1::PUSH_FINISH_NONE:
      out = geometry::PushFinish::None;
      return true;
    default:
      return false;
  }
}

bool to_pick_tangents(v1::PickTangents tangents, geometry::PickTangents& out) {
  switch (tangents) {
    case v1::PICK_TANGENTS_CREASE:
      out = geometry::PickTangents::Crease;
      return true;
    case v1::PICK_TANGENTS_CHORD:
      out = geometry::PickTangents::Chord;
      return true;
    default:
      return false;
  }
}

geometry::FillOptions to_fill_options(const v1::FillOptions& options) {
  geometry::FillOptions o;
  if (options.refine_iterations() != 0)
    o.refine_iterations = static_cast<int>(options.refine_iterations());
  switch (options.shape()) {
    case v1::PATCH_SHAPE_FLAT:
      o.shape = geometry::PatchShape::Flat;
      break;
    case v1::PATCH_SHAPE_FAIR:
      o.shape = geometry::PatchShape::Fair;
      break;
    default:
      o.shape = geometry::PatchShape::Auto;
      break;
  }
  o.sharp = options.sharp() == v1::SHARP_OFF ? geometry::SharpMode::Off : geometry::SharpMode::Auto;
  if (options.crease_angle_deg() > 0 && options.crease_angle_deg() < 180) {
    o.creases.crease_angle_deg = options.crease_angle_deg();
    o.creases.partner_angle_deg = std::min(o.creases.partner_angle_deg, options.crease_angle_deg());
  }
  o.remove_fragments = options.remove_fragments();
  return o;
}

void to_proto(const geometry::ValidationReport& report, v1::ValidationSummary& out) {
  out.set_input_vertices(report.input_vertices);
  out.set_input_faces(report.input_faces);
  out.set_degenerate_faces(report.degenerate_faces);
  out.set_duplicate_faces(report.duplicate_faces);
  out.set_non_manifold_edges(report.non_manifold_edges);
  out.set_inconsistent_edges(report.inconsistent_edges);
  out.set_non_manifold_vertices(report.non_manifold_vertices);
  out.set_refused_faces(report.refused_faces.size());
  out.set_boundary_loops(report.boundary_loops);
}

void to_proto(const geometry::HoleFillReport& report, v1::HoleFillResult& out) {
  out.set_hole_id(report.hole_id);
  out.set_boundary_vertices(static_cast<std::uint32_t>(report.boundary_vertices));
  out.set_filled(report.filled);
  out.set_skipped(report.skipped);
  out.set_reason(report.reason);
  out.set_method(geometry::to_string(report.method));
  out.set_shape(geometry::to_string(report.shape));
  out.set_shape_reason(report.shape_reason);
  out.set_faces_added(static_cast<std::uint32_t>(report.faces_added));
  out.set_vertices_added(static_cast<std::uint32_t>(report.vertices_added));
  out.set_seconds(report.seconds);
  out.set_creases(report.creases);
  out.set_crease_curves(static_cast<std::uint32_t>(report.crease_curves));
  out.set_min_angle_deg(report.min_angle_deg);
  out.set_fragment_faces_removed(static_cast<std::uint32_t>(report.removed_faces.size()));
}

Status export_document(const rpc::MeshDocument& document, geometry::MeshFormat format, bool binary,
                       std::string& bytes) {
  // Compact: alive vertices in slot order, alive faces.
  geometry::MeshSoup soup;
  std::vector<std::uint32_t> compact(document.positions.size(), kNoId);
  for (std::size_t v = 0; v < document.positions.size(); ++v) {
    if (!document.vertex_alive[v]) continue;
    compact[v] = static_cast<std::uint32_t>(soup.points.size());
    const auto& p = document.positions[v];
    soup.points.emplace_back(p[0], p[1], p[2]);
  }
  for (std::size_t f = 0; f < document.faces.size(); ++f) {
    if (!document.face_alive[f]) continue;
    const auto& c = document.faces[f];
    soup.triangles.push_back({compact[c[0]], compact[c[1]], compact[c[2]]});
  }
  geometry::BuildResult built = geometry::build_mesh(soup);
  if (!built.report.refused_faces.empty()) {
    return {StatusCode::Internal, "the session's mesh has faces the exporter cannot represent"};
  }
  geometry::WriteOptions options;
  options.binary = binary;
  const geometry::WriteResult written =
      geometry::serialize_mesh(built.mesh, format, options, bytes);
  if (!written.ok) return {StatusCode::Internal, written.error};
  return {};
}

// ---------------------------------------------------------------------------------------

void SessionGeometry::sync(const rpc::MeshDocument& document) {
  if (valid_ && version_ == document.version) return;
  geometry::MeshSoup soup;
  soup.points.reserve(document.positions.size());
  for (const auto& p : document.positions) soup.points.emplace_back(p[0], p[1], p[2]);
  doc_of_mesh_face_.clear();
  mesh_of_doc_face_.assign(document.faces.size(), kNoId);
  for (std::size_t f = 0; f < document.faces.size(); ++f) {
    if (!document.face_alive[f]) continue;
    mesh_of_doc_face_[f] = static_cast<std::uint32_t>(doc_of_mesh_face_.size());
    soup.triangles.push_back(document.faces[f]);
    doc_of_mesh_face_.push_back(static_cast<std::uint32_t>(f));
  }
  mesh_ = geometry::build_mesh(soup).mesh;
  doc_of_mesh_vertex_.resize(document.positions.size());
  mesh_of_doc_vertex_.resize(document.positions.size());
  for (std::size_t v = 0; v < document.positions.size(); ++v) {
    doc_of_mesh_vertex_[v] = static_cast<std::uint32_t>(v);
    mesh_of_doc_vertex_[v] = static_cast<std::uint32_t>(v);
  }
  version_ = document.version;
  valid_ = true;
  forget_search();
  faces_at_rebuild_ = mesh_.n_faces();
  vertices_at_rebuild_ = mesh_.n_vertices();
}

std::string SessionGeometry::mirror_mismatch(const rpc::MeshDocument& document) const {
  if (!valid_) return "no cache";
  if (version_ != document.version)
    return fmt::format("cache of version {}, document {}", version_, document.version);
  const auto mapped = [](const std::vector<std::uint32_t>& map, std::size_t i) {
    return i < map.size() ? map[i] : kNoId;
  };
  for (std::size_t v = 0; v < document.positions.size(); ++v) {
    const std::uint32_t m = mapped(mesh_of_doc_vertex_, v);
    if (m == kNoId) {
      if (document.vertex_alive[v]) return fmt::format("alive vertex {} not in the cache", v);
      continue;
    }
    const VertexHandle h(static_cast<int>(m));
    if (m >= mesh_.n_vertices() || mesh_.status(h).deleted() || mapped(doc_of_mesh_vertex_, m) != v)
      return fmt::format("vertex {} maps to mesh vertex {}, which is not its", v, m);
    if (!document.vertex_alive[v]) {
      if (!mesh_.is_isolated(h)) return fmt::format("dead vertex {} has faces in the cache", v);
      continue;
    }
    const auto& p = document.positions[v];
    if (mesh_.point(h) != geometry::Vec3(p[0], p[1], p[2]))
      return fmt::format("vertex {} is elsewhere in the cache", v);
  }
  std::size_t mirrored = 0;
  for (std::size_t f = 0; f < document.faces.size(); ++f) {
    const std::uint32_t m = mapped(mesh_of_doc_face_, f);
    if (!document.face_alive[f]) {
      if (m != kNoId) return fmt::format("dead face {} maps to mesh face {}", f, m);
      continue;
    }
    const FaceHandle h(static_cast<int>(m));
    if (m == kNoId || m >= mesh_.n_faces() || mesh_.status(h).deleted() ||
        mapped(doc_of_mesh_face_, m) != f)
      return fmt::format("alive face {} has no face of its own in the cache", f);
    std::array<std::uint32_t, 3> corners{};
    int k = 0;
    for (const VertexHandle v : mesh_.fv_range(h))
      corners[static_cast<std::size_t>(k++)] = mapped(doc_of_mesh_vertex_, v.idx());
    const auto& want = document.faces[f];
    const bool same = corners == want ||
                      corners == std::array<std::uint32_t, 3>{want[1], want[2], want[0]} ||
                      corners == std::array<std::uint32_t, 3>{want[2], want[0], want[1]};
    if (!same) return fmt::format("face {} has other corners in the cache", f);
    ++mirrored;
  }
  std::size_t live = 0;
  for (std::size_t f = 0; f < mesh_.n_faces(); ++f)
    live += mesh_.status(FaceHandle(static_cast<int>(f))).deleted() ? 0 : 1;
  if (live != mirrored)
    return fmt::format("the cache has {} live faces, the document {}", live, mirrored);
  return {};
}

void SessionGeometry::cut_deleted_tail() {
  // An undo deletes what the edit it undoes added, at the end of the arrays: dropping it there
  // costs what it is, where a compaction reads the whole mesh and makes the holes and the search
  // reach be found again (at 1.37M faces a fill and its undo added 1,500 faces, and every 230 of
  // them a compaction put 20-80 ms into one request).
  // The holes' update reads the vertices the edits touched, some of them among those dropped:
  // it runs first (the loops it leaves pass live vertices only, all below the cut).
  if (!geometry::has_deleted_tail(mesh_)) return;
  if (holes_) search();
  touched_.clear();
  geometry::drop_deleted_tail(mesh_);
  // Deleted elements map to no document slot.
  doc_of_mesh_vertex_.resize(std::min(doc_of_mesh_vertex_.size(), mesh_.n_vertices()));
  doc_of_mesh_face_.resize(std::min(doc_of_mesh_face_.size(), mesh_.n_faces()));
  if (reach_) reach_->cut_back(mesh_.n_vertices(), mesh_.n_faces());
}

void SessionGeometry::bound_growth() {
  if (valid_) cut_deleted_tail();
  // Undo deletes faces in place and reused slots retire their old vertices; OpenMesh only
  // marks them. Once the arrays have grown by a quarter, garbage-collect in place: linear, and
  // far cheaper than rebuilding the mesh from the document. The document <-> mesh maps are
  // carried through by OpenMesh's handle tracking.
  if (!valid_ || (mesh_.n_faces() <= faces_at_rebuild_ + faces_at_rebuild_ / 4 + 1024 &&
                  mesh_.n_vertices() <= vertices_at_rebuild_ + vertices_at_rebuild_ / 4 + 1024))
    return;
  std::vector<VertexHandle> vertices;
  std::vector<std::uint32_t> vertex_docs;
  for (std::size_t v = 0; v < mesh_of_doc_vertex_.size(); ++v) {
    if (mesh_of_doc_vertex_[v] == kNoId) continue;
    vertices.emplace_back(static_cast<int>(mesh_of_doc_vertex_[v]));
    vertex_docs.push_back(static_cast<std::uint32_t>(v));
  }
  std::vector<FaceHandle> faces;
  std::vector<std::uint32_t> face_docs;
  for (std::size_t f = 0; f < mesh_of_doc_face_.size(); ++f) {
    if (mesh_of_doc_face_[f] == kNoId) continue;
    faces.emplace_back(static_cast<int>(mesh_of_doc_face_[f]));
    face_docs.push_back(static_cast<std::uint32_t>(f));
  }
  std::vector<VertexHandle*> vertex_pointers;
  vertex_pointers.reserve(vertices.size());
  for (VertexHandle& h : vertices) vertex_pointers.push_back(&h);
  std::vector<FaceHandle*> face_pointers;
  face_pointers.reserve(faces.size());
  for (FaceHandle& h : faces) face_pointers.push_back(&h);
  std::vector<geometry::Mesh::HalfedgeHandle*> no_halfedges;
  mesh_.garbage_collection(vertex_pointers, no_halfedges, face_pointers, true, true, true);
  forget_search();  // handles moved
  doc_of_mesh_vertex_.assign(mesh_.n_vertices(), kNoId);
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    if (!vertices[i].is_valid()) return invalidate();  // a tracked vertex was deleted: rebuild
    mesh_of_doc_vertex_[vertex_docs[i]] = static_cast<std::uint32_t>(vertices[i].idx());
    doc_of_mesh_vertex_[static_cast<std::size_t>(vertices[i].idx())] = vertex_docs[i];
  }
  doc_of_mesh_face_.assign(mesh_.n_faces(), kNoId);
  for (std::size_t i = 0; i < faces.size(); ++i) {
    if (!faces[i].is_valid()) return invalidate();
    mesh_of_doc_face_[face_docs[i]] = static_cast<std::uint32_t>(faces[i].idx());
    doc_of_mesh_face_[static_cast<std::size_t>(faces[i].idx())] = face_docs[i];
  }
  faces_at_rebuild_ = mesh_.n_faces();
  vertices_at_rebuild_ = mesh_.n_vertices();
}

void SessionGeometry::bound_touched() {
  // Edits that no search follows (undo and redo in a row) would let the list grow without end;
  // past an eighth of the vertices a search of the whole mesh costs about as much as the update.
  if (touched_.size() > 4096 + mesh_.n_vertices() / 8) {
    holes_.reset();
    touched_.clear();
  }
  // Vertices added since the reach's runs were boxed are read one by one by every search: once
  // there are a few thousand, they are boxed too (a pass over them alone; making the reach again
  // read the whole mesh, 40 ms at 1.37M faces).
  if (reach_ && mesh_.n_vertices() > reach_->blocks_below + 4096) reach_->box_new_vertices(mesh_);
}

void SessionGeometry::forget_search() {
  holes_.reset();
  touched_.clear();
  reach_.reset();
}

void SessionGeometry::note_moved(VertexHandle v) {
  touched_.push_back(v);
  for (const VertexHandle w : mesh_.vv_range(v)) touched_.push_back(w);
  if (reach_) reach_->note_moved(mesh_, v);
}

void SessionGeometry::note_edit(std::span<const FaceHandle> faces,
                                std::span<const VertexHandle> moved) {
  for (const VertexHandle v : moved) note_moved(v);
  for (const FaceHandle f : faces)
    if (f.is_valid() && !mesh_.status(f).deleted())
      for (const VertexHandle v : mesh_.fv_range(f)) touched_.push_back(v);
  if (reach_) reach_->note_reshaped(mesh_, faces);
  bound_touched();
}

void SessionGeometry::forget_bridged(std::span<const FaceHandle> faces) {
  // A bridge adds faces and vertices only (its delta has no moves), so the reach stays true once
  // its long faces are listed. The holes are searched again: its attempts that were taken out
  // again may have relinked loops that no face it kept touches.
  holes_.reset();
  touched_.clear();
  if (reach_) reach_->note_reshaped(mesh_, faces);
  bound_touched();
}

geometry::HoleSearchResult& SessionGeometry::search() {
  constexpr geometry::HoleSearchOptions kOptions{.compute_projectability = false};
  if (holes_ && !touched_.empty() && !geometry::update_holes(mesh_, *holes_, touched_, kOptions))
    holes_.reset();
  touched_.clear();
  if (!holes_) holes_ = geometry::find_holes(mesh_, kOptions);
  return *holes_;
}

std::uint32_t SessionGeometry::doc_vertex(std::size_t mesh_index) const {
  return mesh_index < doc_of_mesh_vertex_.size() ? doc_of_mesh_vertex_[mesh_index] : kNoId;
}

std::uint32_t SessionGeometry::doc_hole_id(const geometry::Hole& hole) const {
  std::uint32_t id = kNoId;
  for (const auto v : hole.loop) id = std::min(id, doc_vertex(static_cast<std::size_t>(v.idx())));
  return id;
}

v1::Hole SessionGeometry::hole_to_proto(const geometry::Hole& hole) const {
  v1::Hole out;
  out.set_id(doc_hole_id(hole));
  for (const auto v : hole.loop) out.add_loop(doc_vertex(static_cast<std::size_t>(v.idx())));
  out.set_boundary_edges(static_cast<std::uint32_t>(hole.size()));
  out.set_perimeter(hole.perimeter);
  out.set_area(hole.area);
  auto set = [](v1::Point3* p, const geometry::Vec3& v) {
    p->set_x(v[0]);
    p->set_y(v[1]);
    p->set_z(v[2]);
  };
  set(out.mutable_normal(), hole.normal);
  set(out.mutable_centroid(), hole.centroid);
  out.set_simple(hole.is_simple);
  out.set_unfillable_reason(hole.unfillable_reason);
  for (const auto v : hole.pinched_at)
    out.add_pinched_at(doc_vertex(static_cast<std::size_t>(v.idx())));
  out.set_fragment_faces(static_cast<std::uint32_t>(hole.fragment_faces));
  return out;
}

std::vector<v1::Hole> SessionGeometry::holes(const rpc::MeshDocument& document) {
  sync(document);
  std::vector<v1::Hole> out;
  for (auto& h : search().holes) {
    if (!h.projectability_computed) geometry::compute_hole_properties(mesh_, h, true);
    out.push_back(hole_to_proto(h));
  }
  return out;
}

SessionGeometry::Nearest SessionGeometry::nearest_hole(const rpc::MeshDocument& document,
                                                       const v1::Point3& point) {
  sync(document);
  Nearest result;
  auto& found = search();
  const geometry::Vec3 p(point.x(), point.y(), point.z());
  if (const auto nearest = geometry::find_nearest_hole(mesh_, found.holes, p)) {
    geometry::Hole& hole = found.holes[nearest->index];
    if (!hole.projectability_computed) geometry::compute_hole_properties(mesh_, hole, true);
    result.found = true;
    result.hole = hole_to_proto(hole);
    result.distance = nearest->distance;
  }
  return result;
}

SessionGeometry::FillOutcome SessionGeometry::fill(const rpc::MeshDocument& document,
                                                   const v1::HoleSelection& selection,
                                                   const v1::FillOptions& options,
                                                   const geometry::FillProgress& progress,
                                                   SlotExtent first_free) {
  FillOutcome outcome;
  if (options.refine_iterations() > 5) {
    outcome.status = {StatusCode::InvalidArgument, "refine_iterations must be 1-5 (0 = default)"};
    return outcome;
  }
  geometry::FillSelection sel;
  sel.max_boundary = options.max_boundary();
  switch (selection.mode_case()) {
    case v1::HoleSelection::kAll:
      sel.mode = geometry::FillSelection::Mode::All;
      break;
    case v1::HoleSelection::kIds:
      sel.mode = geometry::FillSelection::Mode::Ids;
      if (selection.ids().ids_size() == 0) {
        outcome.status = {StatusCode::InvalidArgument, "empty hole id list"};
        return outcome;
      }
      break;
    case v1::HoleSelection::kNear: {
      const auto& p = selection.near();
      if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) {
        outcome.status = {StatusCode::InvalidArgument, "the point is not finite"};
        return outcome;
      }
      sel.mode = geometry::FillSelection::Mode::Nearest;
      sel.point = geometry::Vec3(p.x(), p.y(), p.z());
      break;
    }
    default:
      outcome.status = {StatusCode::InvalidArgument, "no hole selection (all, ids or near)"};
      return outcome;
  }
  sync(document);
  if (sel.mode == geometry::FillSelection::Mode::Ids) {
    // Ids are document vertex ids; unknown ones are an error before anything changes.
    const auto& found = search();
    std::vector<std::uint32_t> unknown;
    for (const std::uint32_t id : selection.ids().ids()) {
      // A hole's id is the smallest document vertex id on its boundary (the mesh cache's
      // own indices differ once it has been compacted).
      const auto it = std::find_if(found.holes.begin(), found.holes.end(),
                                   [&](const geometry::Hole& h) { return doc_hole_id(h) == id; });
      if (it == found.holes.end()) {
        unknown.push_back(id);
      } else {
        sel.ids.push_back(it->id);
      }
    }
    if (!unknown.empty()) {
      std::string list;
      for (auto id : unknown) list += (list.empty() ? "" : ", ") + std::to_string(id);
      outcome.status = {StatusCode::NotFound, "no hole with id " + list + " (the mesh has " +
                                                  std::to_string(found.holes.size()) + " holes)"};
      return outcome;
    }
  }
  std::unordered_map<std::uint32_t, std::uint32_t> doc_ids_of_holes;  // geometry id -> doc id
  for (const auto& h : search().holes) doc_ids_of_holes[h.id] = doc_hole_id(h);
  const auto doc_id_of_hole = [&](std::uint32_t geometry_id) {
    const auto it = doc_ids_of_holes.find(geometry_id);
    return it != doc_ids_of_holes.end() ? it->second : doc_vertex(geometry_id);
  };
  const geometry::FillReport report =
      geometry::fill_holes(mesh_, sel, to_fill_options(options), progress, &search(), &reach_);
  // The next search updates the holes from the vertices this fill touched (update_holes): the
  // loops of the holes it worked on (filled, left open after attempts, or a fragment deleted)
  // and the corners of its new faces. Nothing else of the mesh changes in a fill.
  for (const auto& h : report.holes) {
    if (const auto i = geometry::find_hole_by_id(holes_->holes, h.hole_id))
      touched_.insert(touched_.end(), holes_->holes[*i].loop.begin(), holes_->holes[*i].loop.end());
    else
      holes_.reset();  // cannot happen (the fill reports the holes it was given): search again
    if (!holes_) break;
    for (const FaceHandle f : h.new_faces)
      if (!mesh_.status(f).deleted())
        for (const VertexHandle v : mesh_.fv_range(f)) touched_.push_back(v);
  }
  bound_touched();
  if (sel.mode == geometry::FillSelection::Mode::Nearest && report.holes.empty()) {
    outcome.status = {StatusCode::FailedPrecondition, "the mesh has no holes"};
    return outcome;
  }
  outcome.report.set_holes_found(static_cast<std::uint32_t>(report.holes_found));
  for (const std::uint32_t id : report.unknown_ids) outcome.report.add_unknown_ids(doc_vertex(id));
  std::vector<VertexHandle> new_vertices;
  std::vector<FaceHandle> new_faces;
  std::vector<FaceHandle> removed_faces;
  std::vector<VertexHandle> removed_vertices;
  for (const auto& h : report.holes) {
    v1::HoleFillResult* r = outcome.report.add_holes();
    to_proto(h, *r);
    r->set_hole_id(doc_id_of_hole(h.hole_id));
    removed_faces.insert(removed_faces.end(), h.removed_faces.begin(), h.removed_faces.end());
    removed_vertices.insert(removed_vertices.end(), h.removed_vertices.begin(),
                            h.removed_vertices.end());
    if (!h.filled) continue;
    for (const auto v : h.new_vertices) {
      if (!mesh_.status(v).deleted()) new_vertices.push_back(v);
    }
    for (const auto f : h.new_faces) {
      if (!mesh_.status(f).deleted()) new_faces.push_back(f);
    }
  }
  outcome.delta = edit_delta(document, std::move(new_vertices), std::move(new_faces), first_free);
  // Fragments deleted (FillOptions.remove_fragments): their document slots die with the edit.
  for (const FaceHandle f : removed_faces) {
    const auto i = static_cast<std::size_t>(f.idx());
    if (i >= doc_of_mesh_face_.size() || doc_of_mesh_face_[i] == kNoId) continue;
    outcome.delta.add_removed_faces(doc_of_mesh_face_[i]);
    pending_removed_faces_.push_back(static_cast<std::uint32_t>(i));
  }
  for (const VertexHandle v : removed_vertices) {
    const auto i = static_cast<std::size_t>(v.idx());
    if (i >= doc_of_mesh_vertex_.size() || doc_of_mesh_vertex_[i] == kNoId) continue;
    outcome.delta.add_removed_vertices(doc_of_mesh_vertex_[i]);
    pending_removed_vertices_.push_back(static_cast<std::uint32_t>(i));
  }
  return outcome;
}

v1::MeshDelta SessionGeometry::edit_delta(const rpc::MeshDocument& document,
                                          std::vector<VertexHandle> new_vertices,
                                          std::vector<FaceHandle> new_faces,
                                          SlotExtent first_free) {
  // The edit as a delta: new vertices and faces get free document slots, in order.
  v1::MeshDelta delta;
  delta.set_base_version(document.version);
  delta.set_version(document.version + 1);
  pending_vertex_map_.clear();
  pending_face_map_.clear();
  pending_removed_faces_.clear();
  pending_removed_vertices_.clear();
  pending_replaced_faces_.clear();
  // Slot allocation: dead slots from first_free on (reused), then the end of the arrays.
  std::uint32_t next_vertex = std::min<std::uint32_t>(
      first_free.vertices, static_cast<std::uint32_t>(document.positions.size()));
  std::uint32_t next_face =
      std::min<std::uint32_t>(first_free.faces, static_cast<std::uint32_t>(document.faces.size()));
  const auto take_vertex_slot = [&] {
    while (next_vertex < document.positions.size() && document.vertex_alive[next_vertex])
      ++next_vertex;
    return next_vertex++;
  };
  const auto take_face_slot = [&] {
    while (next_face < document.faces.size() && document.face_alive[next_face]) ++next_face;
    return next_face++;
  };
  // The new vertices' slots; the others' are doc_of_mesh_vertex_'s (a copy of that map per edit
  // was a memcpy of the whole mesh's vertices).
  geometry::LocalMap<std::uint32_t> new_slot(2 * new_vertices.size() + 16);
  const auto slot_of = [&](VertexHandle v) {
    const auto i = static_cast<std::size_t>(v.idx());
    if (const std::uint32_t* s = new_slot.find(v.idx())) return *s;
    return i < doc_of_mesh_vertex_.size() ? doc_of_mesh_vertex_[i] : kNoId;
  };
  // New elements get document ids in handle order, the order garbage collection keeps, so an
  // export lists them exactly as an in-process edit written to a file does.
  std::sort(new_vertices.begin(), new_vertices.end());
  std::sort(new_faces.begin(), new_faces.end());
  for (const auto v : new_vertices) {
    const auto& p = mesh_.point(v);
    const std::uint32_t slot = take_vertex_slot();
    new_slot.insert(v.idx(), slot);
    pending_vertex_map_.push_back(static_cast<std::uint32_t>(v.idx()));
    pending_vertex_map_.push_back(slot);
    delta.add_added_vertex_ids(slot);
    delta.add_added_positions(p[0]);
    delta.add_added_positions(p[1]);
    delta.add_added_positions(p[2]);
  }
  for (const auto f : new_faces) {
    const std::uint32_t slot = take_face_slot();
    pending_face_map_.push_back(static_cast<std::uint32_t>(f.idx()));
    pending_face_map_.push_back(slot);
    delta.add_added_face_ids(slot);
    for (const auto v : mesh_.fv_range(f)) {
      delta.add_added_faces(slot_of(v));
    }
  }
  pending_version_ = document.version + 1;
  return delta;
}

SessionGeometry::FillOutcome SessionGeometry::stitch(const rpc::MeshDocument& document,
                                                     std::uint32_t a, std::uint32_t b,
                                                     std::uint32_t t, SlotExtent first_free) {
  FillOutcome outcome;
  sync(document);
  const auto mesh_vertex = [&](std::uint32_t id) {
    const std::uint32_t m = id < mesh_of_doc_vertex_.size() ? mesh_of_doc_vertex_[id] : kNoId;
    return m == kNoId || id >= document.vertex_alive.size() || !document.vertex_alive[id]
               ? VertexHandle()
               : VertexHandle(static_cast<int>(m));
  };
  const VertexHandle va = mesh_vertex(a), vb = mesh_vertex(b), vt = mesh_vertex(t);
  if (!va.is_valid() || !vb.is_valid() || !vt.is_valid()) {
    outcome.status = {StatusCode::NotFound, "no vertex with one of the ids " + std::to_string(a) +
                                                ", " + std::to_string(b) + ", " +
                                                std::to_string(t)};
    return outcome;
  }
  const geometry::StitchResult r = geometry::stitch_triangle(mesh_, va, vb, vt);
  if (!r.ok) {
    outcome.status = {StatusCode::FailedPrecondition, "stitch refused: " + r.reason};
    return outcome;
  }
  note_edit(std::span<const FaceHandle>(&r.face, 1), {});
  outcome.delta = edit_delta(document, {}, {r.face}, first_free);
  return outcome;
}

namespace {

bool finite_point(const v1::Point3& p) {
  return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z());
}

geometry::Vec3 to_vec(const v1::Point3& p) {
  return {p.x(), p.y(), p.z()};
}

}  // namespace

std::optional<geometry::Hole> SessionGeometry::hole_by_doc_id(std::uint32_t id) {
  for (const geometry::Hole& h : search().holes)
    if (doc_hole_id(h) == id) return h;
  return std::nullopt;
}

SessionGeometry::FillOutcome SessionGeometry::sharpen(const rpc::MeshDocument& document,
                                                      const v1::SharpenRequest& request,
                                                      SlotExtent first_free, std::string& summary) {
  FillOutcome outcome;
  if (request.points_size() % 4 != 0 ||
      (request.points_size() == 0 && request.corner_size() == 0)) {
    outcome.status = {StatusCode::InvalidArgument,
                      "four points per curve are needed: P1, P2 on one side of the hole, P3, P4 "
                      "on the other"};
    return outcome;
  }
  if (request.corner_size() % 2 != 0 || (request.corner_size() > 0 && request.corner_size() < 6)) {
    outcome.status = {StatusCode::InvalidArgument,
                      "a corner needs two points per crease (away from the hole, at the rim) and "
                      "three creases or more"};
    return outcome;
  }
  const bool one_curve = request.points_size() == 4 && request.corner_size() == 0;
  if (!one_curve && request.method() == v1::SHARPEN_PUSH_DOWN) {
    outcome.status = {StatusCode::InvalidArgument,
                      "several curves or a corner are retained by the split method only"};
    return outcome;
  }
  if (!std::all_of(request.points().begin(), request.points().end(), finite_point) ||
      !std::all_of(request.corner().begin(), request.corner().end(), finite_point)) {
    outcome.status = {StatusCode::InvalidArgument, "a point is not finite"};
    return outcome;
  }
  if (!(request.depth() >= 0) || !(request.k1() >= 0) || !(request.k4() >= 0) ||
      !std::isfinite(request.depth() + request.k1() + request.k4())) {
    outcome.status = {StatusCode::InvalidArgument, "k1, k4 and depth must be finite and >= 0"};
    return outcome;
  }
  if (request.fill().refine_iterations() > 5) {
    outcome.status = {StatusCode::InvalidArgument, "refine_iterations must be 1-5 (0 = default)"};
    return outcome;
  }
  geometry::SharpenOptions options;
  options.method = request.method() == v1::SHARPEN_PUSH_DOWN ? geometry::SharpenMethod::PushDown
                                                             : geometry::SharpenMethod::Split;
  if (request.depth() > 0 && options.method != geometry::SharpenMethod::PushDown) {
    outcome.status = {StatusCode::InvalidArgument, "depth applies to the push-down method"};
    return outcome;
  }
  options.hermite.k1 = request.k1();
  options.hermite.k4 = request.k4();
  options.depth = request.depth();
  if (!to_push_finish(request.finish(), options.finish)) {
    outcome.status = {StatusCode::InvalidArgument,
                      "unknown push-down finish " + std::to_string(request.finish())};
    return outcome;
  }
  if (!to_pick_tangents(request.tangents(), options.tangents)) {
    outcome.status = {StatusCode::InvalidArgument,
                      "unknown pick tangents " + std::to_string(request.tangents())};
    return outcome;
  }
  options.fill = to_fill_options(request.fill());
  sync(document);
  const auto hole = hole_by_doc_id(request.hole_id());
  if (!hole) {
    outcome.status = {StatusCode::NotFound, "no hole with id " + std::to_string(request.hole_id())};
    return outcome;
  }
  geometry::PickedCreases picked;
  for (int i = 0; i + 3 < request.points_size(); i += 4)
    picked.curves.push_back({to_vec(request.points(i)), to_vec(request.points(i + 1)),
                             to_vec(request.points(i + 2)), to_vec(request.points(i + 3))});
  for (int i = 0; i + 1 < request.corner_size(); i += 2)
    picked.corner.push_back({to_vec(request.corner(i)), to_vec(request.corner(i + 1))});
  const geometry::SharpenResult r =
      one_curve ? geometry::sharpen_hole(mesh_, *hole, picked.curves[0], options)
                : geometry::sharpen_creases(mesh_, *hole, picked, options);
  // As a fill: what changed is inside the hole's loop (the delta says no more), the patch's
  // vertices are new ones (the reach reads them one by one), its long faces are listed.
  touched_.insert(touched_.end(), hole->loop.begin(), hole->loop.end());
  note_edit(r.ok ? std::span<const FaceHandle>(r.patch) : std::span<const FaceHandle>(), {});
  if (!r.ok) {
    outcome.status = {StatusCode::FailedPrecondition, "sharpen refused: " + r.failure};
    return outcome;
  }
  v1::HoleFillResult* result = outcome.report.add_holes();
  to_proto(r.fill, *result);
  result->set_hole_id(request.hole_id());
  outcome.report.set_holes_found(1);
  // The patch's vertices that the document does not have yet (curve, refinement, splits).
  const auto is_new = [&](VertexHandle v) {
    const auto i = static_cast<std::size_t>(v.idx());
    return i >= doc_of_mesh_vertex_.size() || doc_of_mesh_vertex_[i] == kNoId;
  };
  std::vector<VertexHandle> vertices;
  std::set<int> seen;
  for (const FaceHandle f : r.patch)
    for (const VertexHandle v : mesh_.fv_range(f))
      if (is_new(v) && seen.insert(v.idx()).second) vertices.push_back(v);
  const std::string tangents =
      geometry::tangents_summary(r.crease_tangent_start, r.crease_tangent_end, options.tangents);
  summary =
      options.method == geometry::SharpenMethod::PushDown
          ? fmt::format("sharp edge retained on hole {} (push-down: {}; {})", request.hole_id(),
                        geometry::push_down_summary(r, options.finish), tangents)
      : one_curve
          ? fmt::format("sharp edge retained on hole {} (split along the curve; {})",
                        request.hole_id(), tangents)
          : fmt::format("sharp edges retained on hole {} (split along {})", request.hole_id(),
                        geometry::creases_summary(r, picked, options.tangents));
  outcome.delta = edit_delta(document, std::move(vertices), r.patch, first_free);
  return outcome;
}

std::vector<geometry::Gap> SessionGeometry::gaps(const rpc::MeshDocument& document,
                                                 double max_width) {
  sync(document);
  geometry::GapOptions options;
  options.max_width = max_width;
  return geometry::find_gaps(mesh_, search().holes, options);
}

v1::Gap SessionGeometry::gap_to_proto(const geometry::Gap& gap) const {
  v1::Gap out;
  out.set_id(gap.id);
  for (const auto& h : holes_ ? holes_->holes : std::vector<geometry::Hole>{}) {
    if (h.id == gap.hole_a) out.set_hole_a(doc_hole_id(h));
    if (h.id == gap.hole_b) out.set_hole_b(doc_hole_id(h));
  }
  for (const VertexHandle v : gap.run_a)
    out.add_run_a(doc_vertex(static_cast<std::size_t>(v.idx())));
  for (const VertexHandle v : gap.run_b)
    out.add_run_b(doc_vertex(static_cast<std::size_t>(v.idx())));
  out.set_cyclic(gap.cyclic);
  out.set_mean_width(gap.mean_width);
  out.set_max_width(gap.max_width);
  out.set_length(gap.length);
  return out;
}

SessionGeometry::FillOutcome SessionGeometry::bridge(const rpc::MeshDocument& document,
                                                     const v1::BridgeGapsRequest& request,
                                                     SlotExtent first_free, std::string& summary) {
  FillOutcome outcome;
  if (!(request.max_width() >= 0) || !std::isfinite(request.max_width())) {
    outcome.status = {StatusCode::InvalidArgument, "max_width must be finite and >= 0"};
    return outcome;
  }
  if (request.fill().refine_iterations() > 5) {
    outcome.status = {StatusCode::InvalidArgument, "refine_iterations must be 1-5 (0 = default)"};
    return outcome;
  }
  const geometry::FillOptions fill = to_fill_options(request.fill());
  std::vector<FaceHandle> faces;
  std::vector<VertexHandle> vertices;
  const auto collect = [&](const geometry::HoleFillReport& f) {
    to_proto(f, *outcome.report.add_holes());
    if (!f.filled) return;
    for (const auto v : f.new_vertices)
      if (!mesh_.status(v).deleted()) vertices.push_back(v);
    for (const auto x : f.new_faces)
      if (!mesh_.status(x).deleted()) faces.push_back(x);
  };
  if (request.mode_case() == v1::BridgeGapsRequest::kEnds) {
    sync(document);
    const auto vertex = [&](std::uint32_t id) {
      const std::uint32_t m = id < mesh_of_doc_vertex_.size() ? mesh_of_doc_vertex_[id] : kNoId;
      return m == kNoId || id >= document.vertex_alive.size() || !document.vertex_alive[id]
                 ? VertexHandle()
                 : VertexHandle(static_cast<int>(m));
    };
    const auto& e1 = request.ends().first();
    const auto& e2 = request.ends().second();
    const geometry::GapEnd first{vertex(e1.a()), vertex(e1.b()), vertex(e1.t())};
    const geometry::GapEnd second{vertex(e2.a()), vertex(e2.b()), vertex(e2.t())};
    for (const VertexHandle v : {first.a, first.b, first.t, second.a, second.b, second.t})
      if (!v.is_valid()) {
        outcome.status = {StatusCode::NotFound, "a gap end names a vertex that does not exist"};
        return outcome;
      }
    const geometry::GapBridgeResult r = geometry::bridge_gap(mesh_, first, second, fill);
    if (r.stitches.empty()) {
      forget_bridged({});
      outcome.status = {StatusCode::FailedPrecondition, "bridge refused: " + r.reason};
      return outcome;
    }
    faces = r.stitches;
    for (const auto& f : r.fills) collect(f);
    forget_bridged(faces);
    summary = r.ok ? "gap bridged: a stitch at each end, the loop between them filled"
                   : "gap ends stitched; " + r.reason;
    outcome.delta = edit_delta(document, std::move(vertices), std::move(faces), first_free);
    return outcome;
  }
  std::vector<geometry::Gap> found = gaps(document, request.max_width());
  std::vector<const geometry::Gap*> selected;
  if (request.mode_case() == v1::BridgeGapsRequest::kAll) {
    for (const auto& g : found) selected.push_back(&g);
  } else if (request.mode_case() == v1::BridgeGapsRequest::kIds) {
    for (const std::uint32_t id : request.ids().ids()) {
      if (id >= found.size()) {
        outcome.status = {StatusCode::NotFound, "no gap with id " + std::to_string(id) +
                                                    " (the mesh has " +
                                                    std::to_string(found.size()) + " gaps)"};
        return outcome;
      }
      selected.push_back(&found[id]);
    }
  } else {
    outcome.status = {StatusCode::InvalidArgument, "no gap selection (all, ids or ends)"};
    return outcome;
  }
  std::size_t bridged = 0;
  std::vector<std::string> refused;
  const geometry::DetectedGapsBridge all = geometry::bridge_detected_gaps(mesh_, selected, fill);
  for (std::size_t k = 0; k < selected.size(); ++k) {
    const geometry::DetectedGapBridge& b = all.gaps[k];
    if (!b.zip.ok) {
      refused.push_back(fmt::format("gap {}: {}", selected[k]->id, b.zip.reason));
      continue;
    }
    ++bridged;
    faces.insert(faces.end(), b.zip.faces.begin(), b.zip.faces.end());
    for (const auto& f : b.end_fills) collect(f);
  }
  std::size_t leftovers_filled = 0;
  for (const auto& f : all.leftover_fills) {
    collect(f);
    leftovers_filled += f.filled ? 1 : 0;
  }
  forget_bridged(faces);
  summary = fmt::format("bridged {} of {} gaps{}{}{}", bridged, selected.size(),
                        all.leftover_fills.empty()
                            ? ""
                            : fmt::format(", {} of {} narrow holes between the zippers filled",
                                          leftovers_filled, all.leftover_fills.size()),
                        refused.empty() ? "" : "; ", fmt::join(refused, "; "));
  if (bridged == 0 && !selected.empty()) {
    outcome.status = {StatusCode::FailedPrecondition, summary};
    return outcome;
  }
  outcome.delta = edit_delta(document, std::move(vertices), std::move(faces), first_free);
  return outcome;
}

std::optional<geometry::GuideSurface> SharpEdgeTool::guide() const {
  geometry::HermiteOptions options;
  options.k1 = k1;
  options.k4 = k4;
  const auto curve =
      geometry::make_hermite_curve(points, options, 1e-12 * std::max(height, 1e-300));
  if (!curve.curve) return std::nullopt;
  return geometry::make_guide_surface(*curve.curve, normal, segment_length, height);
}

std::pair<double, double> SharpEdgeTool::effective_k() const {
  geometry::HermiteOptions options;
  options.k1 = k1;
  options.k4 = k4;
  const auto curve =
      geometry::make_hermite_curve(points, options, 1e-12 * std::max(height, 1e-300));
  return {curve.k1, curve.k4};
}

Status SessionGeometry::sharp_edge_begin(const rpc::MeshDocument& document, SlotExtent base,
                                         const v1::SharpEdgeBegin& begin, SharpEdgeTool& tool) {
  if (begin.points_size() != 4)
    return {StatusCode::InvalidArgument, "four points are needed (P1, P2, P3, P4)"};
  for (const auto& p : begin.points())
    if (!finite_point(p)) return {StatusCode::InvalidArgument, "a point is not finite"};
  if (!(begin.k1() >= 0) || !(begin.k4() >= 0) || !std::isfinite(begin.k1() + begin.k4()))
    return {StatusCode::InvalidArgument, "k1 and k4 must be finite and >= 0"};
  sync(document);
  SharpEdgeTool t;
  t.points = {to_vec(begin.points(0)), to_vec(begin.points(1)), to_vec(begin.points(2)),
              to_vec(begin.points(3))};
  t.k1 = begin.k1();
  t.k4 = begin.k4();
  if (!to_pick_tangents(begin.tangents(), t.tangents))
    return {StatusCode::InvalidArgument, "unknown tangents " + std::to_string(begin.tangents())};
  const auto edited = [&](FaceHandle f) {
    const std::uint32_t id = doc_of_mesh_face_.size() > static_cast<std::size_t>(f.idx())
                                 ? doc_of_mesh_face_[static_cast<std::size_t>(f.idx())]
                                 : kNoId;
    return id != kNoId && id >= base.faces;
  };
  // The patch: the edited face nearest the middle of the chord P2-P3, and every edited face
  // connected to it across edges.
  const geometry::Vec3 middle = 0.5 * (t.points.p2 + t.points.p3);
  FaceHandle seed;
  double best = std::numeric_limits<double>::infinity();
  for (const FaceHandle f : mesh_.faces()) {
    if (mesh_.status(f).deleted() || !edited(f)) continue;
    geometry::TrianglePoints tri;
    int k = 0;
    for (const VertexHandle v : mesh_.fv_range(f))
      tri[static_cast<std::size_t>(k++)] = mesh_.point(v);
    const double d = (geometry::closest_point_on_triangle(middle, tri) - middle).norm();
    if (d < best) {
      best = d;
      seed = f;
    }
  }
  if (!seed.is_valid())
    return {StatusCode::FailedPrecondition,
            "no filled patch: fill the hole first, then pick the points around it"};
  std::vector<FaceHandle> patch{seed};
  std::set<int> in_patch{seed.idx()};
  for (std::size_t i = 0; i < patch.size(); ++i)
    for (const HalfedgeHandle h : mesh_.fh_range(patch[i])) {
      const FaceHandle n = mesh_.face_handle(mesh_.opposite_halfedge_handle(h));
      if (n.is_valid() && edited(n) && in_patch.insert(n.idx()).second) patch.push_back(n);
    }
  double boundary_length = 0;
  std::size_t boundary_edges = 0;
  geometry::Vec3 normal(0, 0, 0);
  double diameter = 0;
  for (const FaceHandle f : patch) {
    t.patch_faces.push_back(doc_of_mesh_face_[static_cast<std::size_t>(f.idx())]);
    for (const HalfedgeHandle h : mesh_.fh_range(f)) {
      const FaceHandle n = mesh_.face_handle(mesh_.opposite_halfedge_handle(h));
      if (n.is_valid() && in_patch.count(n.idx())) continue;
      boundary_length += mesh_.calc_edge_length(h);
      ++boundary_edges;
      for (const VertexHandle v : {mesh_.from_vertex_handle(h), mesh_.to_vertex_handle(h)}) {
        t.boundary.insert(doc_vertex(static_cast<std::size_t>(v.idx())));
        for (const FaceHandle around : mesh_.vf_range(v))
          if (!in_patch.count(around.idx())) normal += mesh_.calc_face_normal(around);
      }
    }
  }
  for (const std::uint32_t a : t.boundary)
    for (const std::uint32_t b : t.boundary)
      if (a < b)
        diameter = std::max(diameter,
                            (mesh_.point(VertexHandle(static_cast<int>(mesh_of_doc_vertex_[a]))) -
                             mesh_.point(VertexHandle(static_cast<int>(mesh_of_doc_vertex_[b]))))
                                .norm());
  if (boundary_edges == 0 || !(normal.norm() > 0))
    return {StatusCode::FailedPrecondition, "the patch under the curve has no boundary"};
  t.normal = normal / normal.norm();
  t.segment_length = boundary_length / static_cast<double>(boundary_edges);
  double reach = 0;
  for (const FaceHandle f : patch)
    for (const VertexHandle v : mesh_.fv_range(f))
      reach = std::max(reach, std::abs(OpenMesh::dot(mesh_.point(v) - t.points.p2, t.normal)));
  t.height = std::max(diameter, 3 * reach);
  if (t.tangents == geometry::PickTangents::Crease) {
    // P2 (P3) picked at a rim vertex: the crease through it that P1 (P4) lies on gives the
    // curve's direction there, as the batch sharpen takes it (seed 000 §5: one pick on a badly
    // oriented triangle biases the curve).
    const geometry::SharpenOptions defaults;
    const auto rim_vertex = [&](const geometry::Vec3& q) {
      VertexHandle nearest;
      double best_distance = defaults.crease_pick_tolerance * t.segment_length;
      for (const std::uint32_t id : t.boundary) {
        const VertexHandle v(static_cast<int>(mesh_of_doc_vertex_[id]));
        const double d = (mesh_.point(v) - q).norm();
        if (d <= best_distance) {
          best_distance = d;
          nearest = v;
        }
      }
      return nearest;
    };
    const geometry::CreaseTangentPicks taken = geometry::take_crease_tangents(
        mesh_, t.points, rim_vertex(t.points.p2), rim_vertex(t.points.p3), boundary_length,
        t.segment_length, defaults);
    t.points = taken.points;
    t.crease_tangent_start = taken.start;
    t.crease_tangent_end = taken.end;
  }
  if (!t.guide())
    return {StatusCode::InvalidArgument, "the four points make no curve (two coincide)"};
  tool = std::move(t);
  return {};
}

std::optional<geometry::SharpEdgeState> SessionGeometry::tool_state(const SharpEdgeTool& tool,
                                                                    std::string& why) {
  geometry::SharpEdgeState state;
  const auto guide = tool.guide();
  if (!guide) {
    why = "the curve is degenerate";
    return std::nullopt;
  }
  state.guide = *guide;
  const auto vertex = [&](std::uint32_t id) {
    return id < mesh_of_doc_vertex_.size() && mesh_of_doc_vertex_[id] != kNoId
               ? VertexHandle(static_cast<int>(mesh_of_doc_vertex_[id]))
               : VertexHandle();
  };
  for (const std::uint32_t f : tool.patch_faces) {
    const std::uint32_t m = f < mesh_of_doc_face_.size() ? mesh_of_doc_face_[f] : kNoId;
    if (m == kNoId || mesh_.status(FaceHandle(static_cast<int>(m))).deleted()) {
      why = "the patch changed since the tool began (begin again)";
      return std::nullopt;
    }
    state.patch.push_back(FaceHandle(static_cast<int>(m)));
  }
  for (const std::uint32_t v : tool.boundary)
    if (const VertexHandle h = vertex(v); h.is_valid()) state.boundary.insert(h.idx());
  for (const auto& [id, c] : tool.on_guide)
    if (const VertexHandle h = vertex(id); h.is_valid()) state.on_guide[h.idx()] = c;
  for (const std::uint32_t id : tool.moved)
    if (const VertexHandle h = vertex(id); h.is_valid()) state.moved.insert(h.idx());
  return state;
}

std::optional<geometry::SharpEdgeState> SessionGeometry::tool_state_of(
    const rpc::MeshDocument& document, const SharpEdgeTool& tool, FillOutcome& outcome) {
  sync(document);
  std::string why;
  auto state = tool_state(tool, why);
  if (!state) outcome.status = {StatusCode::FailedPrecondition, why};
  return state;
}

std::map<int, geometry::Vec3> SessionGeometry::patch_positions(
    const geometry::SharpEdgeState& state) const {
  std::map<int, geometry::Vec3> positions;
  for (const FaceHandle f : state.patch)
    for (const VertexHandle v : mesh_.fv_range(f)) positions.emplace(v.idx(), mesh_.point(v));
  return positions;
}

v1::MeshDelta SessionGeometry::move_delta(const rpc::MeshDocument& document,
                                          const std::vector<VertexHandle>& vertices) const {
  v1::MeshDelta delta;
  delta.set_base_version(document.version);
  delta.set_version(document.version + 1);
  for (const VertexHandle v : vertices) {
    const std::uint32_t id = doc_vertex(static_cast<std::size_t>(v.idx()));
    const auto& from = document.positions[id];
    const auto& to = mesh_.point(v);
    delta.add_moved_vertex_ids(id);
    for (int c = 0; c < 3; ++c) delta.add_moved_positions(to[c]);
    for (int c = 0; c < 3; ++c) delta.add_moved_from(from[static_cast<std::size_t>(c)]);
  }
  return delta;
}

SessionGeometry::FillOutcome SessionGeometry::sharp_edge_snap(const rpc::MeshDocument& document,
                                                              SharpEdgeTool& tool,
                                                              SlotExtent first_free) {
  FillOutcome outcome;
  auto state = tool_state_of(document, tool, outcome);
  if (!state) return outcome;
  // Patch vertices and their positions before, to report the moves.
  const std::map<int, geometry::Vec3> before = patch_positions(*state);
  const geometry::SnapReport snap = geometry::snap_to_guide(mesh_, *state);
  if (state->on_guide.empty()) {
    outcome.status = {StatusCode::FailedPrecondition,
                      "the curve does not cross the patch seen along its normal: pick P2 and P3 "
                      "on the rim where the crease meets it"};
    invalidate();
    return outcome;
  }
  // The delta: the old patch faces go, the patch as it is now comes (splits and flips change
  // faces in place), new vertices are added and moved ones moved.
  std::vector<FaceHandle> faces;
  for (const FaceHandle f : state->patch)
    if (!mesh_.status(f).deleted()) faces.push_back(f);
  // Everything the snap changed is in the patch (the delta says no more): its faces, split and
  // flipped in place, and its vertices, moved or new.
  {
    std::vector<VertexHandle> moved = snap.new_vertices;
    for (const auto& [index, old] : before)
      if (mesh_.point(VertexHandle(index)) != old) moved.push_back(VertexHandle(index));
    note_edit(faces, moved);
  }
  outcome.delta = edit_delta(document, snap.new_vertices, faces, first_free);
  for (const std::uint32_t f : tool.patch_faces) outcome.delta.add_removed_faces(f);
  pending_replaced_faces_.assign(tool.patch_faces.begin(), tool.patch_faces.end());
  for (const auto& [index, old] : before) {
    const VertexHandle v(index);
    if (mesh_.point(v) == old) continue;
    const std::uint32_t id = doc_vertex(static_cast<std::size_t>(index));
    outcome.delta.add_moved_vertex_ids(id);
    for (int c = 0; c < 3; ++c) outcome.delta.add_moved_positions(mesh_.point(v)[c]);
    for (int c = 0; c < 3; ++c) outcome.delta.add_moved_from(old[c]);
  }
  // The tool in document ids: new vertices' ids come from the delta's slot map.
  std::map<std::uint32_t, std::uint32_t> new_doc;  // mesh index -> doc id
  for (std::size_t i = 0; i + 1 < pending_vertex_map_.size(); i += 2)
    new_doc[pending_vertex_map_[i]] = pending_vertex_map_[i + 1];
  const auto doc_id = [&](int index) {
    const auto it = new_doc.find(static_cast<std::uint32_t>(index));
    return it != new_doc.end() ? it->second : doc_vertex(static_cast<std::size_t>(index));
  };
  tool.patch_faces.assign(outcome.delta.added_face_ids().begin(),
                          outcome.delta.added_face_ids().end());
  tool.on_guide.clear();
  for (const auto& [index, c] : state->on_guide) tool.on_guide[doc_id(index)] = c;
  tool.snapped = true;
  return outcome;
}

SessionGeometry::FillOutcome SessionGeometry::sharp_edge_push(const rpc::MeshDocument& document,
                                                              SharpEdgeTool& tool,
                                                              const v1::SharpEdgePush& push,
                                                              PushReport& report) {
  FillOutcome outcome;
  if (!finite_point(push.proxy()) || !finite_point(push.previous()) ||
      !std::isfinite(push.step() + push.depth()) || !(push.step() > 0) || push.depth() < 0) {
    outcome.status = {StatusCode::InvalidArgument,
                      "proxy and previous must be finite, step > 0 and depth >= 0"};
    return outcome;
  }
  auto state = tool_state_of(document, tool, outcome);
  if (!state) return outcome;
  const auto nearest_patch_face = [&](const geometry::Vec3& point) {
    FaceHandle nearest;
    double best = std::numeric_limits<double>::infinity();
    for (const FaceHandle f : state->patch) {
      if (mesh_.status(f).deleted()) continue;
      geometry::TrianglePoints tri;
      int k = 0;
      for (const VertexHandle v : mesh_.fv_range(f))
        tri[static_cast<std::size_t>(k++)] = mesh_.point(v);
      const double d = (geometry::closest_point_on_triangle(point, tri) - point).norm();
      if (d < best) {
        best = d;
        nearest = f;
      }
    }
    return nearest;
  };
  FaceHandle fixed_face;
  if (push.face() != kNoId && push.face() < mesh_of_doc_face_.size() &&
      mesh_of_doc_face_[push.face()] != kNoId)
    fixed_face = FaceHandle(static_cast<int>(mesh_of_doc_face_[push.face()]));
  // The motion since the last push is cut into tool samples of one step each (Algorithm VI
  // moves a vertex by the step per sample), so a client whose pushes are delayed by the
  // network sends the same sweep in fewer, longer requests and gets the same result.
  const geometry::Vec3 from = to_vec(push.previous()), to = to_vec(push.proxy());
  const double length = (to - from).norm();
  const int samples =
      std::clamp(static_cast<int>(std::floor(length / push.step())), 1, kMaxSamplesPerPush);
  geometry::PushOptions options;
  options.step = push.step();
  options.depth = push.depth();
  std::vector<VertexHandle> moved;
  std::string why_not;
  for (int i = 1; i <= samples; ++i) {
    const geometry::Vec3 previous = from + (to - from) * (double(i - 1) / samples);
    const geometry::Vec3 proxy = from + (to - from) * (double(i) / samples);
    const FaceHandle touched = push.face() == kNoId ? nearest_patch_face(proxy) : fixed_face;
    const geometry::PushResult r =
        geometry::push_down(mesh_, *state, proxy, previous, touched, options);
    report.at_limit = r.at_limit;
    if (!r.moved) {
      why_not = r.why_not;
      continue;
    }
    if (std::find(moved.begin(), moved.end(), r.vertex) == moved.end()) moved.push_back(r.vertex);
  }
  if (moved.empty()) {
    outcome.status = {StatusCode::FailedPrecondition, "push refused: " + why_not};
    return outcome;
  }
  for (const VertexHandle v : moved) {
    const std::uint32_t id = doc_vertex(static_cast<std::size_t>(v.idx()));
    tool.on_guide[id] = state->on_guide[v.idx()];
    tool.moved.insert(id);
    note_moved(v);
  }
  bound_touched();
  report.samples = static_cast<std::uint32_t>(samples);
  outcome.delta = move_delta(document, moved);
  pending_vertex_map_.clear();
  pending_face_map_.clear();
  pending_version_ = document.version + 1;
  return outcome;
}

SessionGeometry::FillOutcome SessionGeometry::sharp_edge_smooth(const rpc::MeshDocument& document,
                                                                SharpEdgeTool& tool,
                                                                geometry::PushFinish finish) {
  FillOutcome outcome;
  auto state = tool_state_of(document, tool, outcome);
  if (!state) return outcome;
  const std::map<int, geometry::Vec3> before = patch_positions(*state);
  // A finish that fails or folds the patch into the mesh is undone there and refused here.
  const geometry::PushFinishReport finished =
      geometry::finish_push(mesh_, *state, finish, /*check_intersections=*/true);
  // The finish only moves the patch's free vertices (a refused one puts them back).
  std::vector<VertexHandle> moved;
  for (const auto& [index, old] : before)
    if (mesh_.point(VertexHandle(index)) != old) moved.push_back(VertexHandle(index));
  note_edit({}, moved);
  if (!finished.undone.empty()) {
    outcome.status = {StatusCode::FailedPrecondition, finished.undone};
    return outcome;
  }
  outcome.delta = move_delta(document, moved);
  pending_vertex_map_.clear();
  pending_face_map_.clear();
  pending_version_ = document.version + 1;
  return outcome;
}

void SessionGeometry::commit_pending() {
  doc_of_mesh_vertex_.resize(mesh_.n_vertices(), kNoId);
  doc_of_mesh_face_.resize(mesh_.n_faces(), kNoId);
  for (std::size_t i = 0; i + 1 < pending_vertex_map_.size(); i += 2) {
    const std::uint32_t mesh_index = pending_vertex_map_[i];
    const std::uint32_t doc_id = pending_vertex_map_[i + 1];
    doc_of_mesh_vertex_[mesh_index] = doc_id;
    if (mesh_of_doc_vertex_.size() <= doc_id) mesh_of_doc_vertex_.resize(doc_id + 1, kNoId);
    // A reused dead slot: its old mesh vertex (isolated) is retired, collected later.
    if (const std::uint32_t old = mesh_of_doc_vertex_[doc_id]; old != kNoId && old != mesh_index) {
      const VertexHandle retired(static_cast<int>(old));
      doc_of_mesh_vertex_[old] = kNoId;
      if (mesh_.is_isolated(retired)) mesh_.status(retired).set_deleted(true);
    }
    mesh_of_doc_vertex_[doc_id] = mesh_index;
  }
  // Document faces the edit replaced by faces it changed in place: their mesh faces take the new
  // slots below (or were deleted).
  for (const std::uint32_t doc : pending_replaced_faces_) {
    if (doc >= mesh_of_doc_face_.size()) continue;
    if (const std::uint32_t mf = mesh_of_doc_face_[doc];
        mf < doc_of_mesh_face_.size() && doc_of_mesh_face_[mf] == doc)
      doc_of_mesh_face_[mf] = kNoId;
    mesh_of_doc_face_[doc] = kNoId;
  }
  for (std::size_t i = 0; i + 1 < pending_face_map_.size(); i += 2) {
    const std::uint32_t doc_id = pending_face_map_[i + 1];
    doc_of_mesh_face_[pending_face_map_[i]] = doc_id;
    if (mesh_of_doc_face_.size() <= doc_id) mesh_of_doc_face_.resize(doc_id + 1, kNoId);
    mesh_of_doc_face_[doc_id] = pending_face_map_[i];
  }
  // Elements the edit deleted from the mesh (a removed fragment): their slots map to nothing.
  for (const std::uint32_t mf : pending_removed_faces_) {
    if (mf >= doc_of_mesh_face_.size()) continue;
    if (const std::uint32_t doc = doc_of_mesh_face_[mf]; doc < mesh_of_doc_face_.size())
      mesh_of_doc_face_[doc] = kNoId;
    doc_of_mesh_face_[mf] = kNoId;
  }
  for (const std::uint32_t mv : pending_removed_vertices_) {
    if (mv >= doc_of_mesh_vertex_.size()) continue;
    if (const std::uint32_t doc = doc_of_mesh_vertex_[mv]; doc < mesh_of_doc_vertex_.size())
      mesh_of_doc_vertex_[doc] = kNoId;
    doc_of_mesh_vertex_[mv] = kNoId;
  }
  pending_vertex_map_.clear();
  pending_face_map_.clear();
  pending_removed_faces_.clear();
  pending_removed_vertices_.clear();
  pending_replaced_faces_.clear();
  version_ = pending_version_;
  bound_growth();
}

void SessionGeometry::discard_pending() {
  pending_vertex_map_.clear();
  pending_face_map_.clear();
  pending_removed_faces_.clear();
  pending_removed_vertices_.clear();
  pending_replaced_faces_.clear();
  // The attempts' elements are deleted in the cache: they map to no document slot.
  doc_of_mesh_vertex_.resize(mesh_.n_vertices(), kNoId);
  doc_of_mesh_face_.resize(mesh_.n_faces(), kNoId);
  bound_growth();
}

bool SessionGeometry::removals_free(const v1::MeshDelta& delta) const {
  if (!valid_ || version_ != delta.base_version() || !pending_vertex_map_.empty() ||
      !pending_face_map_.empty() || !pending_removed_faces_.empty() ||
      !pending_removed_vertices_.empty() || !pending_replaced_faces_.empty())
    return false;
  geometry::LocalSet removed_faces(2 * static_cast<std::size_t>(delta.removed_faces_size()) + 16);
  for (const std::uint32_t f : delta.removed_faces()) removed_faces.insert(static_cast<int>(f));
  for (const std::uint32_t v : delta.removed_vertices()) {
    const std::uint32_t m = v < mesh_of_doc_vertex_.size() ? mesh_of_doc_vertex_[v] : kNoId;
    if (m == kNoId || m >= mesh_.n_vertices()) return false;
    for (const FaceHandle f : mesh_.vf_range(VertexHandle(static_cast<int>(m)))) {
      const auto i = static_cast<std::size_t>(f.idx());
      const std::uint32_t doc = i < doc_of_mesh_face_.size() ? doc_of_mesh_face_[i] : kNoId;
      if (doc == kNoId || !removed_faces.contains(static_cast<int>(doc))) return false;
    }
  }
  return true;
}

void SessionGeometry::apply(const v1::MeshDelta& delta) {
  if (!valid_ || version_ != delta.base_version()) {
    invalidate();
    return;
  }
  // The holes are updated from the vertices the edit touches (update_holes), not searched
  // again: the corners of the faces it deletes and adds, the vertices it moves and their
  // neighbours.
  const auto fail = [this] { invalidate(); };
  std::vector<VertexHandle> moved;
  for (const std::uint32_t f : delta.removed_faces()) {
    const std::uint32_t mf = f < mesh_of_doc_face_.size() ? mesh_of_doc_face_[f] : kNoId;
    if (mf == kNoId || mesh_.status(FaceHandle(static_cast<int>(mf))).deleted()) return fail();
    for (const VertexHandle v : mesh_.fv_range(FaceHandle(static_cast<int>(mf))))
      touched_.push_back(v);
    // Keep the vertices: those the delta removes are deleted below; any other left isolated
    // stays, as after a rebuild.
    mesh_.delete_face(FaceHandle(static_cast<int>(mf)), false);
    mesh_of_doc_face_[f] = kNoId;
    doc_of_mesh_face_[mf] = kNoId;
  }
  // A removed vertex is deleted in the mesh too and maps to nothing: its slot, if the document
  // brings it back (redo) or reuses it, gets a new mesh vertex. Those an undo removes are the
  // last the mesh added, so cut_deleted_tail drops them.
  for (const std::uint32_t v : delta.removed_vertices()) {
    const std::uint32_t mv = v < mesh_of_doc_vertex_.size() ? mesh_of_doc_vertex_[v] : kNoId;
    if (mv == kNoId || !mesh_.is_isolated(VertexHandle(static_cast<int>(mv)))) return fail();
    mesh_.status(VertexHandle(static_cast<int>(mv))).set_deleted(true);
    mesh_of_doc_vertex_[v] = kNoId;
    doc_of_mesh_vertex_[mv] = kNoId;
  }
  for (int i = 0; i < delta.added_vertex_ids_size(); ++i) {
    const std::uint32_t v = delta.added_vertex_ids(i);
    const geometry::Vec3 p(delta.added_positions(3 * i), delta.added_positions(3 * i + 1),
                           delta.added_positions(3 * i + 2));
    std::uint32_t mv = v < mesh_of_doc_vertex_.size() ? mesh_of_doc_vertex_[v] : kNoId;
    if (mv == kNoId) {
      mv = static_cast<std::uint32_t>(mesh_.add_vertex(p).idx());
      if (mesh_of_doc_vertex_.size() <= v) mesh_of_doc_vertex_.resize(v + 1, kNoId);
      mesh_of_doc_vertex_[v] = mv;
      doc_of_mesh_vertex_.resize(mesh_.n_vertices(), kNoId);
      doc_of_mesh_vertex_[mv] = v;
    } else {
      const VertexHandle vh(static_cast<int>(mv));
      if (mesh_.status(vh).deleted() || !mesh_.is_isolated(vh)) return fail();
      mesh_.set_point(vh, p);
      moved.push_back(vh);
    }
  }
  for (int i = 0; i < delta.moved_vertex_ids_size(); ++i) {
    const std::uint32_t v = delta.moved_vertex_ids(i);
    const std::uint32_t mv = v < mesh_of_doc_vertex_.size() ? mesh_of_doc_vertex_[v] : kNoId;
    if (mv == kNoId) return fail();
    mesh_.set_point(VertexHandle(static_cast<int>(mv)),
                    geometry::Vec3(delta.moved_positions(3 * i), delta.moved_positions(3 * i + 1),
                                   delta.moved_positions(3 * i + 2)));
    moved.push_back(VertexHandle(static_cast<int>(mv)));
  }
  for (int i = 0; i < delta.added_face_ids_size(); ++i) {
    std::array<VertexHandle, 3> corners;
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = delta.added_faces(3 * i + k);
      const std::uint32_t mv = v < mesh_of_doc_vertex_.size() ? mesh_of_doc_vertex_[v] : kNoId;
      if (mv == kNoId) return fail();
      corners[static_cast<std::size_t>(k)] = VertexHandle(static_cast<int>(mv));
    }
    const FaceHandle fh = mesh_.add_face(corners[0], corners[1], corners[2]);
    if (!fh.is_valid()) return fail();  // OpenMesh could not link it: rebuild from the document
    touched_.insert(touched_.end(), corners.begin(), corners.end());
    if (reach_) reach_->add(mesh_, std::span<const FaceHandle>(&fh, 1));
    const std::uint32_t f = delta.added_face_ids(i);
    if (mesh_of_doc_face_.size() <= f) mesh_of_doc_face_.resize(f + 1, kNoId);
    mesh_of_doc_face_[f] = static_cast<std::uint32_t>(fh.idx());
    doc_of_mesh_face_.resize(mesh_.n_faces(), kNoId);
    doc_of_mesh_face_[static_cast<std::size_t>(fh.idx())] = f;
  }
  for (const VertexHandle v : moved) note_moved(v);
  bound_touched();
  version_ = delta.version();
  bound_growth();
}

}  // namespace touchmend::service
