#include "tests/support/cases.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <set>
#include <sstream>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "server/geometry/mesh_io.h"

namespace touchmend::testing {

namespace fs = std::filesystem;

std::string shared_data_dir() {
  if (const char* env = std::getenv("TOUCHMEND_SHARED_DATA")) return env;
  return TOUCHMEND_SHARED_DATA_DIR;
}

std::vector<std::string> list_cases() {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(fs::path(shared_data_dir()) / "cases", ec))
    if (entry.is_directory() && fs::exists(entry.path() / "case.json"))
      out.push_back(entry.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

namespace {

std::vector<std::uint32_t> read_ids(std::istringstream& line) {
  std::vector<std::uint32_t> ids;
  std::uint32_t v;
  while (line >> v) ids.push_back(v);
  return ids;
}

}  // namespace

std::optional<HoleCase> load_case(const std::string& name, std::string& error) {
  HoleCase c;
  c.name = name;
  c.directory = (fs::path(shared_data_dir()) / "cases" / name).string();
  std::ifstream json_file(fs::path(c.directory) / "case.json");
  if (!json_file) {
    error = c.directory + "/case.json: cannot open";
    return std::nullopt;
  }
  nlohmann::json j;
  try {
    json_file >> j;
  } catch (const std::exception& e) {
    error = c.directory + "/case.json: " + e.what();
    return std::nullopt;
  }
  const std::string original = j.value("original", "");
  c.original_path = (fs::path(c.directory) / original).lexically_normal().string();
  const bool real = j.value("type", "") != "cut_holes";
  c.holed_path =
      real ? c.original_path : (fs::path(c.directory) / j.value("input", "holed.off")).string();
  auto original_read = geometry::read_mesh_file(c.original_path);
  if (!original_read.ok) {
    error = original_read.error;
    return std::nullopt;
  }
  c.original = std::move(original_read.soup);
  auto holed_read = geometry::read_mesh_file(c.holed_path);
  if (!holed_read.ok) {
    error = holed_read.error;
    return std::nullopt;
  }
  c.holed = std::move(holed_read.soup);
  Eigen::AlignedBox3d box;
  std::vector<char> used(c.original.points.size(), 0);
  for (const auto& t : c.original.triangles)
    for (auto v : t) used[v] = 1;
  for (std::size_t i = 0; i < c.original.points.size(); ++i)
    if (used[i])
      box.extend(Eigen::Vector3d(c.original.points[i][0], c.original.points[i][1],
                                 c.original.points[i][2]));
  c.diagonal = box.diagonal().norm();
  if (!real) {
    std::ifstream holes_file(fs::path(c.directory) / j.value("holes_file", "holed.holes.txt"));
    std::string line;
    CaseHole* current = nullptr;
    while (std::getline(holes_file, line)) {
      std::istringstream in(line);
      std::string key;
      in >> key;
      if (key == "hole") {
        c.holes.emplace_back();
        current = &c.holes.back();
        in >> current->id;
        std::string k;
        while (in >> k)
          if (k == "kind") in >> current->kind;
      } else if (current && key == "faces") {
        current->original_faces = read_ids(in);
      } else if (current && key == "loop_holed") {
        current->loop_holed = read_ids(in);
      }
    }
  }
  return c;
}

std::vector<geometry::TrianglePoints> ground_truth(const HoleCase& c, const CaseHole& hole) {
  std::vector<geometry::TrianglePoints> out;
  for (const std::uint32_t f : hole.original_faces) {
    const auto& t = c.original.triangles.at(f);
    out.push_back({c.original.points[t[0]], c.original.points[t[1]], c.original.points[t[2]]});
  }
  return out;
}

std::vector<std::array<geometry::Vec3, 2>> ground_truth_creases(const HoleCase& c,
                                                                const CaseHole& hole,
                                                                double sharp_deg) {
  // Each undirected edge of the removed faces with its two face normals.
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<geometry::Vec3>> edges;
  for (const std::uint32_t f : hole.original_faces) {
    const auto& t = c.original.triangles.at(f);
    const geometry::Vec3 n = OpenMesh::cross(c.original.points[t[1]] - c.original.points[t[0]],
                                             c.original.points[t[2]] - c.original.points[t[0]])
                                 .normalize_cond();
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = t[static_cast<std::size_t>(k)],
                          b = t[static_cast<std::size_t>((k + 1) % 3)];
      edges[{std::min(a, b), std::max(a, b)}].push_back(n);
    }
  }
  std::vector<std::array<geometry::Vec3, 2>> out;
  const double limit = std::cos(sharp_deg * std::numbers::pi / 180.0);
  for (const auto& [edge, normals] : edges)
    if (normals.size() == 2 && OpenMesh::dot(normals[0], normals[1]) < limit)
      out.push_back({c.original.points[edge.first], c.original.points[edge.second]});
  return out;
}

std::optional<std::uint32_t> matching_hole_id(const std::vector<geometry::Hole>& holes,
                                              const CaseHole& hole) {
  const std::set<std::uint32_t> wanted(hole.loop_holed.begin(), hole.loop_holed.end());
  for (const auto& h : holes) {
    std::set<std::uint32_t> have;
    for (const auto v : h.loop) have.insert(static_cast<std::uint32_t>(v.idx()));
    if (have == wanted) return h.id;
  }
  return std::nullopt;
}

std::map<std::pair<std::string, std::string>, AnchorNumbers> read_baseline() {
  std::map<std::pair<std::string, std::string>, AnchorNumbers> out;
  std::ifstream in(fs::path(shared_data_dir()) / "cases" / "BASELINE.md");
  std::string line;
  auto number = [](const std::string& cell, double& value) {
    try {
      value = std::stod(cell);
      return true;
    } catch (...) {
      return false;
    }
  };
  while (std::getline(in, line)) {
    if (line.rfind("| ", 0) != 0) continue;
    std::vector<std::string> cells;
    std::stringstream ss(line.substr(1));
    std::string cell;
    while (std::getline(ss, cell, '|')) {
      cell.erase(0, cell.find_first_not_of(' '));
      cell.erase(cell.find_last_not_of(' ') + 1);
      cells.push_back(cell);
    }
    // Per-hole rows: case | hole | kind | r | bnd | GT faces | crease | method | ms | new faces | H
    // | H f->g | H g->f | mean ...
    if (cells.size() < 20) continue;
    const std::string& method = cells[7];
    if (method.find("CGAL") == std::string::npos && method.find("MeshLab") == std::string::npos)
      continue;
    AnchorNumbers& a = out[{cells[0], cells[1]}];
    double mean = 0, hausdorff = 0, ms = 0;
    if (number(cells[13], mean) && (a.best_mean < 0 || mean < a.best_mean)) a.best_mean = mean;
    if (method == "CGAL refine+fair") {
      if (number(cells[13], mean)) a.cgal_fair_mean = mean;
      if (number(cells[10], hausdorff)) a.cgal_fair_hausdorff = hausdorff;
      if (number(cells[8], ms)) a.cgal_fair_ms = ms;
    }
  }
  return out;
}

HoleScore score_fill(const geometry::Mesh& mesh, const geometry::HoleFillReport& fill,
                     const HoleCase& c, const CaseHole& hole) {
  HoleScore s;
  const auto fill_triangles = geometry::face_triangles(mesh, fill.new_faces);
  const auto gt = ground_truth(c, hole);
  s.distance = geometry::surface_distance(fill_triangles, gt, 0.002 * c.diagonal);
  s.quality = geometry::triangle_quality(fill_triangles);
  s.hausdorff_permille = 1000 * s.distance.hausdorff / c.diagonal;
  s.mean_permille = 1000 * s.distance.mean / c.diagonal;
  const auto creases = ground_truth_creases(c, hole);
  const geometry::SegmentDistance crease =
      geometry::segment_distance(creases, fill_triangles, 0.002 * c.diagonal);
  if (crease.valid) s.crease_permille = 1000 * crease.max / c.diagonal;
  return s;
}

HoleScore score_sharpen(const geometry::Mesh& mesh, const geometry::SharpenResult& result,
                        const HoleCase& c, const CaseHole& hole) {
  geometry::HoleFillReport as_fill = result.fill;
  as_fill.new_faces = result.patch;
  return score_fill(mesh, as_fill, c, hole);
}

}  // namespace touchmend::testing
