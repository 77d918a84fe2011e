#include "client/cli/commands.h"

#include <charconv>
#include <cmath>
#include <iostream>
#include <ostream>
#include <unistd.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "client/cli/reports.h"
#include "server/geometry/hole_filling.h"
#include "server/geometry/holes.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_io.h"
#include "server/geometry/metrics.h"

namespace touchmend::cli {
namespace {

nlohmann::json bounds_json(const geometry::Mesh& mesh) {
  geometry::Vec3 lo(0, 0, 0), hi(0, 0, 0);
  bool first = true;
  for (const auto v : mesh.vertices()) {
    const auto& p = mesh.point(v);
    if (first) {
      lo = hi = p;
      first = false;
    }
    lo.minimize(p);
    hi.maximize(p);
  }
  return {{"min", {lo[0], lo[1], lo[2]}},
          {"max", {hi[0], hi[1], hi[2]}},
          {"diagonal", (hi - lo).norm()}};
}

}  // namespace

std::optional<Loaded> load(const std::string& file, std::ostream& err) {
  geometry::ReadResult read = geometry::read_mesh_file(file);
  if (!read.ok) {
    err << "error: " << read.error << "\n";
    return std::nullopt;
  }
  if (read.soup.triangles.empty()) {
    err << "error: " << file << ": the mesh has no faces\n";
    return std::nullopt;
  }
  Loaded l{geometry::build_mesh(read.soup), read.report};
  return l;
}

bool parse_point(const std::string& text, geometry::Vec3& point) {
  std::size_t start = 0;
  for (int k = 0; k < 3; ++k) {
    const std::size_t end = k < 2 ? text.find(',', start) : text.size();
    if (end == std::string::npos) return false;
    const char* first = text.data() + start;
    const char* last = text.data() + end;
    if (first < last && *first == '+') ++first;
    const auto [ptr, ec] = std::from_chars(first, last, point[k]);
    if (ec != std::errc() || ptr != last || !std::isfinite(point[k])) return false;
    start = end + 1;
  }
  return true;
}

int run_info(const InfoArgs& args, std::ostream& out, std::ostream& err) {
  const auto loaded = load(args.file, err);
  if (!loaded) return kExitBadInput;
  const auto& mesh = loaded->built.mesh;
  const auto& report = loaded->built.report;
  if (args.json) {
    nlohmann::json j = {{"file", args.file},
                        {"format", geometry::format_name(loaded->read.format)},
                        {"binary", loaded->read.binary},
                        {"polygons_triangulated", loaded->read.polygons_triangulated},
                        {"stl_corners_welded", loaded->read.stl_corners_welded},
                        {"vertices", mesh.n_vertices()},
                        {"faces", mesh.n_faces()},
                        {"edges", mesh.n_edges()},
                        {"bounds", bounds_json(mesh)},
                        {"validation", to_json(report)}};
    out << j.dump(2) << "\n";
    return kExitOk;
  }
  const nlohmann::json b = bounds_json(mesh);
  out << fmt::format("file                {} ({}{})\n", args.file,
                     geometry::format_name(loaded->read.format),
                     loaded->read.binary ? ", binary" : "");
  out << fmt::format("mesh                {} vertices, {} faces, {} edges\n", mesh.n_vertices(),
                     mesh.n_faces(), mesh.n_edges());
  out << fmt::format(
      "bounds              ({}, {}, {}) .. ({}, {}, {}), diagonal {}\n", b["min"][0].get<double>(),
      b["min"][1].get<double>(), b["min"][2].get<double>(), b["max"][0].get<double>(),
      b["max"][1].get<double>(), b["max"][2].get<double>(), b["diagonal"].get<double>());
  if (loaded->read.polygons_triangulated)
    out << fmt::format("polygons split      {}\n", loaded->read.polygons_triangulated);
  if (loaded->read.stl_corners_welded)
    out << fmt::format("STL corners welded  {}\n", loaded->read.stl_corners_welded);
  out << validation_text(report);
  return kExitOk;
}

int run_holes(const HolesArgs& args, std::ostream& out, std::ostream& err) {
  const auto loaded = load(args.file, err);
  if (!loaded) return kExitBadInput;
  const geometry::HoleSearchResult found = geometry::find_holes(loaded->built.mesh);
  if (found.corrupt_fans > 0)
    err << fmt::format("warning: {} boundary walks hit a corrupt vertex fan\n", found.corrupt_fans);
  if (args.json) {
    nlohmann::json holes = nlohmann::json::array();
    for (const auto& h : found.holes) holes.push_back(to_json(h));
    out << nlohmann::json{{"file", args.file}, {"holes", holes}}.dump(2) << "\n";
  } else {
    out << holes_text(found.holes);
  }
  return kExitOk;
}

int run_fill(const FillArgs& args, std::ostream& out, std::ostream& err) {
  geometry::MeshFormat out_format;
  if (!geometry::format_from_path(args.output, out_format)) {
    err << "error: " << args.output
        << ": unknown output extension (expected .stl, .obj, .off or .ply)\n";
    return kExitUsage;
  }
  const int modes = (args.all ? 1 : 0) + (args.hole_ids.empty() ? 0 : 1) + (args.near ? 1 : 0);
  if (modes != 1) {
    err << "error: choose exactly one of --all, --hole ID... or --near X,Y,Z\n";
    return kExitUsage;
  }
  geometry::FillOptions options;
  if (!geometry::parse_patch_shape(args.shape, options.shape)) {
    err << "error: --shape must be flat, fair or auto\n";
    return kExitUsage;
  }
  if (!geometry::parse_sharp_mode(args.sharp, options.sharp)) {
    err << "error: --sharp must be off or auto\n";
    return kExitUsage;
  }
  if (!(args.crease_angle > 0 && args.crease_angle < 180)) {
    err << "error: --crease-angle must be between 0 and 180 degrees\n";
    return kExitUsage;
  }
  options.creases.crease_angle_deg = args.crease_angle;
  options.creases.partner_angle_deg =
      std::min(options.creases.partner_angle_deg, args.crease_angle);
  options.refine_iterations = args.refine_iterations;
  options.remove_fragments = args.remove_fragments;
  auto loaded = load(args.file, err);
  if (!loaded) return kExitBadInput;
  geometry::Mesh& mesh = loaded->built.mesh;
  geometry::FillSelection selection;
  if (args.all) {
    selection.mode = geometry::FillSelection::Mode::All;
  } else if (!args.hole_ids.empty()) {
    selection.mode = geometry::FillSelection::Mode::Ids;
    selection.ids = args.hole_ids;
  } else {
    selection.mode = geometry::FillSelection::Mode::Nearest;
    selection.point = *args.near;
  }
  selection.max_boundary = args.max_boundary;

  // Unknown ids are bad input: check before doing any work.
  if (selection.mode == geometry::FillSelection::Mode::Ids) {
    const auto found = geometry::find_holes(mesh, {.compute_projectability = false});
    std::vector<std::uint32_t> unknown;
    for (const auto id : selection.ids)
      if (!geometry::find_hole_by_id(found.holes, id)) unknown.push_back(id);
    if (!unknown.empty()) {
      std::string known;
      for (std::size_t i = 0; i < found.holes.size() && i < 20; ++i)
        known += (i ? ", " : "") + std::to_string(found.holes[i].id);
      err << fmt::format("error: {}: no hole with id {} (the mesh has {} holes{}{})\n", args.file,
                         fmt::join(unknown, ", "), found.holes.size(),
                         found.holes.empty() ? "" : ": ", known);
      return kExitBadInput;
    }
  }
  // Progress on stderr for multi-hole fills when it is a terminal, so stdout stays the report.
  const bool show_progress = !args.json && &err == &std::cerr && ::isatty(STDERR_FILENO) != 0;
  const geometry::FillReport report =
      geometry::fill_holes(mesh, selection, options, [&](std::size_t done, std::size_t total) {
        if (show_progress && total > 1)
          err << fmt::format("[{}/{}] holes processed\r", done, total) << std::flush;
        return true;
      });
  if (show_progress && report.holes.size() > 1) err << "\n";
  if (selection.mode == geometry::FillSelection::Mode::Nearest && report.holes.empty()) {
    err << "error: " << args.file << ": the mesh has no holes\n";
    return kExitBadInput;
  }
  // The writer skips the deleted elements of failed attempts and keeps the others' order (the
  // server's documents keep creation order too, so a fill gives the same file either way;
  // OpenMesh's garbage collection would move the last elements into the gaps).
  geometry::WriteOptions wo;
  wo.binary = args.binary;
  const geometry::WriteResult written = geometry::write_mesh_file(mesh, args.output, wo);
  if (!written.ok) {
    err << "error: " << written.error << "\n";
    return kExitBadInput;
  }
  for (const std::string& w : written.warnings) err << "warning: " << w << "\n";
  const std::size_t filled = report.filled();
  const std::size_t open = report.left_open();
  std::size_t skipped = 0;
  for (const auto& h : report.holes) skipped += h.skipped ? 1 : 0;
  const std::size_t removed = report.fragments_removed();
  if (args.json) {
    nlohmann::json holes = nlohmann::json::array();
    for (const auto& h : report.holes) holes.push_back(to_json(h));
    out << nlohmann::json{{"input", args.file},
                          {"output", args.output},
                          {"holes_found", report.holes_found},
                          {"selected", report.holes.size()},
                          {"filled", filled},
                          {"left_open", open},
                          {"skipped", skipped},
                          {"fragments_removed", removed},
                          {"vertices_written", written.vertices_written},
                          {"faces_written", written.faces_written},
                          {"holes", holes}}
               .dump(2)
        << "\n";
  } else {
    for (const auto& h : report.holes) out << fill_text(h);
    out << fill_summary(filled, report.holes.size(), open, skipped, removed, report.holes_found);
    out << fmt::format("wrote {} ({} vertices, {} faces)\n", args.output, written.vertices_written,
                       written.faces_written);
  }
  return args.strict && open > 0 ? kExitLeftOpen : kExitOk;
}

}  // namespace touchmend::cli
