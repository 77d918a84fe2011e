// The haptic station end to end on loopback with a real touchmend-server: a replayed
// trajectory approaches a hole of a shared case and presses the button; the server fills it;
// the station's mesh matches the server's; a second client sees the delta and the first
// operator's cursor. Plus the touchmend-client binary: devices, bad devices, a viewer frame
// under Xvfb with the mesh and a highlighted hole in it.

#include "client/app/station.h"

#include <array>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <limits>
#include <memory>
#include <optional>
#include <png.h>
#include <thread>

#include <gtest/gtest.h>

#include "device/simulated_device.h"
#include "device/trajectory.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_io.h"
#include "tests/integration/server_process.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::testing {
namespace {

using namespace std::chrono_literals;
using haptics::Vec3;

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

const std::filesystem::path kCase =
    std::filesystem::path(TOUCHMEND_SHARED_DATA_DIR) / "cases" / "spot_sml" / "holed.off";

//! A trajectory (device frame) that comes from outside to `target`, presses button 1 there,
//! releases and stays.
//! The device workspace of every replay here: a cube 0.2 across around the origin.
const Eigen::AlignedBox3d kWorkspace(Eigen::Vector3d::Constant(-0.1),
                                     Eigen::Vector3d::Constant(0.1));

//! \p seconds of the tool held still at \p target (a model point), the button up.
device::Trajectory park(const haptics::WorkspaceMap& map, const Vec3& target, double seconds) {
  device::Trajectory t;
  t.workspace = kWorkspace;
  for (int i = 0; i <= static_cast<int>(seconds * 100); ++i)
    t.samples.push_back({i * 0.01, map.to_device(target), 0});
  return t;
}

device::Trajectory approach(const haptics::WorkspaceMap& map, const Vec3& outside,
                            const Vec3& target, const Eigen::AlignedBox3d& workspace) {
  device::Trajectory t;
  t.workspace = workspace;
  for (int i = 0; i <= 1600; ++i) {
    const double s = i * 0.001;
    const double u = std::min(1.0, s / 0.6);
    const Vec3 model = outside + u * (target - outside);
    const std::uint32_t buttons = (s > 0.8 && s < 1.0) ? 1u : 0u;
    t.samples.push_back({s, map.to_device(model), buttons});
  }
  return t;
}

TEST(Station, ReplayPressesOnAHoleTheServerFillsItAndEveryoneAgrees) {
  // The shared cases are a prerequisite of the test suite (deploy/run-tests.sh checks them).
  ASSERT_TRUE(std::filesystem::exists(kCase)) << "shared data missing: " << kCase;
  TempDir dir;
  ServerProcess server(dir.path());
  ASSERT_TRUE(server.start()) << server.log();

  app::StationOptions options;
  options.mesh_bytes = read_file(kCase);
  options.mesh_name = "holed.off";
  app::Station station(server.connect(), options);
  ASSERT_TRUE(station.start().is_ok());
  const app::StationView before = station.view();
  ASSERT_TRUE(before.holes && before.surface);
  const std::size_t holes_before = before.holes->size();
  ASSERT_GE(holes_before, 1u);

  // A second operator on the same session.
  auto channel_b = server.connect();
  net::RepairClient client_b(channel_b);
  net::SessionReplica replica_b(client_b, station.session_id());
  std::vector<Vec3> cursors_b;
  replica_b.on_presence = [&](const v1::Presence& p) {
    cursors_b.emplace_back(p.tool_position().x(), p.tool_position().y(), p.tool_position().z());
  };
  ASSERT_TRUE(replica_b.start().is_ok());

  // The trajectory: from outside the model straight onto a vertex of the first hole's rim.
  const auto& hole = before.holes->front();
  const Vec3 rim = before.surface->positions[hole.vertices.front()];
  const Eigen::AlignedBox3d model = app::bounds_of(station.document());
  const Vec3 outward = (rim - model.center()).normalized();
  const Eigen::AlignedBox3d& workspace = kWorkspace;
  const haptics::WorkspaceMap map = haptics::WorkspaceMap::fit(model, workspace);
  device::ReplayDevice replay(
      approach(map, rim + 0.3 * model.diagonal().norm() * outward, rim, workspace), "approach");
  device::SafetyFilter safe(replay);
  ASSERT_TRUE(safe.open().ok);
  app::StationRuntime runtime(station, safe, app::loop_options_for(model, workspace));
  runtime.start();

  // Wait for the fill to land in the station's replica.
  const std::uint64_t start_version = station.version();
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (station.version() == start_version && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(10ms);
  std::this_thread::sleep_for(300ms);  // the rest of the trajectory: tool samples, presence
  runtime.stop();
  safe.close();

  const app::StationView after = station.view();
  EXPECT_EQ(station.fills_requested(), 1u) << after.status;
  ASSERT_GT(station.version(), start_version) << "no fill arrived; status: " << after.status;
  EXPECT_EQ(after.status.rfind("fill:", 0), 0u) << after.status;
  EXPECT_NE(after.status.find("filled"), std::string::npos) << after.status;
  ASSERT_TRUE(after.holes);
  EXPECT_EQ(after.holes->size(), holes_before - 1);
  // The station's mesh is the server's.
  net::RepairClient check(server.connect());
  rpc::MeshDocument server_document;
  ASSERT_TRUE(check.download_document(station.session_id(), server_document).is_ok());
  EXPECT_TRUE(station.document() == server_document);
  // The second operator got the delta and saw the first one's cursor near the hole.
  ASSERT_TRUE(replica_b.wait_for_version(server_document.version, 10s).is_ok());
  EXPECT_TRUE(replica_b.document() == server_document);
  for (int i = 0; i < 20; ++i) (void)replica_b.poll(10ms);
  ASSERT_FALSE(cursors_b.empty());
  double nearest = 1e9;
  for (const Vec3& c : cursors_b) nearest = std::min(nearest, (c - rim).norm());
  EXPECT_LT(nearest, 0.05 * model.diagonal().norm());
  // The haptic side did its part: ticks, patches, samples acknowledged.
  EXPECT_GT(runtime.loop().stats().ticks, 500u);
  EXPECT_GT(station.samples_sent(), 100u);
  EXPECT_GT(station.samples_acked(), 0u);  // batches reached the server
}

// A press on the outline of a lone triangle beside the surface deletes the triangle (the only
// way to close that loop): the status says so, and the station's mesh is the server's.
TEST(Station, PressOnAFragmentsOutlineRemovesIt) {
  TempDir dir;
  ServerProcess server(dir.path());
  ASSERT_TRUE(server.start()) << server.log();
  app::StationOptions options;
  options.mesh_bytes = to_off(with_lone_triangle(grid(4, 4), {6, 1, 0.5}));
  options.mesh_name = "debris.off";
  app::Station station(server.connect(), options);
  ASSERT_TRUE(station.start().is_ok());
  const app::StationView before = station.view();
  ASSERT_TRUE(before.holes && before.surface);
  ASSERT_EQ(before.holes->size(), 2u);
  const std::size_t faces_before = station.document().alive_faces();
  // Onto the triangle's corner farthest from the grid, from beyond it.
  const Vec3 corner(7, 1, 0.5);
  const Eigen::AlignedBox3d model = app::bounds_of(station.document());
  const Eigen::AlignedBox3d& workspace = kWorkspace;
  const haptics::WorkspaceMap map = haptics::WorkspaceMap::fit(model, workspace);
  device::ReplayDevice replay(approach(map, corner + Vec3(2, 0, 1), corner, workspace), "fragment");
  device::SafetyFilter safe(replay);
  ASSERT_TRUE(safe.open().ok);
  app::StationRuntime runtime(station, safe, app::loop_options_for(model, workspace));
  runtime.start();
  // The delta comes with the session stream, the status with the fill's answer: wait for both.
  const std::uint64_t start_version = station.version();
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while ((station.version() == start_version || station.view().status.rfind("fill:", 0) != 0) &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(10ms);
  runtime.stop();
  safe.close();
  const app::StationView after = station.view();
  ASSERT_GT(station.version(), start_version) << "no edit arrived; status: " << after.status;
  EXPECT_NE(after.status.find("removed: a fragment of 1 face"), std::string::npos) << after.status;
  EXPECT_EQ(station.document().alive_faces(), faces_before - 1);
  ASSERT_TRUE(after.holes);
  EXPECT_EQ(after.holes->size(), 1u);
  net::RepairClient check(server.connect());
  rpc::MeshDocument server_document;
  ASSERT_TRUE(check.download_document(station.session_id(), server_document).is_ok());
  EXPECT_TRUE(station.document() == server_document);
}

TEST(Station, ConnectionLossKeepsTheSurfaceUnderTheToolAndResumes) {
  TempDir dir;
  ServerProcess server(dir.path());
  ASSERT_TRUE(server.start()) << server.log();
  app::StationOptions options;
  options.mesh_bytes = read_file(TOUCHMEND_SAMPLE_MESH);
  app::Station station(server.connect(), options);
  ASSERT_TRUE(station.start().is_ok());
  const app::StationView view = station.view();
  const Eigen::AlignedBox3d model = app::bounds_of(station.document());
  // The simulated hand presses down onto the top of the model (where a ray from above first
  // meets it).
  haptics::TriangleSet whole;
  whole.build(*view.surface);
  const Vec3 above = model.center() + model.diagonal().norm() * Vec3::UnitY();
  haptics::SegmentHit top;
  ASSERT_TRUE(whole.first_hit(above, model.center(), top));
  const Vec3 spot = top.point;
  const Vec3 inward = -Vec3::UnitY();
  const Eigen::AlignedBox3d& workspace = kWorkspace;
  const haptics::WorkspaceMap map = haptics::WorkspaceMap::fit(model, workspace);
  device::SimulatedOptions so;
  so.start = map.to_device(spot - 0.1 * model.diagonal().norm() * inward);
  device::SimulatedDevice sim(so);
  sim.set_target(so.start, 0);  // hold outside until the first proxy patch is there
  device::SafetyFilter safe(sim);
  ASSERT_TRUE(safe.open().ok);
  app::StationRuntime runtime(station, safe, app::loop_options_for(model, workspace));
  runtime.start();
  for (int i = 0; i < 400 && runtime.loop().stats().patches_taken == 0; ++i)
    std::this_thread::sleep_for(10ms);
  // A hand's pace (the safety filter disarms above 1 m/s): half a second down to the surface.
  const Vec3 pressed = map.to_device(spot + 0.02 * model.diagonal().norm() * inward);
  for (int i = 1; i <= 50; ++i) {
    sim.set_target(so.start + (pressed - so.start) * (i / 50.0), 0);
    std::this_thread::sleep_for(10ms);
  }
  auto& ui = runtime.loop().ui_state();
  const auto touching = [&] {
    ui.update();
    return ui.front().in_contact && ui.front().force.norm() > 0.05;
  };
  for (int i = 0; i < 400 && !touching(); ++i) std::this_thread::sleep_for(10ms);
  ASSERT_TRUE(touching()) << "the stylus never pressed on the surface: proxy "
                          << ui.front().proxy.transpose() << " device "
                          << ui.front().device_position.transpose() << " spot " << spot.transpose()
                          << " patches " << runtime.loop().stats().patches_taken << " safety "
                          << device::to_string(safe.arm_state()) << " velocity trips "
                          << safe.counters().velocity_trips;

  // The server dies: the loop keeps rendering the last surface, with a safe force.
  EXPECT_EQ(server.stop(SIGKILL), -SIGKILL);
  const std::uint64_t ticks_before = runtime.loop().stats().ticks;
  for (int i = 0; i < 50; ++i) {
    std::this_thread::sleep_for(10ms);
    ui.update();
    EXPECT_TRUE(ui.front().in_contact);
    EXPECT_TRUE(ui.front().force.allFinite());
    EXPECT_LE(ui.front().force.norm(), safe.force_cap() + 1e-9);
  }
  // The loop keeps ticking without its server (its rate is the haptics benchmark's business:
  // on a loaded machine, under the sanitizers, half a second held 291 ticks once).
  for (int i = 0; i < 500 && runtime.loop().stats().ticks <= ticks_before + 300; ++i)
    std::this_thread::sleep_for(10ms);
  EXPECT_GT(runtime.loop().stats().ticks, ticks_before + 300);
  EXPECT_EQ(safe.arm_state(), device::ArmState::Armed);

  // Back: another operator fills a hole; the station reconnects and gets it by replay.
  ASSERT_TRUE(server.start()) << server.log();
  net::RepairClient other(server.connect());
  v1::FillHolesRequest fill;
  fill.set_session_id(station.session_id());
  fill.mutable_selection()->mutable_ids()->add_ids(view.holes->front().id);
  v1::EditResponse edit;
  ASSERT_TRUE(other.fill_holes(fill, edit).is_ok());
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (station.version() < edit.version() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(20ms);
  runtime.stop();
  safe.close();
  EXPECT_EQ(station.version(), edit.version()) << station.view().status;
  EXPECT_GE(station.reconnects(), 1u);
  rpc::MeshDocument server_document;
  ASSERT_TRUE(other.download_document(station.session_id(), server_document).is_ok());
  EXPECT_TRUE(station.document() == server_document);
}

// ---- the binary ----

int run(const std::string& command, std::string& output) {
  const std::string file = (std::filesystem::temp_directory_path() /
                            ("tm-client-" + std::to_string(::getpid()) + ".out"))
                               .string();
  const int rc = std::system((command + " > " + file + " 2>&1").c_str());
  output = read_file(file);
  std::filesystem::remove(file);
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

//! A trajectory in the model frame: straight moves between waypoints at 1 kHz, each with the
//! buttons held during the move.
struct Waypoint {
  Vec3 position;
  double seconds;  //!< time to get there from the previous waypoint
  std::uint32_t buttons;
};

device::Trajectory path(const haptics::WorkspaceMap& map, const Eigen::AlignedBox3d& workspace,
                        const std::vector<Waypoint>& waypoints) {
  device::Trajectory t;
  t.workspace = workspace;
  double time = 0;
  Vec3 from = waypoints.front().position;
  for (const Waypoint& w : waypoints) {
    const int steps = std::max(1, static_cast<int>(w.seconds * 1000));
    for (int i = 1; i <= steps; ++i) {
      const Vec3 p = from + (static_cast<double>(i) / steps) * (w.position - from);
      t.samples.push_back({time, map.to_device(p), w.buttons});
      time += 0.001;
    }
    from = w.position;
  }
  return t;
}

//! Comes from outside along \p away to just under the surface at \p p, presses button 1
//! there, releases and leaves.
void press_at(std::vector<Waypoint>& w, const Vec3& p, const Vec3& away) {
  w.push_back({p + 1.0 * away, 0.15, 0});
  w.push_back({p - 0.02 * away, 0.25, 0});
  w.push_back({p - 0.02 * away, 0.1, 1});
  w.push_back({p - 0.02 * away, 0.1, 0});
  w.push_back({p + 1.0 * away, 0.15, 0});
}

//! Out of the cube [0, 8]³ across its edge x = z = 8 (between the two faces).
Vec3 out_of_the_edge() {
  return Vec3(1, 0, 1).normalized();
}

//! From outside, presses at points of the cube's edge x = z = 8 at heights \p ys (the
//! sharp-edge picks P1..P4: by default a straight crease with |P3 - P2| = 4.8).
std::vector<Waypoint> picks_on_the_edge(std::initializer_list<double> ys = {0.5, 1.6, 6.4, 7.5}) {
  std::vector<Waypoint> w{{Vec3(8, *ys.begin(), 8) + 2.0 * out_of_the_edge(), 0.1, 0}};
  for (const double y : ys) press_at(w, Vec3(8, y, 8), out_of_the_edge());
  return w;
}

//! A session holding the cube [0, 8]³ with a hole across its edge x = z = 8 (around y = 4),
//! filled with \p shape.
void filled_cube_session(ServerProcess& server, v1::PatchShape shape, v1::SessionInfo& info,
                         v1::EditResponse& filled) {
  const geometry::MeshSoup soup = cube_with_hole(8, geometry::Vec3(8, 4, 8), 2.2);
  net::RepairClient setup(server.connect());
  ASSERT_TRUE(setup.create_session("cube edge", info).is_ok());
  v1::LoadMeshResponse loaded;
  ASSERT_TRUE(
      setup.upload_mesh(info.session_id(), to_off(soup), v1::OFF, "cube.off", loaded).is_ok());
  v1::FillHolesRequest fill;
  fill.set_session_id(info.session_id());
  fill.mutable_selection()->set_all(true);
  fill.mutable_options()->set_shape(shape);
  // The plain fill: automatic crease retaining would already put the edge into the patch.
  fill.mutable_options()->set_sharp(v1::SHARP_OFF);
  ASSERT_TRUE(setup.fill_holes(fill, filled).is_ok());
}

//! A server holding the filled cube-edge session and a station on it, with the model's place
//! in the tests' device workspace.
struct CubeEdgeStation {
  TempDir dir;
  ServerProcess server{dir.path()};
  v1::SessionInfo info;
  v1::EditResponse filled;
  std::unique_ptr<app::Station> station;
  Eigen::AlignedBox3d model;
  Eigen::AlignedBox3d workspace = kWorkspace;
  haptics::WorkspaceMap map;
};

//! Starts \p s: the server, the cube filled with \p shape, the station with \p tool (use under
//! ASSERT_NO_FATAL_FAILURE).
void start_cube_edge_station(CubeEdgeStation& s, v1::PatchShape shape, app::StationTool tool,
                             double push_step = 0) {
  ASSERT_TRUE(s.server.start()) << s.server.log();
  ASSERT_NO_FATAL_FAILURE(filled_cube_session(s.server, shape, s.info, s.filled));
  app::StationOptions options;
  options.session_id = s.info.session_id();
  options.tool = tool;
  options.push_step = push_step;
  s.station = std::make_unique<app::Station>(s.server.connect(), options);
  ASSERT_TRUE(s.station->start().is_ok());
  s.model = app::bounds_of(s.station->document());
  s.map = haptics::WorkspaceMap::fit(s.model, s.workspace);
}

//! The station running on a replayed trajectory (its haptic loop, proxy updates and network
//! side) until this is destroyed.
class ReplayedRun {
 public:
  ReplayedRun(app::Station& station, const device::Trajectory& trajectory,
              const Eigen::AlignedBox3d& model, const Eigen::AlignedBox3d& workspace)
      : device_(trajectory, "script"), safe_(device_) {
    if (!safe_.open().ok) return;
    runtime_.emplace(station, safe_, app::loop_options_for(model, workspace));
    runtime_->start();
  }
  ~ReplayedRun() { stop(); }
  ReplayedRun(const ReplayedRun&) = delete;
  ReplayedRun& operator=(const ReplayedRun&) = delete;
  bool running() const { return runtime_.has_value(); }
  void stop() {
    if (!runtime_) return;
    runtime_->stop();
    runtime_.reset();
    safe_.close();
  }

 private:
  device::ReplayDevice device_;
  device::SafetyFilter safe_;
  std::optional<app::StationRuntime> runtime_;
};

//! Runs the station on a replayed trajectory until it ends (plus a moment).
void replay(app::Station& station, const device::Trajectory& trajectory,
            const Eigen::AlignedBox3d& model, const Eigen::AlignedBox3d& workspace) {
  ReplayedRun run(station, trajectory, model, workspace);
  ASSERT_TRUE(run.running());
  const double seconds = trajectory.samples.back().t + 1.0;
  std::this_thread::sleep_for(std::chrono::milliseconds(static_cast<int>(seconds * 1000)));
}

//! Polls \p done until it holds or \p limit has passed; its last answer.
template <class Done>
bool wait_until(const Done& done, std::chrono::milliseconds limit = 10s) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (!done() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(5ms);
  return done();
}

TEST(Station, ReplayedStitchDragCreatesTheTriangle) {
  TempDir dir;
  ServerProcess server(dir.path());
  ASSERT_TRUE(server.start()) << server.log();
  // Two 4x4 plates in z = 0 with a 0.5 gap between x = 4 and x = 4.5.
  const geometry::MeshSoup soup = two_plates(4, 0.5);
  app::StationOptions options;
  options.mesh_bytes = to_off(soup);
  options.tool = app::StationTool::Stitch;
  app::Station station(server.connect(), options);
  ASSERT_TRUE(station.start().is_ok());
  EXPECT_EQ(station.view().tool, "stitch");
  const std::uint64_t start_version = station.version();
  const Eigen::AlignedBox3d model = app::bounds_of(station.document());
  const Eigen::AlignedBox3d& workspace = kWorkspace;
  const haptics::WorkspaceMap map = haptics::WorkspaceMap::fit(model, workspace);
  // Above the plates (no contact needed to pick): press near the left plate's edge x = 4,
  // 0 < y < 1, drag across the gap to the right plate's corner (4.5, 0), release.
  replay(station,
         path(map, workspace,
              {{Vec3(3.5, 0.5, 0.3), 0.2, 0},
               {Vec3(3.92, 0.5, 0.05), 0.3, 0},
               {Vec3(3.92, 0.5, 0.05), 0.2, 1},
               {Vec3(4.55, 0.05, 0.05), 0.5, 1},
               {Vec3(4.55, 0.05, 0.05), 0.2, 0},
               {Vec3(4.55, 0.05, 0.4), 0.2, 0}}),
         model, workspace);
  const app::StationView after = station.view();
  // The edge (4, 0)-(4, 1) is vertices 4 and 9, in the hole loop's order; (4.5, 0) is 25.
  EXPECT_NE(after.status.find("stitch: triangle 9-4-25"), std::string::npos) << after.status;
  // The status comes with the stitch's answer, the edit itself with the session's stream: on a
  // loaded machine the delta may arrive a little later.
  EXPECT_TRUE(wait_until([&] { return station.version() >= start_version + 1; }));
  EXPECT_EQ(station.version(), start_version + 1) << after.status;
  net::RepairClient check(server.connect());
  rpc::MeshDocument server_document;
  ASSERT_TRUE(check.download_document(station.session_id(), server_document).is_ok());
  EXPECT_TRUE(station.document() == server_document);
  EXPECT_EQ(server_document.alive_faces(), 65u);
}

TEST(Station, ReplayedSharpEdgePicksPushesAndSmoothsACubeEdge) {
  // The cube [0, 8]³ with a hole across its edge x = z = 8, filled rounded (faired) first.
  CubeEdgeStation s;
  ASSERT_NO_FATAL_FAILURE(
      start_cube_edge_station(s, v1::PATCH_SHAPE_FAIR, app::StationTool::SharpEdge, 0.1));
  app::Station& station = *s.station;
  // How near the patch comes to the edge x = z = 8 in its middle (the hole, radius 2.2 around
  // (8, 4, 8), took every vertex of the cube there that is nearer than 1.6 to the edge).
  const auto nearest_to_edge = [](const rpc::MeshDocument& d) {
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t v = 0; v < d.positions.size(); ++v) {
      const auto& p = d.positions[v];
      if (d.vertex_alive[v] && p[1] > 2.5 && p[1] < 5.5)
        nearest = std::min(nearest, std::hypot(8 - p[0], 8 - p[2]));
    }
    return nearest;
  };
  const double before_gap = nearest_to_edge(station.document());
  ASSERT_GT(before_gap, 0.2);
  const Vec3 diagonal = out_of_the_edge();
  std::vector<Waypoint> w = picks_on_the_edge();  // P1..P4
  press_at(w, Vec3(8, 0.5, 8), diagonal);         // confirm
  // Sweeps: pressed into the patch under the edge, back and forth along it (enough of them for
  // a vertex to reach the edge even when a loaded machine delays the pushes).
  w.push_back({Vec3(8, 2.6, 8) + 1.0 * diagonal, 0.2, 0});
  for (int sweep = 0; sweep < 10; ++sweep) {
    w.push_back({Vec3(8, sweep % 2 ? 5.4 : 2.6, 8) - 0.4 * diagonal, 0.3, 1});
    w.push_back({Vec3(8, sweep % 2 ? 2.6 : 5.4, 8) - 0.4 * diagonal, 1.0, 1});
  }
  w.push_back({Vec3(8, 4, 8) + 1.0 * diagonal, 0.2, 0});
  w.push_back({Vec3(8, 4, 8) + 1.0 * diagonal, 0.1, 2});  // button 2: finish
  w.push_back({Vec3(8, 4, 8) + 1.5 * diagonal, 0.2, 0});
  ASSERT_NO_FATAL_FAILURE(replay(station, path(s.map, s.workspace, w), s.model, s.workspace));

  const app::StationView after = station.view();
  EXPECT_GT(station.pushes(), 0u) << after.status;
  EXPECT_NE(after.status.find("patch finished (fair)"), std::string::npos) << after.status;
  EXPECT_TRUE(after.picks.empty());  // the tool finished
  net::RepairClient check(s.server.connect());
  rpc::MeshDocument doc;
  ASSERT_TRUE(check.download_document(station.session_id(), doc).is_ok());
  EXPECT_TRUE(wait_until([&] { return station.version() >= doc.version; }, 30s));  // the last delta
  EXPECT_TRUE(station.document() == doc);
  // The pushes brought vertices of the rounded patch up to the edge; before, the faired
  // patch's vertices under the edge were far below it. (The picks are proxy positions, a
  // little off the edge on one face or the other, so the curve is too.)
  const double after_gap = nearest_to_edge(doc);
  EXPECT_LT(after_gap, 0.1) << station.pushes() << " pushes; " << after.status;
  EXPECT_LT(after_gap, before_gap / 4) << before_gap;
  // The tool is done on the server too.
  v1::SharpEdgeRequest push;
  push.set_session_id(station.session_id());
  push.mutable_push()->set_step(0.1);
  v1::SharpEdgeResponse response;
  EXPECT_EQ(check.sharp_edge(push, response).code, rpc::StatusCode::FailedPrecondition);
}

TEST(Station, SharpEdgeTangentsAdjustLiveWithoutAnEdit) {
  CubeEdgeStation s;
  ASSERT_NO_FATAL_FAILURE(
      start_cube_edge_station(s, v1::PATCH_SHAPE_AUTO, app::StationTool::SharpEdge));
  app::Station& station = *s.station;
  const Vec3 diagonal = out_of_the_edge();
  std::vector<Waypoint> w{{Vec3(8, 0.5, 8) + 2.0 * diagonal, 0.1, 0}};
  // P1 off the edge's line (a bend; far enough from the edge that it is on no crease, so the
  // chord gives the start direction), so longer tangents move the curve's middle.
  for (const Vec3& p : {Vec3(8, 0.5, 5.5), Vec3(8, 1.6, 8), Vec3(8, 6.4, 8), Vec3(8, 7.5, 8)})
    press_at(w, p, diagonal);
  w.push_back({Vec3(8, 4, 8) + 2.0 * diagonal, 6.0, 0});  // then wait while k is adjusted
  ReplayedRun run(station, path(s.map, s.workspace, w), s.model, s.workspace);
  ASSERT_TRUE(run.running());
  ASSERT_TRUE(wait_until([&] { return !station.view().curve.empty(); })) << station.view().status;
  const app::StationView first = station.view();
  EXPECT_EQ(first.picks.size(), 4u);
  EXPECT_FALSE(first.guide.empty());
  station.adjust_tangents(5);
  ASSERT_TRUE(wait_until([&] { return station.view().k1 > first.k1 * 1.5; }))
      << station.view().status;
  const app::StationView longer = station.view();
  EXPECT_NEAR(longer.k1, first.k1 * std::pow(1.1, 5), 1e-9 * first.k1);
  EXPECT_NEAR(longer.k4, first.k4 * std::pow(1.1, 5), 1e-9 * first.k4);
  const Vec3 a = first.curve[first.curve.size() / 2], b = longer.curve[longer.curve.size() / 2];
  EXPECT_GT((a - b).norm(), 1e-3);  // the preview changed
  station.adjust_tangents(-5);
  ASSERT_TRUE(wait_until([&] { return std::abs(station.view().k1 - first.k1) < 1e-9 * first.k1; }));
  run.stop();
  // Only previews: the session's version is the fill's.
  EXPECT_EQ(station.version(), s.filled.version());
}

TEST(Station, SharpEdgeTangentsFollowADragAndAClickConfirms) {
  CubeEdgeStation s;
  ASSERT_NO_FATAL_FAILURE(
      start_cube_edge_station(s, v1::PATCH_SHAPE_AUTO, app::StationTool::SharpEdge));
  app::Station& station = *s.station;
  const Vec3 diagonal = out_of_the_edge();
  std::vector<Waypoint> w = picks_on_the_edge();
  w.push_back({Vec3(8, 3, 8) + 1.0 * diagonal, 1.0, 0});  // the preview arrives
  // Press on the edge and drag a quarter of the chord |P3 - P2| = 4.8 towards P3: k doubles.
  w.push_back({Vec3(8, 3, 8) - 0.02 * diagonal, 0.3, 0});
  w.push_back({Vec3(8, 3, 8) - 0.02 * diagonal, 0.1, 1});
  w.push_back({Vec3(8, 4.2, 8) - 0.02 * diagonal, 1.0, 1});
  w.push_back({Vec3(8, 4.2, 8) - 0.02 * diagonal, 0.2, 1});
  w.push_back({Vec3(8, 4.2, 8) - 0.02 * diagonal, 0.1, 0});
  w.push_back({Vec3(8, 4.2, 8) + 1.0 * diagonal, 1.0, 0});
  press_at(w, Vec3(8, 2, 8), diagonal);  // a click: confirm
  w.push_back({Vec3(8, 2, 8) + 2.0 * diagonal, 1.5, 0});
  ReplayedRun run(station, path(s.map, s.workspace, w), s.model, s.workspace);
  ASSERT_TRUE(run.running());
  ASSERT_TRUE(wait_until([&] { return !station.view().curve.empty(); }, 10s))
      << station.view().status;
  const app::StationView first = station.view();
  ASSERT_GT(first.k1, 0);
  // P1 and P4 were picked on the edge: the curve leaves along it at both ends.
  EXPECT_NE(first.status.find("tangents: crease at P2, crease at P3"), std::string::npos)
      << first.status;
  // The drag: k grows while the button is held; nothing is committed.
  ASSERT_TRUE(wait_until([&] { return station.view().k1 > 1.5 * first.k1; }, 15s))
      << station.view().status;
  EXPECT_EQ(station.version(), s.filled.version());
  // The click confirms: the snap is the next version.
  EXPECT_TRUE(wait_until([&] { return station.version() > s.filled.version(); }, 15s))
      << station.view().status;
  const app::StationView after = station.view();
  run.stop();
  EXPECT_EQ(station.version(), s.filled.version() + 1) << after.status;
  EXPECT_NE(after.tool.find("sweep to push"), std::string::npos) << after.tool;
  // k1 and k4 were scaled together, by about two (the proxy's path is not the device's exactly).
  EXPECT_NEAR(after.k1 / first.k1, 2.0, 0.3);
  EXPECT_NEAR(after.k4 / first.k4, after.k1 / first.k1, 1e-9);
}

TEST(Station, SharpEdgeCancelDuringAPressLeavesNoDragBehind) {
  CubeEdgeStation s;
  ASSERT_NO_FATAL_FAILURE(
      start_cube_edge_station(s, v1::PATCH_SHAPE_AUTO, app::StationTool::SharpEdge));
  app::Station& station = *s.station;
  const Vec3 diagonal = out_of_the_edge();
  std::vector<Waypoint> w = picks_on_the_edge();
  w.push_back({Vec3(8, 3, 8) + 1.0 * diagonal, 1.0, 0});  // the preview arrives
  // Press on the curve, then button 2 while button 1 is still held: cancelled; release.
  w.push_back({Vec3(8, 3, 8) - 0.02 * diagonal, 0.3, 0});
  w.push_back({Vec3(8, 3, 8) - 0.02 * diagonal, 0.1, 1});
  w.push_back({Vec3(8, 3, 8) - 0.02 * diagonal, 0.1, 3});
  w.push_back({Vec3(8, 3, 8) - 0.02 * diagonal, 0.1, 1});
  w.push_back({Vec3(8, 3, 8) - 0.02 * diagonal, 0.1, 0});
  // Picks again: the fourth one's release must leave the new curve previewed, not confirm it.
  const std::vector<Waypoint> again = picks_on_the_edge();
  w.insert(w.end(), again.begin(), again.end());
  w.push_back({Vec3(8, 3, 8) + 1.0 * diagonal, 1.0, 0});
  ASSERT_NO_FATAL_FAILURE(replay(station, path(s.map, s.workspace, w), s.model, s.workspace));
  const app::StationView after = station.view();
  EXPECT_EQ(station.version(), s.filled.version()) << after.status;
  EXPECT_FALSE(after.curve.empty()) << after.status;
  EXPECT_NE(after.tool.find("click to confirm"), std::string::npos) << after.tool;
  // Nor did holding that press drag k: the default tangent length of a straight edge is the
  // chord |P3 - P2| = 4.8.
  EXPECT_NEAR(after.k1, 4.8, 0.5) << after.status;
}

TEST(Station, ShowsAnotherClientsSharpEdgePreviewUntilItEnds) {
  CubeEdgeStation s;
  ASSERT_NO_FATAL_FAILURE(start_cube_edge_station(s, v1::PATCH_SHAPE_FAIR, app::StationTool::Fill));
  app::Station& station = *s.station;
  // The station's tool rests away from the cube while another client drives the tool.
  ReplayedRun run(station, path(s.map, s.workspace, {{Vec3(12, 4, 12), 8.0, 0}}), s.model,
                  s.workspace);
  ASSERT_TRUE(run.running());
  net::RepairClient other(s.server.connect());
  v1::SharpEdgeRequest request;
  request.set_session_id(s.info.session_id());
  for (const double y : {0.5, 2.0, 6.0, 7.5}) {
    auto* p = request.mutable_begin()->add_points();
    p->set_x(8);
    p->set_y(y);
    p->set_z(8);
  }
  v1::SharpEdgeResponse response;
  ASSERT_TRUE(other.sharp_edge(request, response).is_ok());
  EXPECT_TRUE(wait_until([&] { return !station.view().remote_curve.empty(); }));
  const app::StationView seen = station.view();
  EXPECT_EQ(seen.remote_curve.size(), static_cast<std::size_t>(response.curve_size()));
  EXPECT_EQ(seen.remote_guide.size(), static_cast<std::size_t>(response.guide_size()));
  EXPECT_TRUE(seen.curve.empty());  // not this station's tool
  request.set_cancel(true);
  ASSERT_TRUE(other.sharp_edge(request, response).is_ok());
  EXPECT_TRUE(wait_until([&] { return station.view().remote_curve.empty(); }));
  EXPECT_TRUE(station.view().remote_guide.empty());
}

TEST(ClientBinary, DevicesAndUsageErrors) {
  std::string out;
  EXPECT_EQ(run(std::string(TOUCHMEND_CLIENT_PATH) + " --list-devices", out), 0) << out;
  EXPECT_NE(out.find("sim"), std::string::npos);
  EXPECT_NE(out.find("replay:FILE"), std::string::npos);
  // No Falcon here: a clear message and a non-zero exit.
  EXPECT_EQ(run(std::string(TOUCHMEND_CLIENT_PATH) + " --device falcon --headless", out), 1) << out;
  EXPECT_NE(out.find("Falcon"), std::string::npos) << out;
  EXPECT_EQ(run(std::string(TOUCHMEND_CLIENT_PATH) + " --device phantom --headless", out), 2)
      << out;
  EXPECT_EQ(
      run(std::string(TOUCHMEND_CLIENT_PATH) + " --device replay:/nonexistent.traj --headless",
          out),
      1)
      << out;
  EXPECT_NE(out.find("nonexistent"), std::string::npos) << out;
  // No server: exit code 4.
  EXPECT_EQ(
      run(std::string(TOUCHMEND_CLIENT_PATH) + " --server 127.0.0.1:1 --headless --duration 1",
          out),
      4)
      << out;
}

//! Runs touchmend-client on \p session of \p server under Xvfb with \p arguments; its exit code.
int run_client_under_xvfb(const ServerProcess& server, const std::string& session,
                          const std::string& arguments, std::string& out) {
  // Under ASan, Mesa's software driver leaves allocations behind from a module it unloads at
  // exit (unattributable, so no suppression can name it): leak checking is off for these runs
  // of the client; every other client run in the tests keeps it.
  return run(
      "ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 xvfb-run -a -s '-screen 0 1280x1024x24' " +
          std::string(TOUCHMEND_CLIENT_PATH) + " --server 127.0.0.1:" +
          std::to_string(server.port()) + " --session " + session + " " + arguments,
      out);
}

// The station marks a loose fragment's outline as the server's hole listing does: the lone
// triangle's loop borders a piece of 1 face; the grid's border loop borders the whole grid (32
// faces, more than its 16 edges), and a hole cut into the grid borders no separate piece at all.
TEST(Station, BoundaryLoopsMarkALooseFragmentsOutline) {
  const auto loops_of = [](const geometry::MeshSoup& soup) {
    haptics::SurfaceMesh surface;
    for (const auto& p : soup.points) surface.positions.emplace_back(p[0], p[1], p[2]);
    for (const auto& t : soup.triangles) surface.triangles.push_back({t[0], t[1], t[2]});
    return app::find_boundary_loops(surface);
  };
  const auto debris = loops_of(with_lone_triangle(grid(4, 4), {6, 1, 0.5}));
  ASSERT_EQ(debris.size(), 2u);
  std::vector<std::size_t> marked;
  for (const app::HoleLoop& loop : debris) marked.push_back(loop.fragment_faces);
  std::sort(marked.begin(), marked.end());
  EXPECT_EQ(marked, (std::vector<std::size_t>{0, 1}));
  const auto holed = loops_of(testing::remove_faces(grid(6, 6), [](const geometry::Vec3& c) {
    return (c - geometry::Vec3(3, 3, 0)).norm() < 1.2;
  }));
  ASSERT_EQ(holed.size(), 2u);
  for (const app::HoleLoop& loop : holed) EXPECT_EQ(loop.fragment_faces, 0u);
}

// With the tool resting on a lone triangle's corner, the headless client's status line says a
// press there deletes the fragment (no press is made: the mesh stays as it was).
TEST(ClientBinary, StatusLineSaysTheHoleUnderTheToolIsAFragmentsOutline) {
  TempDir dir;
  ServerProcess server(dir.path());
  ASSERT_TRUE(server.start()) << server.log();
  net::RepairClient client(server.connect());
  v1::SessionInfo info;
  ASSERT_TRUE(client.create_session("fragment", info).is_ok());
  v1::LoadMeshResponse loaded;
  ASSERT_TRUE(client
                  .upload_mesh(info.session_id(),
                               to_off(with_lone_triangle(grid(4, 4), {6, 1, 0.5})), v1::OFF,
                               "debris.off", loaded)
                  .is_ok());
  rpc::MeshDocument document;
  ASSERT_TRUE(client.download_document(info.session_id(), document).is_ok());
  const Eigen::AlignedBox3d model = app::bounds_of(document);
  const Eigen::AlignedBox3d& workspace = kWorkspace;
  const haptics::WorkspaceMap map = haptics::WorkspaceMap::fit(model, workspace);
  const auto traj = dir.path() / "park.traj";
  ASSERT_TRUE(device::write_trajectory(traj, park(map, Vec3(7, 1, 0.5), 3.0)).ok);
  std::string out;
  ASSERT_EQ(run(std::string(TOUCHMEND_CLIENT_PATH) + " --server 127.0.0.1:" +
                    std::to_string(server.port()) + " --session " + info.session_id() +
                    " --device replay:" + traj.string() + " --headless --stats --duration 2",
                out),
            0)
      << out;
  EXPECT_NE(out.find("under the tool: the outline of a loose fragment of 1 face, a fill press "
                     "deletes it"),
            std::string::npos)
      << out;
  rpc::MeshDocument after;
  ASSERT_TRUE(client.download_document(info.session_id(), after).is_ok());
  EXPECT_EQ(after.version, document.version);
}

TEST(ClientBinary, ViewerDrawsTheMeshAndTheHighlightedHoleUnderXvfb) {
  // deploy/install-deps.sh installs Xvfb: its absence is a broken set-up, not a reason to pass.
  ASSERT_EQ(std::system("command -v xvfb-run > /dev/null 2>&1"), 0) << "xvfb-run is not installed";
  TempDir dir;
  ServerProcess server(dir.path());
  ASSERT_TRUE(server.start()) << server.log();
  // A replay that parks the tool on a rim vertex of the sample's first hole.
  const std::string mesh = TOUCHMEND_SAMPLE_MESH;
  net::RepairClient client(server.connect());
  v1::SessionInfo info;
  ASSERT_TRUE(client.create_session("viewer", info).is_ok());
  v1::LoadMeshResponse loaded;
  ASSERT_TRUE(
      client.upload_mesh(info.session_id(), read_file(mesh), v1::OFF, "spot.off", loaded).is_ok());
  rpc::MeshDocument document;
  ASSERT_TRUE(client.download_document(info.session_id(), document).is_ok());
  const auto surface = app::surface_from_document(document);
  const auto loops = app::find_boundary_loops(*surface);
  ASSERT_FALSE(loops.empty());
  const Vec3 rim = surface->positions[loops.front().vertices.front()];
  const Eigen::AlignedBox3d model = app::bounds_of(document);
  const Eigen::AlignedBox3d& workspace = kWorkspace;
  const haptics::WorkspaceMap map = haptics::WorkspaceMap::fit(model, workspace);
  const auto traj = dir.path() / "park.traj";
  ASSERT_TRUE(device::write_trajectory(traj, park(map, rim, 1.0)).ok);
  const auto png = dir.path() / "frame.png";
  std::string out;
  const int rc = run_client_under_xvfb(
      server, info.session_id(),
      "--device replay:" + traj.string() + " --headless --duration 2 --screenshot " + png.string(),
      out);
  ASSERT_EQ(rc, 0) << out;
  ASSERT_TRUE(std::filesystem::exists(png)) << out;
  EXPECT_NE(out.find("screenshot"), std::string::npos) << out;
  // Decode the PNG and classify its pixels: the lit mesh is grey (r = g = b, brighter than the
  // background), the highlighted rim is yellow (1.0, 0.85, 0.0).
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&image, png.string().c_str())) << image.message;
  image.format = PNG_FORMAT_RGB;
  std::vector<std::uint8_t> pixels(PNG_IMAGE_SIZE(image));
  ASSERT_TRUE(png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr)) << image.message;
  std::size_t mesh_pixels = 0, highlight_pixels = 0;
  const std::size_t total = std::size_t(image.width) * image.height;
  for (std::size_t i = 0; i < total; ++i) {
    const int r = pixels[3 * i], g = pixels[3 * i + 1], b = pixels[3 * i + 2];
    if (r > 60 && std::abs(r - g) < 20 && std::abs(g - b) < 25) ++mesh_pixels;
    if (r > 200 && g > 160 && g < 240 && b < 60) ++highlight_pixels;
  }
  EXPECT_GT(mesh_pixels, total / 50) << "the mesh is not drawn";
  EXPECT_GT(highlight_pixels, 20u) << "no highlighted hole";
  // The status line: light grey strokes (0.92) in the top rows, brighter than the lit mesh can be
  // (its colour is at most 0.78), and only there.
  std::size_t status_pixels = 0, stray_pixels = 0;
  for (std::size_t i = 0; i < total; ++i) {
    const int r = pixels[3 * i], g = pixels[3 * i + 1], b = pixels[3 * i + 2];
    if (r > 215 && r < 250 && std::abs(r - g) < 4 && std::abs(g - b) < 4)
      ++(i / image.width < 70 ? status_pixels : stray_pixels);
  }
  EXPECT_GT(status_pixels, 500u) << "no status line";
  EXPECT_LT(stray_pixels, 100u);
  EXPECT_LT(mesh_pixels + highlight_pixels, total) << "nothing but mesh: no background";
}

//! Reads a PNG as RGB rows (top row first).
std::vector<std::uint8_t> read_png(const std::filesystem::path& file, int& width, int& height) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, file.string().c_str())) return {};
  image.format = PNG_FORMAT_RGB;
  std::vector<std::uint8_t> pixels(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr)) return {};
  width = static_cast<int>(image.width);
  height = static_cast<int>(image.height);
  return pixels;
}

TEST(ClientBinary, SharpEdgePicksAreDrawnNumberedWithThePreviewedCurveUnderXvfb) {
  ASSERT_EQ(std::system("command -v xvfb-run > /dev/null 2>&1"), 0) << "xvfb-run is not installed";
  TempDir dir;
  ServerProcess server(dir.path());
  ASSERT_TRUE(server.start()) << server.log();
  v1::SessionInfo info;
  v1::EditResponse filled;
  ASSERT_NO_FATAL_FAILURE(filled_cube_session(server, v1::PATCH_SHAPE_FAIR, info, filled));
  net::RepairClient client(server.connect());
  rpc::MeshDocument document;
  ASSERT_TRUE(client.download_document(info.session_id(), document).is_ok());
  const Eigen::AlignedBox3d model = app::bounds_of(document);
  const Eigen::AlignedBox3d& workspace = kWorkspace;
  const haptics::WorkspaceMap map = haptics::WorkspaceMap::fit(model, workspace);
  // Four picks along the edge x = z = 8, then the tool parks far outside (out of the picture's
  // colours' way) while the preview is drawn.
  std::vector<Waypoint> w = picks_on_the_edge({0.5, 2.5, 5.5, 7.5});
  w.push_back({Vec3(8, 4, 8) + 6.0 * out_of_the_edge(), 0.3, 0});
  const auto traj = dir.path() / "picks.traj";
  ASSERT_TRUE(device::write_trajectory(traj, path(map, workspace, w)).ok);
  const auto png = dir.path() / "picks.png";
  std::string out;
  const int rc = run_client_under_xvfb(server, info.session_id(),
                                       "--tool sharp-edge --device replay:" + traj.string() +
                                           " --headless --duration 5 --screenshot " + png.string(),
                                       out);
  ASSERT_EQ(rc, 0) << out;
  int width = 0, height = 0;
  const std::vector<std::uint8_t> pixels = read_png(png, width, height);
  ASSERT_FALSE(pixels.empty()) << out;
  // Each pick's colour (P1 red, P2 orange, P3 green, P4 blue): its pixels are the 16 px cursor
  // and, up and to the right of it, the digit; so their bounding box is taller than the cursor.
  struct Box {
    int x0 = 1 << 30, y0 = 1 << 30, x1 = -1, y1 = -1;
    std::size_t count = 0;
  };
  std::array<Box, 4> picks;
  std::size_t curve = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const std::size_t i = 3 * (std::size_t(y) * std::size_t(width) + std::size_t(x));
      const int r = pixels[i], g = pixels[i + 1], b = pixels[i + 2];
      int pick = -1;
      if (r > 230 && g > 35 && g < 70 && b > 35 && b < 70) pick = 0;             // (1, 0.2, 0.2)
      if (r > 230 && g > 140 && g < 170 && b > 10 && b < 40) pick = 1;           // (1, 0.6, 0.1)
      if (r > 35 && r < 70 && g > 215 && g < 240 && b > 60 && b < 90) pick = 2;  // (0.2, 0.9, 0.3)
      if (r > 65 && r < 90 && g > 115 && g < 140 && b > 240) pick = 3;           // (0.3, 0.5, 1)
      if (r > 35 && r < 70 && g > 240 && b > 240) ++curve;                       // (0.2, 1, 1)
      if (pick < 0) continue;
      Box& box = picks[static_cast<std::size_t>(pick)];
      box.x0 = std::min(box.x0, x);
      box.x1 = std::max(box.x1, x);
      box.y0 = std::min(box.y0, y);
      box.y1 = std::max(box.y1, y);
      ++box.count;
    }
  for (std::size_t p = 0; p < picks.size(); ++p) {
    EXPECT_GT(picks[p].count, 100u) << "pick " << p + 1 << " is not drawn\n" << out;
    EXPECT_GT(picks[p].y1 - picks[p].y0, 24) << "pick " << p + 1 << " has no number\n" << out;
    EXPECT_LT(picks[p].y1 - picks[p].y0, 60) << "pick " << p + 1 << ": stray pixels";
  }
  EXPECT_GT(curve, 30u) << "the previewed curve is not drawn\n" << out;
}

}  // namespace
}  // namespace touchmend::testing
