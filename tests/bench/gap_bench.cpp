// touchmend-gap-bench: automatic gap bridging on the shared meshes. Each mesh gets a band of
// faces cut out across its middle (a slab through the bounding-box centre, 1.2 mean edge
// lengths wide, normal to the longest axis): two registered surfaces with a gap between them,
// the ground truth being the faces removed. Prints, per mesh, the gaps found, the time of
// detection and of bridging (median of the repetitions), the holes left and whether the result
// is manifold and free of self-intersections among the new faces.

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <OpenMesh/Core/System/omstream.hh>
#include <fmt/format.h>

#include "server/geometry/gap_bridging.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_intersections.h"
#include "server/geometry/mesh_io.h"
#include "server/geometry/metrics.h"
#include "tests/support/cases.h"
#include "tests/support/mesh_factory.h"

namespace geo = touchmend::geometry;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  omerr().disable();
  omout().disable();
  omlog().disable();
  CLI::App app{"Automatic gap bridging over the shared meshes with a band cut out"};
  int repeat = 5;
  double band = 1.2;
  app.add_option("--repeat", repeat, "Timing repetitions")->check(CLI::Range(1, 100));
  app.add_option("--band", band, "Band width in mean edge lengths")->check(CLI::Range(0.5, 10.0));
  CLI11_PARSE(app, argc, argv);
  const std::string dir = touchmend::testing::shared_data_dir() + "/meshes";
  fmt::print(
      "| mesh | faces | band faces | loops | gaps | detect ms | bridge ms | faces added | "
      "holes left | manifold | new self-int |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const std::string name : {"spot.obj", "fandisk.obj", "rocker-arm.obj", "couplingdown.off",
                                 "sphere966.off", "hand.off", "stanford-bunny.obj"}) {
    const geo::ReadResult read = geo::read_mesh_file(dir + "/" + name);
    if (!read.ok) {
      fmt::print(stderr, "skip {}: {}\n", name, read.error);
      continue;
    }
    // The band (what a mesh builder keeps of the rest, so the input is a clean mesh with two
    // boundaries facing each other).
    const geo::MeshSoup banded = touchmend::testing::cut_band(read.soup, band);
    const geo::MeshSoup cut = geo::to_soup(geo::build_mesh(banded).mesh);
    std::vector<double> detect_ms, bridge_ms;
    std::size_t gaps_found = 0, loops = 0, added = 0, holes_left = 0, self_int = 0;
    bool manifold = false;
    for (int r = 0; r < repeat; ++r) {
      geo::Mesh mesh = geo::build_mesh(cut).mesh;
      const auto t0 = std::chrono::steady_clock::now();
      const auto holes = geo::find_holes(mesh).holes;
      const auto gaps = geo::find_gaps(mesh, holes);
      const auto t1 = std::chrono::steady_clock::now();
      std::vector<geo::FaceHandle> new_faces;
      if (r + 1 == repeat && std::getenv("GAP_BENCH_VERBOSE"))
        fmt::print(stderr, "{}: cut mesh clean {}\n", name, geo::validate_mesh(mesh).is_clean());
      std::vector<const geo::Gap*> all;
      for (const auto& g : gaps) all.push_back(&g);
      const geo::DetectedGapsBridge bridged = geo::bridge_detected_gaps(mesh, all);
      for (std::size_t k = 0; k < gaps.size(); ++k) {
        const auto& g = gaps[k];
        const auto& b = bridged.gaps[k];
        if (r + 1 == repeat && std::getenv("GAP_BENCH_VERBOSE"))
          fmt::print(stderr, "  gap {} ({}+{} verts, cyclic {}, width {:.3g}/{:.3g}): {} {}\n",
                     g.id, g.run_a.size(), g.run_b.size(), g.cyclic, g.mean_width, g.max_width,
                     b.zip.ok ? "ok" : "FAILED", b.zip.reason);
        new_faces.insert(new_faces.end(), b.zip.faces.begin(), b.zip.faces.end());
        for (const auto& f : b.end_fills)
          new_faces.insert(new_faces.end(), f.new_faces.begin(), f.new_faces.end());
      }
      for (const auto& f : bridged.leftover_fills) {
        if (r + 1 == repeat && std::getenv("GAP_BENCH_VERBOSE"))
          fmt::print(stderr, "  leftover hole {}: {}\n", f.hole_id,
                     f.filled ? fmt::format("filled, {} faces", f.faces_added) : f.reason);
        new_faces.insert(new_faces.end(), f.new_faces.begin(), f.new_faces.end());
      }
      const auto t2 = std::chrono::steady_clock::now();
      detect_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
      bridge_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
      if (r + 1 == repeat) {
        loops = holes.size();
        gaps_found = gaps.size();
        std::erase_if(new_faces, [&](geo::FaceHandle f) { return mesh.status(f).deleted(); });
        added = new_faces.size();
        self_int = geo::find_face_intersections(mesh, new_faces).size();
        mesh.garbage_collection();
        holes_left = geo::find_holes(mesh).holes.size();
        manifold = geo::validate_mesh(mesh).is_clean();
      }
    }
    fmt::print("| {} | {} | {} | {} | {} | {:.2f} | {:.2f} | {} | {} | {} | {} |\n", name,
               read.soup.triangles.size(), read.soup.triangles.size() - cut.triangles.size(), loops,
               gaps_found, median(detect_ms), median(bridge_ms), added, holes_left,
               manifold ? "yes" : "NO", self_int);
  }
  return 0;
}
