#pragma once

//! \file session_geometry.h
//! \brief The bridge between a session's MeshDocument (stable slot ids, the wire's view) and
//! the OpenMesh mesh the geometry library works on.
//!
//! \details The mesh is a cache: built from the document when needed (every vertex slot,
//! dead or alive, becomes mesh vertex of the same index, so after a build the two index
//! spaces agree) and kept current in place after fills, which only append. Fills may leave
//! deleted elements of failed attempts in the mesh (DESIGN.md: never garbage-collect inside
//! an algorithm), so the two index spaces drift; the maps below translate. Both maps are
//! monotone, so a hole's id (its smallest vertex) is the same in either space.

#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "proto/rpc/mesh_document.h"
#include "proto/rpc/status.h"
#include "server/geometry/gap_bridging.h"
#include "server/geometry/hole_filling.h"
#include "server/geometry/holes.h"
#include "server/geometry/mesh.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_intersections.h"
#include "server/geometry/mesh_io.h"
#include "server/geometry/sharpen.h"
#include "touchmend/v1/repair.pb.h"

namespace touchmend::service {

using rpc::Status;

inline constexpr std::uint32_t kNoId = std::numeric_limits<std::uint32_t>::max();
//! A push request longer than this many steps is applied as this many samples (a bound on the
//! work one request can ask for).
inline constexpr int kMaxSamplesPerPush = 256;

//! Limits on what a client may load (SERVICE.md §2.3, configurable).
struct MeshLimits {
  std::size_t max_upload_bytes = std::size_t{256} << 20;
  std::size_t max_vertices = 10'000'000;
  std::size_t max_faces = 20'000'000;
};

struct LoadedMesh {
  rpc::MeshDocument document;
  geometry::ValidationReport validation;
};

//! Parses and validates a mesh file into a fresh document (version 0). Errors are
//! INVALID_ARGUMENT with the reader's message (line/byte of the problem).
Status load_document(std::string_view bytes, geometry::MeshFormat format, const MeshLimits& limits,
                     LoadedMesh& out);

bool to_geometry_format(v1::MeshFormat format, geometry::MeshFormat& out);
geometry::FillOptions to_fill_options(const v1::FillOptions& options);
//! False for a value this build does not know (a newer client).
bool to_push_finish(v1::PushFinish finish, geometry::PushFinish& out);
//! False for a value this build does not know (a newer client).
bool to_pick_tangents(v1::PickTangents tangents, geometry::PickTangents& out);
void to_proto(const geometry::ValidationReport& report, v1::ValidationSummary& out);
void to_proto(const geometry::HoleFillReport& report, v1::HoleFillResult& out);

//! Serialises the alive part of \p document as a mesh file.
Status export_document(const rpc::MeshDocument& document, geometry::MeshFormat format, bool binary,
                       std::string& bytes);

//! Numbers of document vertex and face slots (a position in the slot arrays).
struct SlotExtent {
  std::uint32_t vertices = 0;
  std::uint32_t faces = 0;
};

//! The interactive sharp-edge tool of a session, in document ids (the mesh cache may be rebuilt
//! between calls).
struct SharpEdgeTool {
  geometry::HermitePoints points;
  double k1 = 0, k4 = 0;
  //! Where the end directions come from; with Crease, P1 (P4) was moved onto the tangent line
  //! of the crease it lies on where one was found (geometry::take_crease_tangents).
  geometry::PickTangents tangents = geometry::PickTangents::Crease;
  bool crease_tangent_start = false;
  bool crease_tangent_end = false;
  std::vector<std::uint32_t> patch_faces;  //!< document face ids
  std::set<std::uint32_t> boundary;        //!< document vertex ids that never move
  geometry::Vec3 normal{0, 0, 1};          //!< extrusion direction of the guiding surface
  double segment_length = 0;               //!< the patch boundary's mean edge length
  double height = 0;                       //!< half-height of the guiding surface
  bool snapped = false;                    //!< Algorithm V done: the curve is fixed
  std::map<std::uint32_t, geometry::CurtainPoint> on_guide;  //!< document vertex ids
  std::set<std::uint32_t> moved;
  std::optional<geometry::GuideSurface> guide() const;
  //! The tangent lengths in effect (the defaults resolved), for the preview.
  std::pair<double, double> effective_k() const;
};

class SessionGeometry {
 public:
  //! Forget the cache (after undo, redo or load); the next call rebuilds it.
  void invalidate() {
    valid_ = false;
    forget_search();
  }

  //! The holes of the current document, ids and loops in document ids.
  std::vector<v1::Hole> holes(const rpc::MeshDocument& document);

  struct Nearest {
    bool found = false;
    v1::Hole hole;
    double distance = 0;
  };
  Nearest nearest_hole(const rpc::MeshDocument& document, const v1::Point3& point);

  struct FillOutcome {
    Status status;
    v1::FillReport report;
    v1::MeshDelta delta;  //!< from document.version to document.version + 1 (maybe empty)
  };
  //! Fills the selected holes on the cache and returns the edit as a delta on \p document
  //! (not yet applied: the caller journals it, then applies it and calls commit_pending).
  //! New elements take the document's slots from \p first_free on (dead slots above the
  //! applied history, see Session), then append.
  FillOutcome fill(const rpc::MeshDocument& document, const v1::HoleSelection& selection,
                   const v1::FillOptions& options, const geometry::FillProgress& progress,
                   SlotExtent first_free = {});
  //! One stitch triangle (seed 000 Algorithm VIII) over the boundary edge {a, b} to the
  //! boundary vertex t (document vertex ids), as a delta (not yet applied, like fill()).
  FillOutcome stitch(const rpc::MeshDocument& document, std::uint32_t a, std::uint32_t b,
                     std::uint32_t t, SlotExtent first_free = {});
  //! Fills hole `hole_id` and retains the sharp edge through the picked points (sharpen.h), as
  //! one delta; \p summary says what was done.
  FillOutcome sharpen(const rpc::MeshDocument& document, const v1::SharpenRequest& request,
                      SlotExtent first_free, std::string& summary);
  //! The gaps of the current document (ids = positions in the list).
  std::vector<geometry::Gap> gaps(const rpc::MeshDocument& document, double max_width);
  v1::Gap gap_to_proto(const geometry::Gap& gap) const;
  //! Bridges gaps (zipper; or Algorithm IX from two ends) as one delta.
  FillOutcome bridge(const rpc::MeshDocument& document, const v1::BridgeGapsRequest& request,
                     SlotExtent first_free, std::string& summary);
  //! Sharp-edge tool steps. begin finds the patch (the connected edited faces, slots at or
  //! above \p base, under the curve) and fills \p tool; snap, push and smooth return their
  //! edit as a delta (not yet applied, like fill()) and update \p tool.
  Status sharp_edge_begin(const rpc::MeshDocument& document, SlotExtent base,
                          const v1::SharpEdgeBegin& begin, SharpEdgeTool& tool);
  FillOutcome sharp_edge_snap(const rpc::MeshDocument& document, SharpEdgeTool& tool,
                              SlotExtent first_free);
  //! One push request: the motion from previous to proxy is cut into tool samples of one step
  //! (at most kMaxSamplesPerPush), each an Algorithm VI push.
  struct PushReport {
    bool at_limit = false;      //!< the last sample's vertex reached its limit
    std::uint32_t samples = 0;  //!< tool samples applied
  };
  FillOutcome sharp_edge_push(const rpc::MeshDocument& document, SharpEdgeTool& tool,
                              const v1::SharpEdgePush& push, PushReport& report);
  //! The tool's last step: shapes the patch's free vertices (\p finish: fairing each side of
  //! the curve, or Algorithm VII); refused when that would make the patch cross the mesh.
  FillOutcome sharp_edge_smooth(const rpc::MeshDocument& document, SharpEdgeTool& tool,
                                geometry::PushFinish finish);
  //! Records that the last fill's or stitch's delta was applied to the document (else
  //! invalidate()).
  void commit_pending();
  //! Records that the last fill's delta was empty (every selected hole left open) and not
  //! applied: the cache still mirrors the document (the fill took its attempts out again), so
  //! it stays, with its holes and search reach. Invalidating it instead made the next request
  //! rebuild the mesh from the document: about a second on a mesh of a million faces.
  void discard_pending();
  //! Brings the cache along with an edit made elsewhere (undo, redo) instead of rebuilding
  //! it from the document, which is O(mesh size): deleted faces are deleted in the mesh,
  //! revived or new ones added. Anything unexpected falls back to invalidate().
  void apply(const v1::MeshDelta& delta);
  //! Whether every vertex \p delta removes is used by no face but those it removes, told from the
  //! cache's adjacency in O(delta) (rpc::apply_delta's removals_checked). False when the cache
  //! cannot tell: it is not at the delta's base version, or holds an edit not yet committed.
  bool removals_free(const v1::MeshDelta& delta) const;
  //! Whether the cache currently mirrors a document version (for tests and diagnostics).
  bool cached() const { return valid_; }
  //! The cache mesh's vertex and face slots, deleted ones included (for tests and diagnostics).
  std::size_t mesh_vertex_slots() const { return mesh_.n_vertices(); }
  std::size_t mesh_face_slots() const { return mesh_.n_faces(); }
  //! Whether the hole search and the search reach are kept for the next request (else it makes
  //! them again from the whole mesh); for tests and diagnostics.
  bool holes_kept() const { return holes_.has_value(); }
  //! Why the cache does not mirror \p document (its version), or empty when it does: every alive
  //! face maps to a live mesh face with the same corners and back, no other mesh face is live,
  //! every alive vertex maps to a mesh vertex at its position and back, a dead one at most to an
  //! isolated one. One pass over both; for tests and diagnostics.
  std::string mirror_mismatch(const rpc::MeshDocument& document) const;
  bool reach_kept() const { return reach_.has_value(); }

 private:
  void sync(const rpc::MeshDocument& document);
  //! The hole search of the current mesh, done once per version (selection then fill is the
  //! interactive path: the second call reuses the first's search and projectability test).
  geometry::HoleSearchResult& search();
  //! Forgets the holes when more vertices were touched than an update would save; boxes the
  //! vertices the fills added on the search reach once they are a few thousand.
  void bound_touched();
  //! Forgets the holes and the search reach (an edit they are not kept through, a rebuild, a
  //! compaction).
  void forget_search();
  //! Keeps the holes' update and the search reach true after \p v moved.
  void note_moved(geometry::VertexHandle v);
  //! The same after an edit other than a fill, undo or redo, made here: \p faces added or
  //! changed in place (their corners are touched, the long ones listed on the reach), \p moved
  //! the vertices it moved. Everything the edit changed must be in these (its delta's content).
  void note_edit(std::span<const geometry::FaceHandle> faces,
                 std::span<const geometry::VertexHandle> moved);
  //! After a bridge that added \p faces: keeps the search reach, forgets the holes.
  void forget_bridged(std::span<const geometry::FaceHandle> faces);
  v1::Hole hole_to_proto(const geometry::Hole& hole) const;
  //! The smallest document vertex id on the hole's boundary: its stable id on the wire.
  std::uint32_t doc_hole_id(const geometry::Hole& hole) const;
  std::uint32_t doc_vertex(std::size_t mesh_index) const;
  std::optional<geometry::Hole> hole_by_doc_id(std::uint32_t id);
  //! The tool's state on the cache mesh (handles), or why it cannot be mapped.
  std::optional<geometry::SharpEdgeState> tool_state(const SharpEdgeTool& tool, std::string& why);
  //! sync() and tool_state(); a failure goes into \p outcome's status.
  std::optional<geometry::SharpEdgeState> tool_state_of(const rpc::MeshDocument& document,
                                                        const SharpEdgeTool& tool,
                                                        FillOutcome& outcome);
  //! The positions of the patch's vertices (to report what an operation moved).
  std::map<int, geometry::Vec3> patch_positions(const geometry::SharpEdgeState& state) const;
  //! A delta moving the given cache vertices from their document positions.
  v1::MeshDelta move_delta(const rpc::MeshDocument& document,
                           const std::vector<geometry::VertexHandle>& vertices) const;

  bool valid_ = false;
  std::uint64_t version_ = 0;
  geometry::Mesh mesh_;
  std::vector<std::uint32_t> doc_of_mesh_vertex_;
  std::vector<std::uint32_t> mesh_of_doc_vertex_;
  std::vector<std::uint32_t> doc_of_mesh_face_;
  std::vector<std::uint32_t> mesh_of_doc_face_;
  // The last fill, pending commit.
  std::vector<std::uint32_t> pending_vertex_map_;  // pairs mesh index, doc id
  std::vector<std::uint32_t> pending_face_map_;
  std::vector<std::uint32_t> pending_removed_faces_;  // mesh indices the edit deleted
  std::vector<std::uint32_t> pending_removed_vertices_;
  //! Document face ids the edit removed while it changed their mesh faces in place (the snap's
  //! splits and flips): those mesh faces take the edit's new ids.
  std::vector<std::uint32_t> pending_replaced_faces_;
  std::uint64_t pending_version_ = 0;
  std::optional<geometry::HoleSearchResult> holes_;
  //! Vertices the edits since holes_ was found touched (geometry::update_holes): the next
  //! search updates holes_ from them instead of searching the whole mesh, which on a mesh of a
  //! million faces was a third of an interactive fill's round trip.
  std::vector<geometry::VertexHandle> touched_;
  //! The mesh's search reach (geometry::SearchReach), kept through fills, undo and redo (the
  //! faces they add filed on it, the vertices they move noted) instead of a pass over the whole
  //! mesh per fill: 9 ms of a fill request on a mesh of 1.37M faces.
  std::optional<geometry::SearchReach> reach_;
  //! Face handles at the last rebuild or compaction: undo, redo and failed fill attempts
  //! leave deleted faces behind, so once the mesh has grown by a quarter its edges and faces
  //! are garbage-collected in place (amortised O(1) per edit).
  std::size_t faces_at_rebuild_ = 0;
  std::size_t vertices_at_rebuild_ = 0;
  void bound_growth();
  //! Drops the mesh's trailing deleted elements (those an undo left), in O(their number).
  void cut_deleted_tail();
  //! The delta adding \p new_vertices and \p new_faces (already in the cache), with the
  //! pending maps commit_pending() applies.
  v1::MeshDelta edit_delta(const rpc::MeshDocument& document,
                           std::vector<geometry::VertexHandle> new_vertices,
                           std::vector<geometry::FaceHandle> new_faces, SlotExtent first_free);
};

}  // namespace touchmend::service
