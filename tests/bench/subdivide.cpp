// touchmend-subdivide: writes a mesh with every triangle split 1-to-4 at its edge midpoints,
// repeated; the large inputs of the README's command-line measurements (a million faces and
// more from the shared meshes). The surface is the same, only finer, and the holes keep their
// place with 2^k times the boundary edges.

#include <cmath>
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>
#include <OpenMesh/Core/System/omstream.hh>
#include <fmt/format.h>

#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_io.h"
#include "tests/support/mesh_factory.h"

namespace geo = touchmend::geometry;

int main(int argc, char** argv) {
  omerr().disable();
  omout().disable();
  omlog().disable();
  CLI::App app{
      "Split every triangle of a mesh 1-to-4 at its edge midpoints, TIMES times, and write the "
      "result (binary for PLY and STL; the format follows each file's extension)"};
  std::string input, output;
  int times = 1;
  app.add_option("INPUT", input, "Mesh to read (STL, OBJ, OFF, PLY)")->required();
  app.add_option("OUTPUT", output, "Mesh to write (written atomically)")->required();
  app.add_option("--times", times, "Subdivision rounds (each multiplies the faces by 4)")
      ->check(CLI::Range(1, 6));
  CLI11_PARSE(app, argc, argv);

  const geo::ReadResult read = geo::read_mesh_file(input);
  if (!read.ok) {
    fmt::print(stderr, "error: {}\n", read.error);
    return 1;
  }
  // The readers refuse more than 100 million elements; so does this (an in-memory soup of that
  // size is several GB, and nothing could read the result back).
  constexpr double kMaxFaces = 1e8;
  const double faces = static_cast<double>(read.soup.triangles.size()) * std::pow(4.0, times);
  if (faces > kMaxFaces) {
    fmt::print(stderr, "error: {} faces after {} rounds: more than the readers' limit of {:.0f}\n",
               faces, times, kMaxFaces);
    return 1;
  }
  geo::MeshSoup soup = read.soup;
  for (int k = 0; k < times; ++k) soup = touchmend::testing::subdivide_midpoint(soup);
  const geo::BuildResult built = geo::build_mesh(soup);
  geo::WriteOptions options;
  options.binary = true;
  const geo::WriteResult written = geo::write_mesh_file(built.mesh, output, options);
  if (!written.ok) {
    fmt::print(stderr, "error: {}\n", written.error);
    return 1;
  }
  fmt::print("wrote {} ({} vertices, {} faces)\n", output, written.vertices_written,
             written.faces_written);
  return 0;
}
