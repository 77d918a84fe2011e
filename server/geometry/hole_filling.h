#pragma once

//! \file hole_filling.h
//! \brief Filling holes: seed 000 Algorithms I-III for simple holes, seed 001's piecewise
//! split for complex ones, a 3D minimum-weight triangulation as the last resort, then
//! refinement and a per-hole shape decision (flat or faired).
//!
//! \details Pipeline per hole (ALGORITHMS.md §1.4, §2, §5, §6):
//!  1. reference plane from the boundary triangles' normals, rotation to +Z, projectability
//!     test with the Newell and least-squares normals as fallbacks;
//!  2. simple hole: close boundary angles below 5π/9, then Algorithm II (planar method);
//!     complex hole: piecewise split into simple sub-holes; either failing: 3D DP;
//!  3. Liepa refinement capped at the user's round count (Algorithm III);
//!  4. shape: flat (the refined triangulation, exact on planar surroundings) or faired
//!     (bi-Laplacian with the boundary ring fixed, so the patch continues the tangents of the
//!     surface around it); `Auto` decides from the boundary and its neighbouring triangles;
//!  5. the new faces must not intersect any face; a faired patch that does falls back to
//!     flat, a method whose patch still does falls back to the next method, and a hole no
//!     method can close is left open with the reason. Nothing else in the mesh changes.

#include <chrono>
#include <cstdint>
#include <functional>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "server/geometry/fairing.h"
#include "server/geometry/holes.h"
#include "server/geometry/mesh.h"
#include "server/geometry/patch_quality.h"
#include "server/geometry/sharp_edges.h"

namespace touchmend::geometry {

struct SearchReach;  // mesh_intersections.h

enum class PatchShape { Flat, Fair, Auto };
const char* to_string(PatchShape shape);
bool parse_patch_shape(std::string_view text, PatchShape& shape);

enum class FillMethod { Planar, Piecewise, MinimumWeight3d, CreaseSplit, EarClipping };
const char* to_string(FillMethod method);

//! Sharp-edge retaining without a device: `Auto` finds the creases that cross each hole and
//! fills the hole split along them (sharp_edges.h), so the creases run through the patch.
enum class SharpMode { Off, Auto };
const char* to_string(SharpMode mode);
bool parse_sharp_mode(std::string_view text, SharpMode& mode);

struct FillOptions {
  int refine_iterations = 3;  //!< Algorithm III rounds (seed 000 §3.4.4: 1-5); 0 = none
  PatchShape shape = PatchShape::Auto;
  double close_angle = 5.0 * std::numbers::pi / 9.0;  //!< seed 000 §3.4.2
  FairingOptions fairing;
  std::size_t max_dp_vertices = 400;  //!< size limit of the O(n^3) 3D triangulation
  //! A larger hole that every automatic method left open gets the 3D triangulation anyway, up
  //! to this many boundary vertices (its tables take about 100 bytes per pair of vertices: some
  //! 100 MB at 1,000); 0: never.
  std::size_t last_resort_dp_vertices = 1000;
  //! A flat 3D triangulation whose triangles cross the mesh is solved again without them, at
  //! most this many times, within a work budget (the first solve is O(n^3), a later one only
  //! re-solves the intervals around what it forbade; large loops get fewer rounds).
  int max_avoiding_rounds = 128;
  bool check_intersections = true;
  //! Methods to try in order; empty = automatic (simple: planar then 3D; complex: piecewise
  //! then 3D; ear clipping, flat, when every other method's patch crosses the mesh).
  std::vector<FillMethod> methods;
  //! Auto shape: the patch stays flat when every triangle around the boundary is within this
  //! angle of the hole's plane and the boundary lies in that plane (within 1% of its size).
  double flat_max_normal_deviation_deg = 3.0;
  //! Auto shape: an edge whose faces meet at more than this is a crease (CAD feature).
  double feature_angle_deg = 35.0;
  //! Auto shape, holes with creases at the boundary: the surroundings count as piecewise planar
  //! (a CAD part: keep the patch flat along the creases) when the median dihedral angle of the
  //! edges within two rings of the boundary is below this; otherwise they are a curved surface
  //! with strong bends (a coarse scan) and the patch is faired.
  double piecewise_planar_median_deg = 1.0;
  //! ... and when at least this fraction of the rim's vertices lie on a plane around the rim
  //! that reaches across the hole (a part's faces continue past a hole; the facets of a curved
  //! surface refined by midpoint subdivision, edge by edge as planar, do not). 0: off.
  double piecewise_planar_min_planes_across = 0.15;
  //! On by default: a hole that a crease crosses is filled split along it (measured closer to
  //! the ground truth on every case where creases are found; README "How holes are filled").
  SharpMode sharp = SharpMode::Auto;
  //! A faired patch whose vertices move farther than this many hole radii (perimeter / 2π)
  //! off the spanning triangulation is a balloon (fairing domes out where the boundary's
  //! tangents open outwards, e.g. at the rim of a flat cap) and stays flat. A spherical cap of
  //! half-angle 53° rises half its radius; the shared cases' true patches stay below 0.4.
  double max_fair_bulge = 0.5;
  //! A flat stand-in for a refused thin plate that keeps a triangle under 15° (its folds over
  //! a bent rim, which no move within its surface mends) is set aside for a membrane over the
  //! same triangulation (L x = 0, FairingOptions::continuity 0): it stays within the rim's hull,
  //! so it does not balloon, and it is mended in 3D. The one with the larger smallest angle is
  //! kept. Off: the flat stand-in, whatever its angles.
  bool membrane_fallback = true;
  //! After the refinement: mend the triangles below the quality goal (patch_quality.h) before
  //! the patch is faired or kept flat. Off: the refined triangulation as Algorithm III leaves it.
  bool improve_quality = true;
  PatchQualityOptions quality;
  CreaseOptions creases;  //!< detection and pairing for SharpMode::Auto
  //! When the split along every curve of the detected plan cannot be made, it is tried again
  //! with one curve left out (the one nearest where the split went wrong, else the least
  //! certain: plan_without_weakest_curve), at most this many times, before the whole-hole
  //! methods. 0: the whole plan or nothing. Three: on a couplingdown slot (crease-slot bench
  //! seed 14 cut 7) the whole plan and the first two retries could not be made, the third, one
  //! pair, could (mean 0.69 -> 0.003 per mille); since its tooth's corner on the rim is taken as
  //! that rim vertex (join_at_corners), the second retry, the two pairs, makes it.
  int crease_split_retries = 3;
  //! Curves given by the caller (picked points) instead of detected ones: used by the
  //! CreaseSplit method whatever `sharp` says.
  std::optional<HoleCreasePlan> explicit_creases;
  //! A selected hole whose loop is the whole border of a small separate piece
  //! (Hole::fragment_faces: a lone triangle or a few faces of scan debris) is closed by deleting
  //! that piece instead: no patch can close it (a patch would lie on the piece's back), and the
  //! piece is no part of the surface. Off by default: the piece is the input's data.
  bool remove_fragments = false;
  //! Before the fill, close the rim's narrow notches (corners under 15°) with their ears where
  //! those continue the surface (pinch_closing.h: close_notches); counted in angles_closed. Not
  //! under explicit_creases, whose picks name rim vertices an ear would take out of the loop.
  bool close_notches = true;
  //! fill_holes: two selected loops that border one ring-shaped hole (one inside the other on
  //! one plane, running opposite ways: ring_joining.h) are joined by two triangles and filled
  //! as one loop; if that fails, each is filled alone.
  bool join_ring_borders = true;
};

struct HoleFillReport {
  std::uint32_t hole_id = 0;
  std::size_t boundary_vertices = 0;
  bool filled = false;
  bool skipped = false;  //!< not attempted (above the size limit)
  std::string reason;    //!< why the hole was left open or skipped
  FillMethod method = FillMethod::Planar;
  std::string reference_plane;          //!< which normal made the hole simple ("none" if complex)
  PatchShape shape = PatchShape::Flat;  //!< the shape actually applied
  std::string shape_reason;
  //! Faired patches: the surface fitted to the surroundings that the fairing continued
  //! ("sphere", "quadric"; fairing.h), empty when the plain bi-Laplacian was used.
  std::string fair_base;
  //! The last faired attempt: how far its vertices rose off the spanning triangulation, in hole
  //! radii (above FillOptions::max_fair_bulge it was refused as a balloon); 0 if none was faired.
  double fair_bulge = 0;
  std::size_t pieces = 1;
  std::string creases;  //!< SharpMode::Auto: what crosses the hole and what was done with it
  std::size_t crease_curves = 0;  //!< curves the patch was split along
  //! Rim corners closed with one triangle before the triangulation: the planar method's angles
  //! under 5π/9 (seed 000 §3.4.2) and the narrow notches (FillOptions::close_notches).
  std::size_t angles_closed = 0;
  std::size_t refinement_rounds = 0;
  std::size_t splits = 0;
  std::size_t flips = 0;
  std::size_t faces_added = 0;
  std::size_t vertices_added = 0;
  double min_angle_deg = 0;  //!< smallest angle of the new triangles
  double seconds = 0;
  //! Where the time went (all attempts; seconds): what a slow fill spent it on.
  struct Phases {
    double plan = 0;         //!< the hole's projectability (in fill_holes), the shape decision and
                             //!< the crease plan (once per hole)
    double triangulate = 0;  //!< the triangulations of every method tried
    double refine = 0;       //!< Algorithm III
    double mend = 0;         //!< patch_quality
    double fair = 0;         //!< the fairing solves
    double check = 0;        //!< gathering the faces near the hole, and the intersection checks
    Phases& operator+=(const Phases& other) {
      plan += other.plan;
      triangulate += other.triangulate;
      refine += other.refine;
      mend += other.mend;
      fair += other.fair;
      check += other.check;
      return *this;
    }
  } phases;
  std::vector<std::string> warnings;
  std::vector<FaceHandle> new_faces;
  std::vector<VertexHandle> new_vertices;
  //! FillOptions::remove_fragments: the fragment's faces deleted instead of a fill, and its
  //! vertices that no other face used (deleted with them). The hole is then neither filled nor
  //! left open: its loop is gone with the piece.
  std::vector<FaceHandle> removed_faces;
  std::vector<VertexHandle> removed_vertices;
  bool fragment_removed() const { return !removed_faces.empty(); }
};

//! Fills one hole found by find_holes() on the current mesh. On failure the mesh is
//! unchanged (faces the attempt added are deleted elements; serialize_mesh skips them).
HoleFillReport fill_hole(Mesh& mesh, const Hole& hole, const FillOptions& options = {});
//! The same with the searches' reach kept by the caller across several edits of one mesh (a
//! zipper and the fills after it): made by make_search_reach on first use, the new faces filed
//! in it.
HoleFillReport fill_hole(Mesh& mesh, const Hole& hole, const FillOptions& options,
                         SearchReach& reach);

struct FillSelection {
  enum class Mode { All, Ids, Nearest };
  Mode mode = Mode::All;
  std::vector<std::uint32_t> ids;  //!< Mode::Ids
  Vec3 point{0, 0, 0};             //!< Mode::Nearest
  std::size_t max_boundary = 0;    //!< holes with more boundary edges are skipped (0: no limit)
};

struct FillReport {
  std::vector<HoleFillReport> holes;
  std::vector<std::uint32_t> unknown_ids;  //!< requested ids that name no hole
  std::size_t holes_found = 0;
  //! The call's preparation before its first fill (the search reach over the whole mesh;
  //! headroom in the arrays; the ring borders), in no hole's time but part of the call's.
  double prepare_seconds = 0;
  std::size_t filled() const;
  std::size_t left_open() const;  //!< neither filled, skipped, nor closed by a fragment's removal
  std::size_t fragments_removed() const;
};

//! Called after each hole with (holes done, holes selected); return false to stop early.
using FillProgress = std::function<bool(std::size_t done, std::size_t total)>;

//! Finds the holes and fills the selected ones in id order. A caller that already searched
//! the current mesh (an interactive session between edits) passes \p known_holes to skip the
//! search; properties computed for the selected holes are stored back into it.
//! A caller that keeps the mesh's search reach across calls passes \p known_reach: made here
//! when empty, then used and extended with the faces the call adds, instead of a pass over the
//! whole mesh per call. Between calls the caller keeps it true: SearchReach::add for faces it
//! adds, SearchReach::note_moved for vertices it moves; reset when the mesh is compacted.
FillReport fill_holes(Mesh& mesh, const FillSelection& selection, const FillOptions& options = {},
                      const FillProgress& progress = {}, HoleSearchResult* known_holes = nullptr,
                      std::optional<SearchReach>* known_reach = nullptr);

}  // namespace touchmend::geometry
