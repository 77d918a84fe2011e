#include "client/cli/reports.h"

#include <fmt/format.h>

namespace touchmend::cli {
namespace {

nlohmann::json vec(const geometry::Vec3& v) {
  return nlohmann::json::array({v[0], v[1], v[2]});
}

}  // namespace

nlohmann::json to_json(const geometry::ValidationReport& r) {
  nlohmann::json refused = nlohmann::json::object();
  for (const auto reason :
       {geometry::RefusedFaceReason::RepeatedVertex, geometry::RefusedFaceReason::DuplicateFace,
        geometry::RefusedFaceReason::NonManifoldEdge, geometry::RefusedFaceReason::FlippedNeighbour,
        geometry::RefusedFaceReason::ComplexVertex})
    if (const std::size_t n = r.refused(reason)) refused[geometry::to_string(reason)] = n;
  nlohmann::json first = nlohmann::json::array();
  for (std::size_t i = 0; i < r.refused_faces.size() && i < 20; ++i)
    first.push_back({{"face", r.refused_faces[i].face_index},
                     {"reason", geometry::to_string(r.refused_faces[i].reason)}});
  return {{"input_vertices", r.input_vertices},
          {"input_faces", r.input_faces},
          {"unreferenced_vertices", r.unreferenced_vertices},
          {"degenerate_faces", r.degenerate_faces},
          {"duplicate_faces", r.duplicate_faces},
          {"non_manifold_edges", r.non_manifold_edges},
          {"inconsistent_orientation_edges", r.inconsistent_edges},
          {"non_manifold_vertices", r.non_manifold_vertices},
          {"refused_faces", r.refused_faces.size()},
          {"refused_by_reason", refused},
          {"first_refused_faces", first},
          {"boundary_edges", r.boundary_edges},
          {"boundary_loops", r.boundary_loops},
          {"clean", r.is_clean()}};
}

namespace {

std::vector<std::uint32_t> pinched_ids(const geometry::Hole& h) {
  std::vector<std::uint32_t> ids;
  for (const auto v : h.pinched_at) ids.push_back(static_cast<std::uint32_t>(v.idx()));
  return ids;
}

}  // namespace

std::string pinch_note(const std::vector<std::uint32_t>& pinched_at) {
  if (pinched_at.empty()) return {};
  return fmt::format("  pinched at {} {}", pinched_at.size() == 1 ? "vertex" : "vertices",
                     fmt::join(pinched_at, ", "));
}

std::string fragment_note(std::size_t fragment_faces) {
  if (fragment_faces == 0) return {};
  return fmt::format("  border of a separate piece of {} face{}", fragment_faces,
                     fragment_faces == 1 ? "" : "s");
}

nlohmann::json to_json(const geometry::Hole& h) {
  nlohmann::json loop = nlohmann::json::array();
  for (const auto v : h.loop) loop.push_back(v.idx());
  nlohmann::json j = {{"id", h.id},
                      {"boundary_edges", h.loop.size()},
                      {"perimeter", h.perimeter},
                      {"area", h.area},
                      {"normal", vec(h.normal)},
                      {"centroid", vec(h.centroid)},
                      {"planarity", h.planarity},
                      {"simple", h.is_simple},
                      {"reference_plane", h.reference_source},
                      {"loop", loop}};
  if (!h.unfillable_reason.empty()) j["unfillable"] = h.unfillable_reason;
  if (!h.pinched_at.empty()) j["pinched_at"] = pinched_ids(h);
  if (h.fragment_faces > 0) j["fragment_faces"] = h.fragment_faces;
  return j;
}

std::string fill_summary(std::size_t filled, std::size_t selected, std::size_t open,
                         std::size_t skipped, std::size_t fragments_removed, std::size_t found) {
  return fmt::format(
      "filled {} of {} selected holes ({} left open, {} skipped{}; {} holes in the mesh)\n", filled,
      selected, open, skipped,
      fragments_removed > 0 ? fmt::format(", {} closed by removing a fragment", fragments_removed)
                            : std::string{},
      found);
}

nlohmann::json to_json(const geometry::HoleFillReport& r) {
  nlohmann::json j = {{"hole", r.hole_id},
                      {"boundary_edges", r.boundary_vertices},
                      {"filled", r.filled},
                      {"seconds", r.seconds}};
  if (r.skipped) {
    j["skipped"] = true;
    j["reason"] = r.reason;
    return j;
  }
  if (r.fragment_removed()) {
    j["fragment_removed"] = true;
    j["faces_removed"] = r.removed_faces.size();
    j["vertices_removed"] = r.removed_vertices.size();
  }
  if (!r.filled) {
    j["reason"] = r.reason;
    return j;
  }
  j["method"] = geometry::to_string(r.method);
  j["reference_plane"] = r.reference_plane;
  j["shape"] = geometry::to_string(r.shape);
  j["shape_reason"] = r.shape_reason;
  if (!r.fair_base.empty()) j["fair_base"] = r.fair_base;
  // How far the last faired try rose off the spanning triangulation (why a hole stayed flat).
  if (r.fair_bulge > 0) j["fair_bulge_hole_radii"] = r.fair_bulge;
  j["pieces"] = r.pieces;
  if (!r.creases.empty()) {
    j["creases"] = r.creases;
    j["crease_curves"] = r.crease_curves;
  }
  j["angles_closed"] = r.angles_closed;
  j["refinement_rounds"] = r.refinement_rounds;
  j["splits"] = r.splits;
  j["flips"] = r.flips;
  j["faces_added"] = r.faces_added;
  j["vertices_added"] = r.vertices_added;
  j["min_angle_deg"] = r.min_angle_deg;
  if (!r.warnings.empty()) j["warnings"] = r.warnings;
  return j;
}

std::string validation_text(const geometry::ValidationReport& r) {
  std::string out;
  out += fmt::format("vertices            {} ({} unreferenced)\n", r.input_vertices,
                     r.unreferenced_vertices);
  out +=
      fmt::format("faces               {} ({} refused)\n", r.input_faces, r.refused_faces.size());
  out +=
      fmt::format("boundary            {} edges in {} loops\n", r.boundary_edges, r.boundary_loops);
  out += fmt::format("degenerate faces    {}\n", r.degenerate_faces);
  out += fmt::format("duplicate faces     {}\n", r.duplicate_faces);
  out += fmt::format("non-manifold edges  {}\n", r.non_manifold_edges);
  out += fmt::format("non-manifold verts  {}\n", r.non_manifold_vertices);
  out += fmt::format("flipped edges       {} (inconsistent orientation)\n", r.inconsistent_edges);
  for (const auto reason :
       {geometry::RefusedFaceReason::RepeatedVertex, geometry::RefusedFaceReason::DuplicateFace,
        geometry::RefusedFaceReason::NonManifoldEdge, geometry::RefusedFaceReason::FlippedNeighbour,
        geometry::RefusedFaceReason::ComplexVertex})
    if (const std::size_t n = r.refused(reason))
      out += fmt::format("  refused: {} face(s): {}\n", n, geometry::to_string(reason));
  out += r.is_clean() ? "status              clean\n"
                      : "status              defects found (see above)\n";
  return out;
}

std::string holes_text(const std::vector<geometry::Hole>& holes) {
  if (holes.empty()) return "no holes: the mesh is closed\n";
  std::string out = fmt::format("{:>8} {:>6} {:>12} {:>12} {:>8}  {:<30} {}\n", "id", "edges",
                                "perimeter", "area", "kind", "centroid", "normal");
  for (const geometry::Hole& h : holes) {
    out += fmt::format(
        "{:>8} {:>6} {:>12.6g} {:>12.6g} {:>8}  {:<30} ({:.3f}, {:.3f}, {:.3f}){}\n", h.id,
        h.loop.size(), h.perimeter, h.area, h.is_simple ? "simple" : "complex",
        fmt::format("({:.6g}, {:.6g}, {:.6g})", h.centroid[0], h.centroid[1], h.centroid[2]),
        h.normal[0], h.normal[1], h.normal[2],
        pinch_note(pinched_ids(h)) + fragment_note(h.fragment_faces) +
            (h.unfillable_reason.empty() ? "" : "  unfillable: " + h.unfillable_reason));
  }
  return out;
}

std::string fill_text(const geometry::HoleFillReport& r) {
  if (r.skipped) return fmt::format("hole {:>6}: skipped ({})\n", r.hole_id, r.reason);
  if (r.fragment_removed()) return fmt::format("hole {:>6}: removed: {}\n", r.hole_id, r.reason);
  if (!r.filled) return fmt::format("hole {:>6}: LEFT OPEN: {}\n", r.hole_id, r.reason);
  std::string out = fmt::format(
      "hole {:>6}: filled, {} boundary edges, method {}, shape {} ({}), {} faces and {} vertices "
      "added, smallest angle {:.1f} deg, {} refinement rounds, {:.2f} ms\n",
      r.hole_id, r.boundary_vertices, geometry::to_string(r.method), geometry::to_string(r.shape),
      r.shape_reason, r.faces_added, r.vertices_added, r.min_angle_deg, r.refinement_rounds,
      r.seconds * 1e3);
  if (!r.creases.empty() && r.crease_curves == 0)
    out += fmt::format("             sharp edges: {} (none retained)\n", r.creases);
  for (const std::string& w : r.warnings) out += fmt::format("             warning: {}\n", w);
  return out;
}

}  // namespace touchmend::cli
