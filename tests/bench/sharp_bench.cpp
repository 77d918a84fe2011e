// touchmend-sharp-bench: on the *_sharp cases of ../shared/data/cases, every hole filled by the
// plain auto fill and by the sharp-edge-retaining variants, scored against the ground truth:
// Hausdorff and mean distance of the patch, and the crease distance (ground-truth sharp edges
// to the patch, ALGORITHMS.md §11.1), all in per mille of the bounding-box diagonal.

#include <algorithm>
#include <chrono>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <OpenMesh/Core/System/omstream.hh>
#include <fmt/format.h>

#include "server/geometry/hole_filling.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/sharpen.h"
#include "tests/support/cases.h"

namespace tmd = touchmend;
namespace geo = touchmend::geometry;

namespace {

struct Variant {
  std::string name;
  geo::FillOptions options;
};

//! A case's holed mesh, its holes and the crease plan of one of them, as picks are made on it.
struct PlannedHole {
  geo::Mesh mesh;
  std::vector<geo::Hole> holes;
  std::size_t index = 0;
  geo::HoleCreasePlan plan;
  const geo::Hole& hole() const { return holes[index]; }
};

std::optional<PlannedHole> plan_case_hole(const tmd::testing::HoleCase& c,
                                          const tmd::testing::CaseHole& ch, double crease_angle) {
  PlannedHole out;
  out.mesh = geo::build_mesh(c.holed).mesh;
  out.holes = geo::find_holes(out.mesh).holes;
  const auto id = tmd::testing::matching_hole_id(out.holes, ch);
  if (!id) return std::nullopt;
  out.index = *geo::find_hole_by_id(out.holes, *id);
  geo::CreaseOptions co;
  co.crease_angle_deg = crease_angle;
  out.plan = geo::plan_hole_creases(out.mesh, out.hole(), co);
  return out;
}

//! \p run's result and how long it took, in milliseconds.
template <class Run>
std::pair<geo::SharpenResult, double> timed(Run&& run) {
  const auto start = std::chrono::steady_clock::now();
  geo::SharpenResult result = run();
  return {
      std::move(result),
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count()};
}

}  // namespace

int main(int argc, char** argv) {
  omerr().disable();
  omout().disable();
  omlog().disable();
  CLI::App app{"Sharp-edge retaining over the *_sharp cases: plain fill vs --sharp auto"};
  std::vector<std::string> only;
  double crease_angle = 50;
  app.add_option("--cases", only, "Only these cases (default: every case whose name has _sharp)");
  app.add_option("--crease-angle", crease_angle, "Dihedral angle of a crease (degrees)");
  double pick_offset = 0;
  app.add_option("--pick-offset", pick_offset,
                 "Picked points: P1 and P4 this many mean boundary edge lengths beside the crease "
                 "(an unsteady hand)");
  bool verbose = false;
  app.add_flag("--verbose", verbose, "Print each hole's crease crossings and fill warnings");
  CLI11_PARSE(app, argc, argv);

  std::vector<Variant> variants;
  geo::FillOptions plain;
  plain.sharp = geo::SharpMode::Off;
  variants.push_back({"fill --sharp off (auto shape)", plain});
  geo::FillOptions split;
  split.sharp = geo::SharpMode::Auto;
  split.creases.crease_angle_deg = crease_angle;
  variants.push_back({"sharp auto (default): split, regions by auto shape", split});
  split.creases.fair_pieces = false;
  variants.push_back({"sharp auto: split, flat regions", split});
  split.creases.fair_pieces = true;
  variants.push_back({"sharp auto: split, faired regions", split});

  std::vector<tmd::testing::HoleCase> cases;
  for (const std::string& name : tmd::testing::list_cases()) {
    if (only.empty() ? name.find("_sharp") == std::string::npos
                     : std::find(only.begin(), only.end(), name) == only.end())
      continue;
    std::string error;
    if (auto c = tmd::testing::load_case(name, error))
      cases.push_back(std::move(*c));
    else
      fmt::print(stderr, "skip {}: {}\n", name, error);
  }
  fmt::print("| case | hole | variant | method | creases | H ‰ | mean ‰ | crease H ‰ | ms |\n");
  fmt::print("|---|---|---|---|---|---|---|---|---|\n");
  std::vector<double> worst_crease(variants.size(), 0);
  for (const tmd::testing::HoleCase& loaded : cases) {
    const std::string& name = loaded.name;
    const tmd::testing::HoleCase* c = &loaded;
    for (std::size_t vi = 0; vi < variants.size(); ++vi) {
      geo::Mesh mesh = geo::build_mesh(c->holed).mesh;
      const auto holes = geo::find_holes(mesh).holes;
      const geo::FillReport report = geo::fill_holes(mesh, {}, variants[vi].options);
      for (const auto& ch : c->holes) {
        const auto id = tmd::testing::matching_hole_id(holes, ch);
        const geo::HoleFillReport* r = nullptr;
        for (const auto& h : report.holes)
          if (id && h.hole_id == *id) r = &h;
        if (r == nullptr || !r->filled) {
          fmt::print("| {} | {} | {} | OPEN | {} | - | - | - | - |\n", name, ch.id,
                     variants[vi].name, r ? r->reason : "not found");
          continue;
        }
        const auto score = tmd::testing::score_fill(mesh, *r, *c, ch);
        if (verbose) {
          for (const auto& w : r->warnings) fmt::print("    warning: {}\n", w);
          if (vi == 0) {
            geo::Mesh fresh = geo::build_mesh(c->holed).mesh;
            const auto found = geo::find_holes(fresh).holes;
            for (const auto& h : found)
              if (h.id == *id) {
                geo::CreaseOptions co;
                co.crease_angle_deg = crease_angle;
                const auto plan = geo::plan_hole_creases(fresh, h, co);
                for (const auto& x : plan.crossings)
                  fmt::print(
                      "    crossing at loop {} ({:.3f} {:.3f} {:.3f}) inward ({:.2f} {:.2f} "
                      "{:.2f}) dihedral {:.0f} {} traced {}\n",
                      x.loop_index, x.position[0], x.position[1], x.position[2], x.inward[0],
                      x.inward[1], x.inward[2], x.dihedral_deg, x.convex ? "convex" : "concave",
                      x.traced_edges);
                for (const auto& e : tmd::testing::ground_truth_creases(*c, ch))
                  fmt::print("    gt crease ({:.3f} {:.3f} {:.3f}) - ({:.3f} {:.3f} {:.3f})\n",
                             e[0][0], e[0][1], e[0][2], e[1][0], e[1][1], e[1][2]);
              }
          }
        }
        worst_crease[vi] = std::max(worst_crease[vi], score.crease_permille);
        fmt::print("| {} | {} | {} | {}/{} | {} | {:.2f} | {:.2f} | {:.2f} | {:.2f} |\n", name,
                   ch.id, variants[vi].name, geo::to_string(r->method), geo::to_string(r->shape),
                   r->creases.empty() ? "-" : r->creases, score.hausdorff_permille,
                   score.mean_permille, score.crease_permille, 1e3 * r->seconds);
      }
    }
  }
  // Picked points: for the first crease pair the detection finds, P2 and P3 where the creases
  // meet the rim and P1, P4 on the creases themselves, the fit length back from it (where an
  // operator feeling along the crease would pick), through both sharpen variants and, for each,
  // the thesis' chord tangents and the crease's own.
  fmt::print(
      "\n| case | hole | picked-points variant | tangents | result | H ‰ | mean ‰ | "
      "crease H ‰ | ms |\n");
  fmt::print("|---|---|---|---|---|---|---|---|---|\n");
  for (const tmd::testing::HoleCase& loaded : cases) {
    const std::string& name = loaded.name;
    const tmd::testing::HoleCase* c = &loaded;
    for (const auto& ch : c->holes) {
      struct PickedVariant {
        geo::SharpenMethod method;
        geo::PushFinish finish;
      };
      for (const PickedVariant variant :
           {PickedVariant{geo::SharpenMethod::PushDown, geo::PushFinish::Fair},
            PickedVariant{geo::SharpenMethod::PushDown, geo::PushFinish::Smooth},
            PickedVariant{geo::SharpenMethod::PushDown, geo::PushFinish::None},
            PickedVariant{geo::SharpenMethod::Split, geo::PushFinish::None}}) {
        for (const geo::PickTangents tangents :
             {geo::PickTangents::Chord, geo::PickTangents::Crease}) {
          const geo::SharpenMethod method = variant.method;
          const std::string variant_name =
              method == geo::SharpenMethod::Split
                  ? std::string("split")
                  : fmt::format("push-down, finish {}", geo::to_string(variant.finish));
          auto planned = plan_case_hole(*c, ch, crease_angle);
          if (!planned) continue;
          geo::Mesh& mesh = planned->mesh;
          const geo::Hole& hole = planned->hole();
          const geo::HoleCreasePlan& plan = planned->plan;
          const geo::CreaseCurve* pair = nullptr;
          for (const auto& curve : plan.curves)
            if (curve.to && pair == nullptr) pair = &curve;
          if (pair == nullptr) {
            fmt::print("| {} | {} | {} | {} | no crease pair to pick | - | - | - | - |\n", name,
                       ch.id, variant_name, geo::to_string(tangents));
            continue;
          }
          const geo::CreaseCrossing& from = plan.crossings[pair->from];
          const geo::CreaseCrossing& to = plan.crossings[*pair->to];
          geo::HermitePoints picks{from.on_crease, from.position, to.position, to.on_crease};
          // An unsteady hand: P1 and P4 beside the crease, across it in the hole's plane.
          const double shift = pick_offset * hole.mean_edge_length;
          picks.p1 += shift * OpenMesh::cross(from.inward, hole.normal).normalize_cond();
          picks.p4 += shift * OpenMesh::cross(to.inward, hole.normal).normalize_cond();
          geo::SharpenOptions so;
          so.method = method;
          so.finish = variant.finish;
          so.tangents = tangents;
          const auto [r, ms] = timed([&] { return geo::sharpen_hole(mesh, hole, picks, so); });
          const std::string tangent_name =
              tangents == geo::PickTangents::Chord
                  ? std::string("chord")
                  : fmt::format("crease ({} of 2 ends{})",
                                int{r.crease_tangent_start} + int{r.crease_tangent_end},
                                r.arcs > 0 ? ", an arc" : "");
          if (!r.ok) {
            fmt::print("| {} | {} | {} | {} | FAILED: {} | - | - | - | - |\n", name, ch.id,
                       variant_name, tangent_name, r.failure);
            continue;
          }
          const auto score = tmd::testing::score_sharpen(mesh, r, *c, ch);
          fmt::print("| {} | {} | {} | {} | {} | {:.2f} | {:.2f} | {:.2f} | {:.2f} |\n", name,
                     ch.id, variant_name, tangent_name,
                     method == geo::SharpenMethod::Split
                         ? std::string("filled on both sides of the curve")
                         : geo::push_down_summary(r, variant.finish),
                     score.hausdorff_permille, score.mean_permille, score.crease_permille, ms);
        }
      }
      // Where the detection draws several curves or extends creases to a corner, every crease it
      // uses picked (on each crease and where it meets the rim) for sharpen_creases: its pairs as
      // P1..P4, the corner's creases as far and rim points.
      for (const geo::PickTangents tangents :
           {geo::PickTangents::Chord, geo::PickTangents::Crease}) {
        auto planned = plan_case_hole(*c, ch, crease_angle);
        if (!planned) continue;
        geo::Mesh& mesh = planned->mesh;
        const geo::Hole& hole = planned->hole();
        const geo::HoleCreasePlan& plan = planned->plan;
        if (plan.corners.empty() && plan.curves.size() < 2) continue;
        geo::PickedCreases picked;
        const double shift = pick_offset * hole.mean_edge_length;
        const auto on_crease = [&](const geo::CreaseCrossing& x) {
          return x.on_crease + shift * OpenMesh::cross(x.inward, hole.normal).normalize_cond();
        };
        for (const auto& curve : plan.curves) {
          const geo::CreaseCrossing& from = plan.crossings[curve.from];
          if (curve.to) {
            const geo::CreaseCrossing& to = plan.crossings[*curve.to];
            picked.curves.push_back({on_crease(from), from.position, to.position, on_crease(to)});
          } else {
            picked.corner.push_back({on_crease(from), from.position});
          }
        }
        geo::SharpenOptions so;
        so.tangents = tangents;
        const auto [r, ms] = timed([&] { return geo::sharpen_creases(mesh, hole, picked, so); });
        const std::string tangent_name =
            tangents == geo::PickTangents::Chord
                ? std::string("chord")
                : fmt::format("crease ({} of {}{})", r.crease_tangents_taken,
                              2 * picked.curves.size() + picked.corner.size(),
                              r.arcs > 0 ? fmt::format(", {} arcs", r.arcs) : std::string());
        if (!r.ok) {
          fmt::print("| {} | {} | every crease (split) | {} | FAILED: {} | - | - | - | - |\n", name,
                     ch.id, tangent_name, r.failure);
          continue;
        }
        const auto score = tmd::testing::score_sharpen(mesh, r, *c, ch);
        fmt::print(
            "| {} | {} | every crease (split) | {} | {} curve(s), {} creases to the corner | "
            "{:.2f} | {:.2f} | {:.2f} | {:.2f} |\n",
            name, ch.id, tangent_name, picked.curves.size(), picked.corner.size(),
            score.hausdorff_permille, score.mean_permille, score.crease_permille, ms);
      }
    }
  }

  fmt::print("\nworst crease distance per variant (‰ of the diagonal):\n");
  for (std::size_t vi = 0; vi < variants.size(); ++vi)
    fmt::print("  {}: {:.2f}\n", variants[vi].name, worst_crease[vi]);
  return 0;
}
