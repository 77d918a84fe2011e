// Runs the real `touchmend` binary: exit codes, messages, outputs, atomic writes.

#include <filesystem>
#include <fstream>
#include <sstream>
#include <sys/wait.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "client/cli/commands.h"
#include "server/geometry/holes.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_io.h"
#include "tests/support/cases.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::cli {
namespace {

namespace fs = std::filesystem;

struct CliRun {
  int code = -1;
  std::string out, err;
};

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("touchmend_cli_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    spot_ = testing::shared_data_dir() + "/cases/spot_sml/holed.off";
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  void write(const std::string& name, const std::string& bytes) const {
    std::ofstream(path(name), std::ios::binary) << bytes;
  }
  static std::string slurp(const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }

  CliRun run(const std::string& args) const {
    const std::string out = path("stdout.txt"), err = path("stderr.txt");
    const std::string cmd =
        std::string(TOUCHMEND_CLI_PATH) + " " + args + " >" + out + " 2>" + err + " </dev/null";
    const int status = std::system(cmd.c_str());
    CliRun r;
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = slurp(out);
    r.err = slurp(err);
    return r;
  }

  fs::path dir_;
  std::string spot_;
};

//! Loads an output file and returns (clean, boundary edges).
std::pair<bool, std::size_t> closedness(const std::string& file) {
  const auto read = geometry::read_mesh_file(file);
  if (!read.ok) return {false, 0};
  const auto built = geometry::build_mesh(read.soup);
  return {built.report.is_clean(), built.report.boundary_edges};
}

TEST_F(Cli, FillSharpAutoRetainsTheCreases) {
  const std::string fandisk = testing::shared_data_dir() + "/cases/fandisk_sharp/holed.off";
  const CliRun r = run("fill " + fandisk + " -o " + path("out.off") + " --all --sharp auto --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["filled"], 3);
  for (const auto& h : j["holes"]) {
    EXPECT_EQ(h["method"], "crease-split") << h.dump();
    EXPECT_GE(h["crease_curves"].get<int>(), 1);
  }
  const auto [clean, boundary] = closedness(path("out.off"));
  EXPECT_TRUE(clean);
  EXPECT_EQ(boundary, 0u);
  EXPECT_EQ(run("fill " + fandisk + " -o " + path("o.off") + " --all --sharp sometimes").code,
            kExitUsage);
  EXPECT_EQ(run("fill " + fandisk + " -o " + path("o.off") + " --all --crease-angle 0").code,
            kExitUsage);
}

// hand_sml's hole 51 straddles the rim of the flat wrist cap: its faired patch balloons, the
// JSON says how far and why the hole was filled flat.
TEST_F(Cli, FillJsonTellsHowFarAFairedTryBallooned) {
  const std::string hand = testing::shared_data_dir() + "/cases/hand_sml/holed.off";
  const CliRun r = run("fill " + hand + " -o " + path("hand.off") + " --hole 51 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["holes"].size(), 1u);
  const auto& h = j["holes"][0];
  EXPECT_EQ(h["shape"], "flat") << h.dump();
  EXPECT_GT(h["fair_bulge_hole_radii"].get<double>(), 0.5) << h.dump();
  EXPECT_NE(h["warnings"].dump().find("balloon"), std::string::npos) << h.dump();
}

TEST_F(Cli, SharpenRetainsAnEdgeFromFourPoints) {
  const std::string fandisk = testing::shared_data_dir() + "/cases/fandisk_sharp/holed.off";
  // Hole 1444 lies on the straight crease x = 4.828, z = 0 (along y).
  const std::string points = "'4.828,15.2,0;4.828,14.795,0;4.828,14.203,0;4.828,13.8,0'";
  for (const std::string method : {"split", "push-down"}) {
    const CliRun r = run("sharpen " + fandisk + " -o " + path(method + ".off") +
                         " --hole 1444 --points " + points + " --method " + method + " --json");
    ASSERT_EQ(r.code, 0) << method << ": " << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["method"], method);
    EXPECT_TRUE(j["fill"]["filled"].get<bool>());
    // P1 and P4 lie on the crease: its tangents are taken at both ends (the default).
    EXPECT_EQ(j["tangents"], "crease");
    EXPECT_TRUE(j["crease_tangents"]["start"].get<bool>());
    EXPECT_TRUE(j["crease_tangents"]["end"].get<bool>());
    if (method == "push-down") {
      EXPECT_GT(j["pushed"].get<int>(), 0);
      EXPECT_EQ(j["finish"], "fair");  // the default finish
      EXPECT_EQ(j["finish_undone"], "");
    }
    const auto read = geometry::read_mesh_file(path(method + ".off"));
    ASSERT_TRUE(read.ok);
    const auto built = geometry::build_mesh(read.soup);
    EXPECT_TRUE(built.report.is_clean());
    EXPECT_EQ(geometry::find_holes(built.mesh).holes.size(), 2u);  // the other two stay open
  }
  const std::string out = " -o " + path("x.off");
  EXPECT_EQ(run("sharpen " + fandisk + out + " --hole 1444 --points '1,2,3;4,5,6'").code,
            kExitUsage);
  EXPECT_EQ(run("sharpen " + fandisk + out + " --hole 7 --points " + points).code, kExitBadInput);
  EXPECT_EQ(
      run("sharpen " + fandisk + out + " --hole 1444 --points " + points + " --depth 0.1").code,
      kExitUsage);  // --depth needs push-down
  EXPECT_EQ(
      run("sharpen " + fandisk + out + " --hole 1444 --points " + points + " --finish none").code,
      kExitUsage);  // so does --finish
  EXPECT_EQ(run("sharpen " + fandisk + out + " --hole 1444 --points " + points +
                " --method push-down --finish round")
                .code,
            kExitUsage);
  EXPECT_EQ(
      run("sharpen " + fandisk + out + " --hole 1444 --points " + points + " --tangents straight")
          .code,
      kExitUsage);
  {
    const CliRun chord = run("sharpen " + fandisk + " -o " + path("chord.off") +
                             " --hole 1444 --points " + points + " --tangents chord --json");
    ASSERT_EQ(chord.code, 0) << chord.err;
    const auto j = nlohmann::json::parse(chord.out);
    EXPECT_EQ(j["tangents"], "chord");
    EXPECT_FALSE(j["crease_tangents"]["start"].get<bool>());
    const CliRun text =
        run("sharpen " + fandisk + " -o " + path("text.off") + " --hole 1444 --points " + points);
    ASSERT_EQ(text.code, 0) << text.err;
    EXPECT_NE(text.out.find("tangents of the crease at both ends"), std::string::npos) << text.out;
  }
  {
    const CliRun smooth =
        run("sharpen " + fandisk + " -o " + path("smooth.off") + " --hole 1444 --points " + points +
            " --method push-down --finish smooth --json");
    ASSERT_EQ(smooth.code, 0) << smooth.err;
    EXPECT_EQ(nlohmann::json::parse(smooth.out)["finish"], "smooth");
  }
  const CliRun far =
      run("sharpen " + fandisk + out + " --hole 1444 --points '0,0,90;0,0,91;0,0,92;0,0,93'");
  EXPECT_EQ(far.code, kExitBadInput);
  EXPECT_NE(far.err.find("not on the surface"), std::string::npos) << far.err;
  EXPECT_FALSE(fs::exists(path("x.off")));
}

// A box corner cut away, retained from picks on its three creases (--corner); a second curve
// through the hole is given by repeating --points. The picks' rules are usage errors.
// couplingdown_sharp's hole 996 takes in most of a bore's rim (a ring turning 290 deg inside the
// hole): picked at both ends where it meets the rim, with P1 and P4 on the crease outside, the
// split follows the arc both creases continue; with chord tangents there is no crease to read
// the bend from, and the Hermite curve is used.
TEST_F(Cli, SharpenFollowsAPickedRingAsAnArc) {
  const std::string coupling = testing::shared_data_dir() + "/cases/couplingdown_sharp/holed.off";
  const std::string ring =
      " --points '0.117316,-0.009553,-0.025157;0.111210,0.017209,-0.025157;"
      "0.117316,-0.009553,-0.025157;0.111210,0.017209,-0.025157'";
  const std::string head =
      "sharpen " + coupling + " -o " + path("ring.off") + " --hole 996 --method split" + ring;
  const CliRun r = run(head + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["fill"]["filled"].get<bool>());
  EXPECT_EQ(j["crease_tangents_taken"], 2);
  EXPECT_EQ(j["arcs"], 1);
  const auto read = geometry::read_mesh_file(path("ring.off"));
  ASSERT_TRUE(read.ok);
  const auto built = geometry::build_mesh(read.soup);
  EXPECT_TRUE(built.report.is_clean());
  EXPECT_EQ(geometry::find_holes(built.mesh).holes.size(), 2u);  // the other two stay open
  const CliRun text = run(head);
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_NE(text.out.find("a circular arc"), std::string::npos) << text.out;
  const CliRun chord = run(head + " --tangents chord --json");
  ASSERT_EQ(chord.code, 0) << chord.err;
  EXPECT_EQ(nlohmann::json::parse(chord.out)["arcs"], 0);
}

TEST_F(Cli, SharpenRetainsACornerFromItsCreases) {
  const geometry::MeshSoup soup = testing::cube_with_hole(8, geometry::Vec3(8, 8, 8), 2.5);
  {
    std::ofstream file(path("corner.off"), std::ios::binary);
    file << testing::to_off(soup);
  }
  const auto holes = geometry::find_holes(geometry::build_mesh(soup).mesh).holes;
  ASSERT_EQ(holes.size(), 1u);
  const std::string head = "sharpen " + path("corner.off") + " -o " + path("corner-out.off") +
                           " --hole " + std::to_string(holes[0].id);
  const std::string corner = " --corner '8,3.5,8;8,5.6,7.95;3.5,8,8;5.6,8.02,8;8,8,3.5;7.9,8,5.6'";
  const CliRun r = run(head + corner + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["corner_creases"], 3);
  EXPECT_EQ(j["crease_tangents_taken"], 3);
  ASSERT_TRUE(j["corner"].is_array()) << j.dump();
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(j["corner"][k].get<double>(), 8.0, 1e-9);
  const auto read = geometry::read_mesh_file(path("corner-out.off"));
  ASSERT_TRUE(read.ok);
  const auto built = geometry::build_mesh(read.soup);
  EXPECT_TRUE(built.report.is_clean());
  EXPECT_TRUE(geometry::find_holes(built.mesh).holes.empty());
  const CliRun text = run(head + corner);
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_NE(text.out.find("3 creases meeting at a corner (8, 8, 8); 3 of 3"), std::string::npos)
      << text.out;

  EXPECT_EQ(run(head).code, kExitUsage);  // nothing picked
  EXPECT_EQ(run(head + " --corner '8,3.5,8;8,5.6,8;3.5,8,8;5.6,8,8'").code, kExitUsage);
  EXPECT_EQ(run(head + corner + " --method push-down").code, kExitUsage);
  const std::string curve = " --points '8,3.5,8;8,5.6,8;5.6,8,8;3.5,8,8'";
  EXPECT_EQ(run(head + curve + curve + " --method push-down").code, kExitUsage);
  // Two curves sharing their rim vertices: refused as bad picks, nothing written.
  const CliRun twice = run(head + curve + curve);
  EXPECT_EQ(twice.code, kExitBadInput);
  EXPECT_NE(twice.err.find("another pick took"), std::string::npos) << twice.err;
}

TEST_F(Cli, GapsAndBridgeCloseABandCutAroundACube) {
  const geometry::MeshSoup band = testing::remove_faces(
      testing::cube(8), [](const geometry::Vec3& c) { return c[0] > 3 && c[0] < 4; });
  ASSERT_TRUE(geometry::write_mesh_file(geometry::build_mesh(band).mesh, path("band.off"), {}).ok);
  const CliRun listed = run("gaps " + path("band.off") + " --json");
  ASSERT_EQ(listed.code, 0) << listed.err;
  const auto j = nlohmann::json::parse(listed.out);
  ASSERT_EQ(j["gaps"].size(), 1u);
  EXPECT_TRUE(j["gaps"][0]["cyclic"].get<bool>());
  EXPECT_NEAR(j["gaps"][0]["mean_width"].get<double>(), 1.0, 1e-9);
  const CliRun text = run("gaps " + path("band.off"));
  EXPECT_NE(text.out.find("all around"), std::string::npos) << text.out;
  const CliRun bridged = run("bridge " + path("band.off") + " -o " + path("closed.ply") + " --all");
  ASSERT_EQ(bridged.code, 0) << bridged.err;
  EXPECT_NE(bridged.out.find("bridged 1 of 1"), std::string::npos) << bridged.out;
  const auto [clean, boundary] = closedness(path("closed.ply"));
  EXPECT_TRUE(clean);
  EXPECT_EQ(boundary, 0u);
  EXPECT_EQ(run("bridge " + path("band.off") + " -o " + path("x.off") + " --gap 3").code,
            kExitBadInput);
  EXPECT_EQ(run("bridge " + path("band.off") + " -o " + path("x.off")).code, kExitUsage);
  EXPECT_EQ(run("gaps " + path("band.off") + " --max-width 0.5").out.find("no gaps"), 0u);
  EXPECT_EQ(run("--server 127.0.0.1:1 --retries 0 gaps " + path("band.off")).code, kExitServer);
}

TEST_F(Cli, HelpAndUsageErrors) {
  EXPECT_EQ(run("--help").code, 0);
  const CliRun help = run("fill --help");
  EXPECT_EQ(help.code, 0);
  EXPECT_NE(help.out.find("--refine-iterations"), std::string::npos);
  EXPECT_EQ(run("").code, kExitUsage);
  EXPECT_EQ(run("frobnicate x.off").code, kExitUsage);
  EXPECT_EQ(run("fill " + spot_).code, kExitUsage);  // no -o
  const CliRun no_mode = run("fill " + spot_ + " -o " + path("o.off"));
  EXPECT_EQ(no_mode.code, kExitUsage);
  EXPECT_NE(no_mode.err.find("--all"), std::string::npos);
  EXPECT_EQ(run("fill " + spot_ + " -o " + path("o.off") + " --all --hole 3").code, kExitUsage);
  EXPECT_EQ(run("fill " + spot_ + " -o " + path("o.off") + " --all --refine-iterations 9").code,
            kExitUsage);
  EXPECT_EQ(run("fill " + spot_ + " -o " + path("o.off") + " --all --shape round").code,
            kExitUsage);
  EXPECT_EQ(run("fill " + spot_ + " -o " + path("o.off") + " --near 1,2").code, kExitUsage);
  EXPECT_EQ(run("fill " + spot_ + " -o " + path("o.off") + " --near 1,nan,2").code, kExitUsage);
  EXPECT_EQ(run("fill " + spot_ + " -o " + path("o.xyz") + " --all").code, kExitUsage);
  EXPECT_FALSE(fs::exists(path("o.off")));
}

TEST_F(Cli, BadInputIsExitCodeOneWithTheProblemNamed) {
  write("empty.off", "");
  write("nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  write("range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n");
  write("mesh.txt", "hello");
  std::string bad_stl(84, '\0');
  bad_stl[80] = 7;  // claims 7 triangles, holds none
  write("short.stl", bad_stl);
  write("nofaces.obj", "v 0 0 0\n");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"info " + path("empty.off"), "empty"},
      {"holes " + path("nan.obj"), "non-finite"},
      {"info " + path("range.off"), "references vertex 5"},
      {"info " + path("mesh.txt"), "unknown mesh file extension"},
      {"info " + path("missing.off"), "no such file"},
      {"info " + path("short.stl"), "declares 7 triangles"},
      {"info " + path("nofaces.obj"), "no faces"},
      {"fill " + path("nan.obj") + " -o " + path("out.off") + " --all", "non-finite"},
  };
  for (const auto& [args, expected] : cases) {
    const CliRun r = run(args);
    EXPECT_EQ(r.code, kExitBadInput) << args;
    EXPECT_NE(r.err.find(expected), std::string::npos) << args << " -> " << r.err;
  }
  EXPECT_FALSE(fs::exists(path("out.off")));
}

TEST_F(Cli, UnknownHoleIdIsBadInputAndWritesNothing) {
  const CliRun r = run("fill " + spot_ + " -o " + path("o.off") + " --hole 999999");
  EXPECT_EQ(r.code, kExitBadInput);
  EXPECT_NE(r.err.find("no hole with id 999999"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("o.off")));
}

TEST_F(Cli, InfoAndHolesReportTheMesh) {
  const CliRun info = run("info " + spot_ + " --json");
  ASSERT_EQ(info.code, 0) << info.err;
  const auto j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["vertices"], 2727);
  EXPECT_EQ(j["faces"], 5364);
  EXPECT_EQ(j["validation"]["boundary_loops"], 3);
  EXPECT_TRUE(j["validation"]["clean"].get<bool>());
  const CliRun holes = run("holes " + spot_ + " --json");
  ASSERT_EQ(holes.code, 0);
  const auto h = nlohmann::json::parse(holes.out);
  ASSERT_EQ(h["holes"].size(), 3u);
  std::size_t edges = 0;
  for (const auto& hole : h["holes"]) edges += hole["boundary_edges"].get<std::size_t>();
  EXPECT_EQ(edges, 92u);
  const CliRun text = run("holes " + spot_);
  EXPECT_EQ(text.code, 0);
  EXPECT_NE(text.out.find("simple"), std::string::npos);
}

TEST_F(Cli, FillAllWritesAClosedMeshAtomically) {
  write("out.off", "previous content");
  const CliRun r = run("fill " + spot_ + " -o " + path("out.off") + " --all --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["filled"], 3);
  EXPECT_EQ(j["left_open"], 0);
  const auto read = geometry::read_mesh_file(path("out.off"));
  ASSERT_TRUE(read.ok) << read.error;
  const auto built = geometry::build_mesh(read.soup);
  EXPECT_TRUE(built.report.is_clean());
  EXPECT_EQ(built.report.boundary_edges, 0u);
  // Existing vertices keep their exact coordinates.
  const auto original = geometry::read_mesh_file(spot_);
  for (std::size_t i = 0; i < original.soup.points.size(); ++i)
    ASSERT_EQ(read.soup.points[i], original.soup.points[i]);
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos)
        << "temporary file left behind";
}

// A hole whose loop passes a vertex twice (an island inside it touches the rim there) is
// listed with its pinch and filled: closed across the pinch first, then as a disk.
TEST_F(Cli, PinchedHoleIsListedWithItsPinchAndFilled) {
  write("pinched.off", testing::to_off(testing::cut_leaving_an_island(testing::uv_sphere(1, 48, 24),
                                                                      {0, 0.6, 0.8}, 0.45)));
  const CliRun text = run("holes " + path("pinched.off"));
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_NE(text.out.find("pinched at vertex"), std::string::npos) << text.out;
  EXPECT_EQ(text.out.find("unfillable"), std::string::npos) << text.out;
  const CliRun json = run("holes " + path("pinched.off") + " --json");
  ASSERT_EQ(json.code, 0) << json.err;
  const auto h = nlohmann::json::parse(json.out);
  ASSERT_EQ(h["holes"].size(), 1u);
  EXPECT_EQ(h["holes"][0]["pinched_at"].size(), 1u);
  const CliRun fill = run("fill " + path("pinched.off") + " -o " + path("out.off") + " --all");
  ASSERT_EQ(fill.code, 0) << fill.err;
  EXPECT_NE(fill.out.find("pinched"), std::string::npos) << fill.out;
  const auto [clean, boundary_edges] = closedness(path("out.off"));
  EXPECT_TRUE(clean);
  EXPECT_EQ(boundary_edges, 0u);
}

// The outline of a lone triangle is listed as the border of a separate piece (text and JSON).
TEST_F(Cli, HolesMarkTheOutlineOfALoneTriangle) {
  write("debris.off",
        testing::to_off(testing::with_lone_triangle(testing::grid(4, 4), {10, 0, 0})));
  const CliRun text = run("holes " + path("debris.off"));
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_NE(text.out.find("border of a separate piece of 1 face"), std::string::npos) << text.out;
  const CliRun json = run("holes " + path("debris.off") + " --json");
  ASSERT_EQ(json.code, 0) << json.err;
  std::size_t fragments = 0;
  const auto listing = nlohmann::json::parse(json.out);
  for (const auto& h : listing["holes"])
    if (h.contains("fragment_faces")) fragments += h["fragment_faces"].get<std::size_t>();
  EXPECT_EQ(fragments, 1u);
}

// fill --remove-fragments deletes the lone triangle whose outline it cannot fill and says so;
// without the flag the triangle stays and its outline is left open.
TEST_F(Cli, FillRemovesAFragmentOnlyWhenAsked) {
  const geometry::MeshSoup debris = testing::with_lone_triangle(testing::grid(4, 4), {10, 0, 0});
  write("debris.off", testing::to_off(debris));
  const CliRun kept = run("fill " + path("debris.off") + " -o " + path("kept.off") + " --all");
  ASSERT_EQ(kept.code, 0) << kept.err;
  EXPECT_NE(kept.out.find("filled 0 of 2 selected holes (2 left open, 0 skipped;"),
            std::string::npos)
      << kept.out;
  EXPECT_EQ(geometry::read_mesh_file(path("kept.off")).soup.triangles.size(),
            debris.triangles.size());
  const CliRun removed =
      run("fill " + path("debris.off") + " -o " + path("clean.off") + " --all --remove-fragments");
  ASSERT_EQ(removed.code, 0) << removed.err;
  EXPECT_NE(removed.out.find("removed: deleted the separate piece of 1 face"), std::string::npos)
      << removed.out;
  EXPECT_NE(removed.out.find("1 left open, 0 skipped, 1 closed by removing a fragment;"),
            std::string::npos)
      << removed.out;
  const geometry::MeshSoup clean = geometry::read_mesh_file(path("clean.off")).soup;
  EXPECT_EQ(clean.triangles.size(), debris.triangles.size() - 1);
  EXPECT_EQ(clean.points.size(), debris.points.size() - 3);  // no unreferenced vertex written
  const CliRun json = run("fill " + path("debris.off") + " -o " + path("clean.off") +
                          " --all --remove-fragments --json");
  ASSERT_EQ(json.code, 0) << json.err;
  const auto report = nlohmann::json::parse(json.out);
  EXPECT_EQ(report["fragments_removed"], 1);
  EXPECT_EQ(report["left_open"], 1);
  std::size_t faces_removed = 0;
  for (const auto& h : report["holes"])
    if (h.contains("faces_removed")) faces_removed += h["faces_removed"].get<std::size_t>();
  EXPECT_EQ(faces_removed, 1u);
}

TEST_F(Cli, FillOneHoleByIdOrByPointLeavesTheOthers) {
  const CliRun holes = run("holes " + spot_ + " --json");
  const auto h = nlohmann::json::parse(holes.out)["holes"];
  const auto id = h[1]["id"].get<std::uint32_t>();
  const CliRun by_id = run("fill " + spot_ + " -o " + path("one.ply") + " --hole " +
                           std::to_string(id) + " --binary");
  ASSERT_EQ(by_id.code, 0) << by_id.err;
  EXPECT_NE(by_id.out.find("filled 1 of 1"), std::string::npos) << by_id.out;
  const auto after = geometry::find_holes(
      geometry::build_mesh(geometry::read_mesh_file(path("one.ply")).soup).mesh);
  EXPECT_EQ(after.holes.size(), 2u);
  EXPECT_FALSE(geometry::find_hole_by_id(after.holes, id));
  const auto c = h[2]["centroid"];
  const std::string point = std::to_string(c[0].get<double>()) + "," +
                            std::to_string(c[1].get<double>()) + "," +
                            std::to_string(c[2].get<double>());
  const CliRun near =
      run("fill " + spot_ + " -o " + path("near.stl") + " --near " + point + " --json");
  ASSERT_EQ(near.code, 0) << near.err;
  const auto nj = nlohmann::json::parse(near.out);
  EXPECT_EQ(nj["holes"][0]["hole"], h[2]["id"]);
}

TEST_F(Cli, ClosedMeshHasNothingToFill) {
  write("cube.off",
        "OFF\n8 12 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n"
        "3 0 2 1\n3 0 3 2\n3 4 5 6\n3 4 6 7\n3 0 1 5\n3 0 5 4\n3 1 2 6\n3 1 6 5\n3 2 3 7\n3 2 7 6\n"
        "3 3 0 4\n3 3 4 7\n");
  const CliRun holes = run("holes " + path("cube.off"));
  EXPECT_EQ(holes.code, 0);
  EXPECT_NE(holes.out.find("no holes"), std::string::npos) << holes.out;
  const CliRun all = run("fill " + path("cube.off") + " -o " + path("same.off") + " --all");
  EXPECT_EQ(all.code, 0) << all.err;
  EXPECT_NE(all.out.find("filled 0 of 0"), std::string::npos) << all.out;
  const CliRun near = run("fill " + path("cube.off") + " -o " + path("near.off") + " --near 0,0,0");
  EXPECT_EQ(near.code, kExitBadInput);
  EXPECT_NE(near.err.find("no holes"), std::string::npos) << near.err;
  EXPECT_FALSE(fs::exists(path("near.off")));
}

TEST_F(Cli, SizeLimitSkipsAndStrictReportsOpenHoles) {
  const CliRun r =
      run("fill " + spot_ + " -o " + path("o.obj") + " --all --max-boundary 30 --json --strict");
  ASSERT_EQ(r.code, 0) << r.err;  // skipped holes are not failures
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["filled"], 2);
  EXPECT_EQ(j["skipped"], 1);
}

}  // namespace
}  // namespace touchmend::cli
