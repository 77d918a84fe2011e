#pragma once

//! \file cases.h
//! \brief Loader for the hole cases in ../shared/data/cases (holed mesh, original mesh, per-hole
//! ground truth) and per-hole fill scoring with the shared metrics module.

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "server/geometry/hole_filling.h"
#include "server/geometry/intersection.h"
#include "server/geometry/mesh.h"
#include "server/geometry/metrics.h"
#include "server/geometry/sharpen.h"

namespace touchmend::testing {

struct CaseHole {
  int id = 0;
  std::string kind;
  std::vector<std::uint32_t> original_faces;  //!< removed faces, ids of the original mesh
  std::vector<std::uint32_t> loop_holed;      //!< boundary loop, vertex ids of holed.off
};

struct HoleCase {
  std::string name;
  std::string directory;
  std::string holed_path;
  std::string original_path;
  geometry::MeshSoup holed;
  geometry::MeshSoup original;
  std::vector<CaseHole> holes;  //!< empty for *_real cases (no ground truth)
  double diagonal = 0;          //!< bounding-box diagonal of the original mesh
};

//! The shared data directory (TOUCHMEND_SHARED_DATA, else the path configured at build time).
std::string shared_data_dir();

//! Names of the case folders, sorted.
std::vector<std::string> list_cases();

//! Loads a case; for *_real cases the holed mesh is the original itself.
std::optional<HoleCase> load_case(const std::string& name, std::string& error);

//! Ground-truth triangles of one hole.
std::vector<geometry::TrianglePoints> ground_truth(const HoleCase& c, const CaseHole& hole);

//! Sharp edges of the ground truth: edges of the original mesh with both faces removed for this
//! hole whose faces meet at more than \p sharp_deg (the referee's definition, 60°).
std::vector<std::array<geometry::Vec3, 2>> ground_truth_creases(const HoleCase& c,
                                                                const CaseHole& hole,
                                                                double sharp_deg = 60.0);

//! The id (find_holes numbering) of the mesh hole whose loop has the case hole's vertex set.
std::optional<std::uint32_t> matching_hole_id(const std::vector<geometry::Hole>& holes,
                                              const CaseHole& hole);

struct HoleScore {
  geometry::SurfaceDistance distance;  //!< fill vs ground truth, absolute units
  geometry::TriangleQuality quality;
  double hausdorff_permille = 0;  //!< / diagonal x 1000
  double mean_permille = 0;
  double crease_permille = -1;  //!< ground-truth creases to the fill, max; -1: no crease
};

//! The anchors' numbers for one hole from BASELINE.md's per-hole table (per mille of the
//! diagonal; -1 when absent).
struct AnchorNumbers {
  double best_mean = -1;  //!< best mean distance over all anchors
  double cgal_fair_mean = -1;
  double cgal_fair_hausdorff = -1;
  double cgal_fair_ms = -1;
};

//! (case, hole id as printed) -> anchors, from ../shared/data/cases/BASELINE.md.
std::map<std::pair<std::string, std::string>, AnchorNumbers> read_baseline();

HoleScore score_fill(const geometry::Mesh& mesh, const geometry::HoleFillReport& fill,
                     const HoleCase& c, const CaseHole& hole);

//! score_fill of a sharpen result's patch (the faces of the hole at the end).
HoleScore score_sharpen(const geometry::Mesh& mesh, const geometry::SharpenResult& result,
                        const HoleCase& c, const CaseHole& hole);

}  // namespace touchmend::testing
