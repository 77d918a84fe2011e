#include "server/geometry/mesh_io.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>

#include "server/geometry/mesh_build.h"

namespace touchmend::geometry {
namespace {

namespace fs = std::filesystem;

Mesh tricky_mesh() {
  Mesh m;
  // Coordinates that float or 6 significant digits cannot hold.
  const auto a = m.add_vertex({0.12345678901234567, 1e-300, -3.0000000000000004});
  const auto b = m.add_vertex({1.0 / 3.0, 2.0 / 3.0, 1e17 + 8});
  const auto c = m.add_vertex({-0.1, 0.7071067811865476, 5e-324});
  const auto d = m.add_vertex({9.999999999999998, -2.5, 0.3});
  m.add_face(a, b, c);
  m.add_face(a, c, d);
  return m;
}

class TempDir : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("touchmend_io_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  void write(const std::string& name, const std::string& bytes) const {
    std::ofstream(path(name), std::ios::binary) << bytes;
  }
  fs::path dir_;
};

using MeshIo = TempDir;

TEST_F(MeshIo, RoundTripKeepsExactDoublesInEveryLosslessFormat) {
  const Mesh m = tricky_mesh();
  for (const auto& [name, binary] : std::vector<std::pair<std::string, bool>>{{"a.off", false},
                                                                              {"a.obj", false},
                                                                              {"a.ply", false},
                                                                              {"b.ply", true},
                                                                              {"a.stl", false}}) {
    const WriteResult w = write_mesh_file(m, path(name), {.binary = binary});
    ASSERT_TRUE(w.ok) << name << ": " << w.error;
    const ReadResult r = read_mesh_file(path(name));
    ASSERT_TRUE(r.ok) << name << ": " << r.error;
    ASSERT_EQ(r.soup.points.size(), 4u) << name;
    ASSERT_EQ(r.soup.triangles.size(), 2u) << name;
    for (int i = 0; i < 4; ++i)
      EXPECT_EQ(r.soup.points[i], m.point(VertexHandle(i))) << name << " vertex " << i;
  }
}

TEST_F(MeshIo, BinaryStlWarnsAboutFloatRoundingAndWeldsCorners) {
  const Mesh m = tricky_mesh();
  const WriteResult w = write_mesh_file(m, path("a.stl"), {.binary = true});
  ASSERT_TRUE(w.ok);
  EXPECT_FALSE(w.warnings.empty());
  const ReadResult r = read_mesh_file(path("a.stl"));
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_TRUE(r.report.binary);
  EXPECT_EQ(r.soup.points.size(), 4u);  // 6 corners welded into 4 vertices
  EXPECT_EQ(r.report.stl_corners_welded, 2u);
  const BuildResult b = build_mesh(r.soup);
  EXPECT_EQ(b.mesh.n_faces(), 2u);
  EXPECT_TRUE(b.report.refused_faces.empty());
}

TEST_F(MeshIo, AsciiStlWithoutWeldingKeepsCorners) {
  write("w.stl",
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 "
        "0\nendloop\nendfacet\n"
        "facet normal 0 0 1\nouter loop\nvertex 1 0 0\nvertex 1 1 0\nvertex 0 1 "
        "0\nendloop\nendfacet\nendsolid t\n");
  ReadOptions o;
  EXPECT_EQ(read_mesh_file(path("w.stl"), o).soup.points.size(), 4u);
  o.weld_stl_vertices = false;
  EXPECT_EQ(read_mesh_file(path("w.stl"), o).soup.points.size(), 6u);
}

TEST_F(MeshIo, PolygonsAreFanTriangulatedAndCounted) {
  write("q.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1 4/1\n");
  const ReadResult r = read_mesh_file(path("q.obj"));
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.soup.triangles.size(), 2u);
  EXPECT_EQ(r.report.polygons_triangulated, 1u);
  write("neg.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf -3 -2 -1\n");
  const ReadResult n = read_mesh_file(path("neg.obj"));
  ASSERT_TRUE(n.ok) << n.error;
  EXPECT_EQ(n.soup.triangles[0], (Triangle{0, 1, 2}));
}

struct BadInput {
  std::string name;
  std::string bytes;
  std::string expected;  // part of the error message
};

TEST_F(MeshIo, BadInputGivesAClearErrorNamingTheProblem) {
  std::string short_binary(84, '\0');
  const std::uint32_t claimed = 10;  // room for 0 triangles
  std::memcpy(short_binary.data() + 80, &claimed, 4);
  const std::vector<BadInput> cases = {
      {"empty.off", "", "empty"},
      {"empty.stl", "", "empty"},
      {"empty.obj", "", "empty"},
      {"empty.ply", "", "empty"},
      {"badmagic.off", "HELLO\n", "expected the keyword 'OFF'"},
      {"trunc.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n", "truncated"},
      {"huge.off", "OFF\n900000000 1 0\n0 0 0\n", "limit"},
      {"big.off", "OFF\n5000 1 0\n0 0 0\n", "more than"},
      {"nan.off", "OFF\n3 1 0\nnan 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "non-finite"},
      {"inf.obj", "v inf 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "non-finite"},
      {"range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "references vertex 7"},
      {"range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "references vertex 9"},
      {"word.obj", "v 0 zero 0\n", "invalid coordinate"},
      {"wrongcount.stl", short_binary, "declares 10 triangles"},
      {"tiny.stl", "xyz", "too short"},
      {"nanascii.stl",
       "solid x\nfacet normal 0 0 1\nouter loop\nvertex nan 0 0\nvertex 1 0 0\nvertex 0 1 "
       "0\nendloop\nendfacet\nendsolid\n",
       "non-finite"},
      {"cut.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n",
       "truncated"},
      {"noheader.ply", "ply\nformat ascii 1.0\nelement vertex 3\n", "end_header"},
      {"trunc.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty "
       "float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n",
       "truncated"},
      {"binply.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 1000\nproperty double x\nproperty "
       "double y\n"
       "property double z\nend_header\n\x01\x02",
       "truncated"},
  };
  for (const BadInput& c : cases) {
    write(c.name, c.bytes);
    const ReadResult r = read_mesh_file(path(c.name));
    EXPECT_FALSE(r.ok) << c.name;
    EXPECT_NE(r.error.find(c.expected), std::string::npos) << c.name << ": " << r.error;
    EXPECT_NE(r.error.find(c.name), std::string::npos) << "the message names the file: " << r.error;
  }
}

TEST_F(MeshIo, MissingFileAndUnknownExtension) {
  EXPECT_NE(read_mesh_file(path("nope.off")).error.find("no such file"), std::string::npos);
  write("mesh.xyz", "OFF\n");
  EXPECT_NE(read_mesh_file(path("mesh.xyz")).error.find("unknown mesh file extension"),
            std::string::npos);
  EXPECT_FALSE(read_mesh_file(dir_.string() + "/").ok);
}

TEST_F(MeshIo, FailedWriteLeavesTheExistingFileUntouched) {
  write("keep.off", "OFF\n0 0 0\n");
  const Mesh m = tricky_mesh();
  // Unknown extension: nothing is written.
  EXPECT_FALSE(write_mesh_file(m, path("keep.xyz")).ok);
  // A directory that does not exist: clear error, no temporary left behind.
  const WriteResult w = write_mesh_file(m, path("missing/dir/out.off"));
  EXPECT_FALSE(w.ok);
  EXPECT_NE(w.error.find("cannot create a temporary file"), std::string::npos) << w.error;
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_)) ++files;
  EXPECT_EQ(files, 1u);
  std::ifstream in(path("keep.off"));
  std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(content, "OFF\n0 0 0\n");
}

TEST_F(MeshIo, WriteSkipsDeletedElementsAndKeepsVertexOrder) {
  Mesh m = tricky_mesh();
  const auto extra = m.add_vertex({5, 5, 5});
  const auto f = m.add_face(VertexHandle(0), VertexHandle(3), extra);
  ASSERT_TRUE(f.is_valid());
  m.delete_face(f, true);
  ASSERT_TRUE(write_mesh_file(m, path("d.off")).ok);
  const ReadResult r = read_mesh_file(path("d.off"));
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.soup.points.size(), 4u);
  EXPECT_EQ(r.soup.triangles.size(), 2u);
  EXPECT_EQ(r.soup.points[1], m.point(VertexHandle(1)));
}

}  // namespace
}  // namespace touchmend::geometry

namespace touchmend::geometry {
namespace {

// Every reader on garbage and on every truncation of a valid file: an answer, never a crash
// (the sanitizer build runs this too).
TEST(MeshIoRobustness, RandomBytesAndTruncationsNeverCrash) {
  Mesh m;
  const auto a = m.add_vertex({0, 0, 0}), b = m.add_vertex({1, 0, 0}), c = m.add_vertex({0, 1, 0}),
             d = m.add_vertex({1, 1, 1});
  m.add_face(a, b, c);
  m.add_face(b, d, c);
  std::mt19937 rng(12345);
  for (const MeshFormat format :
       {MeshFormat::Off, MeshFormat::Obj, MeshFormat::Ply, MeshFormat::Stl}) {
    for (const bool binary : {false, true}) {
      std::string bytes;
      ASSERT_TRUE(serialize_mesh(m, format, {.binary = binary}, bytes).ok);
      for (std::size_t cut = 0; cut < bytes.size(); ++cut) {
        const ReadResult r = parse_mesh(std::string_view(bytes).substr(0, cut), format);
        EXPECT_TRUE(r.ok || !r.error.empty());
      }
      for (int trial = 0; trial < 200; ++trial) {  // flip random bytes
        std::string noisy = bytes;
        for (int k = 0; k < 3; ++k) noisy[rng() % noisy.size()] = static_cast<char>(rng());
        const ReadResult r = parse_mesh(noisy, format);
        EXPECT_TRUE(r.ok || !r.error.empty());
        for (const auto& t : r.soup.triangles)
          for (const auto v : t) ASSERT_LT(v, r.soup.points.size());
        for (const auto& p : r.soup.points)
          ASSERT_TRUE(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]));
      }
    }
    for (int trial = 0; trial < 200; ++trial) {
      std::string garbage(rng() % 300, '\0');
      for (char& ch : garbage) ch = static_cast<char>(rng());
      const ReadResult r = parse_mesh(garbage, format);
      EXPECT_TRUE(r.ok || !r.error.empty());
    }
  }
}

}  // namespace
}  // namespace touchmend::geometry
