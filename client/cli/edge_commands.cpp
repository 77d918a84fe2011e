// `touchmend sharpen`, `touchmend gaps`, `touchmend bridge`: sharp-edge retaining from four
// picked points and gap bridging (seed 000 ch. 4) for automated clients, in process.

#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "client/cli/commands.h"
#include "client/cli/reports.h"
#include "server/geometry/gap_bridging.h"
#include "server/geometry/holes.h"
#include "server/geometry/mesh_io.h"
#include "server/geometry/metrics.h"
#include "server/geometry/sharpen.h"

namespace touchmend::cli {
namespace {

//! Writes atomically; prints the error and returns false on failure.
bool write_result(const geometry::Mesh& mesh, const std::string& path, bool binary,
                  std::ostream& err, geometry::WriteResult& written) {
  geometry::WriteOptions wo;  // the writer skips deleted elements, in order
  wo.binary = binary;
  written = geometry::write_mesh_file(mesh, path, wo);
  if (!written.ok) {
    err << "error: " << written.error << "\n";
    return false;
  }
  for (const std::string& w : written.warnings) err << "warning: " << w << "\n";
  return true;
}

nlohmann::json point_json(const geometry::Vec3& p) {
  return {p[0], p[1], p[2]};
}

nlohmann::json gap_json(const geometry::Mesh& mesh, const geometry::Gap& g) {
  nlohmann::json a = nlohmann::json::array(), b = nlohmann::json::array();
  for (const auto v : g.run_a) a.push_back(v.idx());
  for (const auto v : g.run_b) b.push_back(v.idx());
  return {{"id", g.id},
          {"hole_a", g.hole_a},
          {"hole_b", g.hole_b},
          {"cyclic", g.cyclic},
          {"mean_width", g.mean_width},
          {"max_width", g.max_width},
          {"length", g.length},
          {"start", point_json(mesh.point(g.run_a.front()))},
          {"run_a", a},
          {"run_b", b}};
}

std::vector<geometry::Gap> detect(const geometry::Mesh& mesh, double max_width) {
  geometry::GapOptions options;
  options.max_width = max_width;
  return geometry::find_gaps(mesh, geometry::find_holes(mesh).holes, options);
}

}  // namespace

namespace {

//! "X,Y,Z;X,Y,Z;..." into finite points (none for an empty text).
bool parse_point_list(const std::string& text, std::vector<geometry::Vec3>& parsed) {
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ';')) {
    geometry::Vec3 p;
    if (!parse_point(item, p)) return false;
    parsed.push_back(p);
  }
  return true;
}

}  // namespace

bool parse_points(const std::string& text, geometry::HermitePoints& points) {
  std::vector<geometry::Vec3> parsed;
  if (!parse_point_list(text, parsed) || parsed.size() != 4) return false;
  points = {parsed[0], parsed[1], parsed[2], parsed[3]};
  return true;
}

bool parse_sharpen_picks(const SharpenArgs& args, geometry::PickedCreases& picked,
                         std::ostream& err) {
  picked = {};
  for (const std::string& text : args.points) {
    geometry::HermitePoints curve;
    if (!parse_points(text, curve)) {
      err << "error: --points expects four points X,Y,Z;X,Y,Z;X,Y,Z;X,Y,Z (P1, P2 on one side "
             "of the hole, P2 nearest it; P3 nearest on the other side, then P4), got '"
          << text << "'\n";
      return false;
    }
    picked.curves.push_back(curve);
  }
  std::vector<geometry::Vec3> corner;
  if (!parse_point_list(args.corner, corner) || corner.size() % 2 != 0 ||
      (!corner.empty() && corner.size() < 6)) {
    err << "error: --corner expects two points per crease, three creases or more "
           "(X,Y,Z;X,Y,Z;... : on each crease a point away from the hole, then the point where "
           "it meets the rim), got '"
        << args.corner << "'\n";
    return false;
  }
  for (std::size_t i = 0; i < corner.size(); i += 2)
    picked.corner.push_back({corner[i], corner[i + 1]});
  if (picked.curves.empty() && picked.corner.empty()) {
    err << "error: pick the crease: --points P1;P2;P3;P4 (one curve through the hole, repeat "
           "for more) and/or --corner (creases meeting inside it)\n";
    return false;
  }
  if (!picked.one_curve() && args.method != "split") {
    err << "error: several curves or a corner are retained by --method split only (the "
           "push-down follows one curve)\n";
    return false;
  }
  return true;
}

int run_sharpen(const SharpenArgs& args, std::ostream& out, std::ostream& err) {
  geometry::MeshFormat format;
  if (!geometry::format_from_path(args.output, format)) {
    err << "error: " << args.output
        << ": unknown output extension (expected .stl, .obj, .off or .ply)\n";
    return kExitUsage;
  }
  geometry::PickedCreases picked;
  if (!parse_sharpen_picks(args, picked, err)) return kExitUsage;
  geometry::SharpenOptions options;
  if (args.method == "split")
    options.method = geometry::SharpenMethod::Split;
  else if (args.method == "push-down")
    options.method = geometry::SharpenMethod::PushDown;
  else {
    err << "error: --method must be split or push-down\n";
    return kExitUsage;
  }
  if (args.depth != 0 && options.method != geometry::SharpenMethod::PushDown) {
    err << "error: --depth applies to --method push-down (the split variant puts the crease "
           "exactly on the curve)\n";
    return kExitUsage;
  }
  if (!args.finish.empty() && options.method != geometry::SharpenMethod::PushDown) {
    err << "error: --finish applies to --method push-down (the split variant fills each side "
           "of the curve by the fill's own shape rules)\n";
    return kExitUsage;
  }
  if (!args.finish.empty() && !geometry::parse_push_finish(args.finish, options.finish)) {
    err << "error: --finish must be fair, smooth or none\n";
    return kExitUsage;
  }
  if (!geometry::parse_patch_shape(args.shape, options.fill.shape)) {
    err << "error: --shape must be flat, fair or auto\n";
    return kExitUsage;
  }
  if (!geometry::parse_pick_tangents(args.tangents, options.tangents)) {
    err << "error: --tangents must be crease or chord\n";
    return kExitUsage;
  }
  options.fill.refine_iterations = args.refine_iterations;
  options.hermite.k1 = args.k1;
  options.hermite.k4 = args.k4;
  options.depth = args.depth;
  auto loaded = load(args.file, err);
  if (!loaded) return kExitBadInput;
  geometry::Mesh& mesh = loaded->built.mesh;
  const auto holes = geometry::find_holes(mesh).holes;
  const auto index = geometry::find_hole_by_id(holes, args.hole);
  if (!index) {
    err << fmt::format(
        "error: {}: no hole with id {} (the mesh has {} holes; see `touchmend "
        "holes`)\n",
        args.file, args.hole, holes.size());
    return kExitBadInput;
  }
  const bool one_curve = picked.one_curve();
  const geometry::SharpenResult r =
      one_curve ? geometry::sharpen_hole(mesh, holes[*index], picked.curves[0], options)
                : geometry::sharpen_creases(mesh, holes[*index], picked, options);
  if (!r.ok) {
    err << fmt::format("error: hole {}: {}\n", args.hole, r.failure);
    return kExitBadInput;
  }
  geometry::WriteResult written;
  if (!write_result(mesh, args.output, args.binary, err, written)) return kExitBadInput;
  if (args.json) {
    nlohmann::json j{
        {"input", args.file},
        {"output", args.output},
        {"hole", args.hole},
        {"method", geometry::to_string(options.method)},
        {"points",
         {point_json(r.points.p1), point_json(r.points.p2), point_json(r.points.p3),
          point_json(r.points.p4)}},
        {"tangents", geometry::to_string(options.tangents)},
        {"crease_tangents", {{"start", r.crease_tangent_start}, {"end", r.crease_tangent_end}}},
        {"curves", picked.curves.size()},
        {"corner_creases", picked.corner.size()},
        {"corner", r.corner ? point_json(*r.corner) : nlohmann::json()},
        {"crease_tangents_taken", r.crease_tangents_taken},
        {"arcs", r.arcs},
        {"fill", to_json(r.fill)},
        {"snapped", r.snap.moved},
        {"split_edges", r.snap.splits},
        {"pushed", r.pushed},
        {"finish", geometry::to_string(options.finish)},
        {"smoothed", r.finish.smooth.moved},
        {"faired", r.finish.fairing.moved},
        {"finish_undone", r.finish.undone},
        {"patch_faces", r.patch.size()},
        {"vertices_written", written.vertices_written},
        {"faces_written", written.faces_written}};
    out << j.dump(2) << "\n";
  } else {
    out << fill_text(r.fill);
    out << (one_curve
                ? "curve: " + geometry::tangents_summary(r.crease_tangent_start,
                                                         r.crease_tangent_end, options.tangents)
                : "creases: " + geometry::creases_summary(r, picked, options.tangents))
        << "\n";
    if (options.method == geometry::SharpenMethod::PushDown)
      out << fmt::format(
          "sharp edge retained (push-down{}): {}\n",
          options.depth > 0 ? fmt::format(", up to {} past the curve", options.depth) : "",
          geometry::push_down_summary(r, options.finish));
    else
      out << "sharp edge retained (split): the hole was filled on both sides of "
          << (one_curve ? "the curve" : "every curve")
          << (r.arcs > 0 ? fmt::format(" ({} of them a circular arc that the picked creases "
                                       "continue, not a Hermite curve)",
                                       r.arcs)
                         : std::string())
          << "\n";
    out << fmt::format("wrote {} ({} vertices, {} faces)\n", args.output, written.vertices_written,
                       written.faces_written);
  }
  return kExitOk;
}

int run_gaps(const GapsArgs& args, std::ostream& out, std::ostream& err) {
  if (args.max_width < 0) {
    err << "error: --max-width must not be negative\n";
    return kExitUsage;
  }
  auto loaded = load(args.file, err);
  if (!loaded) return kExitBadInput;
  const geometry::Mesh& mesh = loaded->built.mesh;
  const auto gaps = detect(mesh, args.max_width);
  if (args.json) {
    nlohmann::json list = nlohmann::json::array();
    for (const auto& g : gaps) list.push_back(gap_json(mesh, g));
    out << nlohmann::json{{"file", args.file}, {"gaps", list}}.dump(2) << "\n";
    return kExitOk;
  }
  if (gaps.empty()) {
    out << "no gaps: no two boundary runs face each other within the width\n";
    return kExitOk;
  }
  out << fmt::format("{:>4} {:>8} {:>8} {:>7} {:>7} {:>12} {:>12} {:>12}\n", "gap", "loop a",
                     "loop b", "verts a", "verts b", "mean width", "max width", "length");
  for (const auto& g : gaps)
    out << fmt::format("{:>4} {:>8} {:>8} {:>7} {:>7} {:>12.6g} {:>12.6g} {:>12.6g}{}\n", g.id,
                       g.hole_a, g.hole_b, g.run_a.size(), g.run_b.size(), g.mean_width,
                       g.max_width, g.length, g.cyclic ? "  (all around)" : "");
  return kExitOk;
}

int run_bridge(const BridgeArgs& args, std::ostream& out, std::ostream& err) {
  geometry::MeshFormat format;
  if (!geometry::format_from_path(args.output, format)) {
    err << "error: " << args.output
        << ": unknown output extension (expected .stl, .obj, .off or .ply)\n";
    return kExitUsage;
  }
  if (args.all == !args.gap_ids.empty()) {
    err << "error: choose exactly one of --all or --gap ID...\n";
    return kExitUsage;
  }
  if (args.max_width < 0) {
    err << "error: --max-width must not be negative\n";
    return kExitUsage;
  }
  auto loaded = load(args.file, err);
  if (!loaded) return kExitBadInput;
  geometry::Mesh& mesh = loaded->built.mesh;
  const auto gaps = detect(mesh, args.max_width);
  std::vector<const geometry::Gap*> selected;
  if (args.all) {
    for (const auto& g : gaps) selected.push_back(&g);
  } else {
    for (const auto id : args.gap_ids) {
      if (id >= gaps.size()) {
        err << fmt::format(
            "error: {}: no gap with id {} (the mesh has {} gaps; see `touchmend "
            "gaps`)\n",
            args.file, id, gaps.size());
        return kExitBadInput;
      }
      selected.push_back(&gaps[id]);
    }
  }
  nlohmann::json results = nlohmann::json::array();
  std::size_t bridged = 0, faces = 0;
  std::string text;
  const geometry::DetectedGapsBridge all = geometry::bridge_detected_gaps(mesh, selected);
  for (std::size_t k = 0; k < selected.size(); ++k) {
    const geometry::Gap* g = selected[k];
    const geometry::DetectedGapBridge& b = all.gaps[k];
    std::size_t end_faces = 0;
    for (const auto& f : b.end_fills) end_faces += f.faces_added;
    bridged += b.zip.ok ? 1 : 0;
    faces += b.zip.faces.size() + end_faces;
    nlohmann::json j{{"gap", g->id}, {"bridged", b.zip.ok}};
    if (b.zip.ok) {
      j["zipper_faces"] = b.zip.faces.size();
      j["end_faces"] = end_faces;
      text += fmt::format("gap {:>4}: bridged, {} zipper triangles, {} at the ends\n", g->id,
                          b.zip.faces.size(), end_faces);
    } else {
      j["reason"] = b.zip.reason;
      text += fmt::format("gap {:>4}: LEFT OPEN: {}\n", g->id, b.zip.reason);
    }
    results.push_back(j);
  }
  std::size_t leftover_faces = 0, leftover_open = 0;
  for (const auto& f : all.leftover_fills) {
    leftover_faces += f.faces_added;
    leftover_open += f.filled ? 0 : 1;
    if (!f.filled)
      text += fmt::format("between the zippers: a narrow hole LEFT OPEN: {}\n", f.reason);
  }
  faces += leftover_faces;
  if (!all.leftover_fills.empty())
    text += fmt::format("between the zippers: {} narrow holes filled ({} faces)\n",
                        all.leftover_fills.size() - leftover_open, leftover_faces);
  geometry::WriteResult written;
  if (!write_result(mesh, args.output, args.binary, err, written)) return kExitBadInput;
  if (args.json) {
    out << nlohmann::json{{"input", args.file},
                          {"output", args.output},
                          {"gaps_found", gaps.size()},
                          {"bridged", bridged},
                          {"faces_added", faces},
                          {"gaps", results},
                          {"leftover_holes_filled", all.leftover_fills.size() - leftover_open},
                          {"leftover_holes_open", leftover_open},
                          {"leftover_faces", leftover_faces}}
               .dump(2)
        << "\n";
  } else {
    out << text;
    out << fmt::format("bridged {} of {} selected gaps ({} gaps found), {} faces added\n", bridged,
                       selected.size(), gaps.size(), faces);
    out << fmt::format("wrote {} ({} vertices, {} faces)\n", args.output, written.vertices_written,
                       written.faces_written);
  }
  return kExitOk;
}

}  // namespace touchmend::cli
