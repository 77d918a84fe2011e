// touchmend-client: the haptic station (DESIGN.md). Feel the model through the device, see
// holes light up as the tool comes near, press the button to have the server fill the hole.

#include <atomic>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <thread>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "client/app/station.h"
#include "client/view/viewer.h"
#include "device/device_factory.h"

using namespace touchmend;
using namespace std::chrono_literals;
using rpc::Status;

namespace {

std::atomic<bool> g_interrupted{false};

struct Args {
  std::string server = "127.0.0.1:7878";
  std::string token;
  std::string tls_ca;
  bool tls = false;
  std::string session;
  std::string mesh;
  std::string device = "sim";
  bool list_devices = false;
  bool headless = false;
  double duration = 0;
  std::string screenshot;
  std::string record;
  double rate = 1000;
  double stiffness = 800;
  double damping = 2;
  double friction = 0;
  double force_cap = 0;
  bool no_realtime = false;
  std::string falcon_firmware;
  double falcon_gain = 1800;
  bool stats = false;
  int exit_after_fills = 0;
  std::string tool = "fill";
  double push_step = 0;
  std::string finish = "fair";
  std::string tangents = "crease";
};

v1::MeshFormat format_of(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".stl" || ext == ".STL") return v1::STL;
  if (ext == ".obj" || ext == ".OBJ") return v1::OBJ;
  if (ext == ".ply" || ext == ".PLY") return v1::PLY;
  return v1::OFF;
}

std::string default_mesh() {
  for (const char* candidate : {TOUCHMEND_SAMPLE_MESH, "deploy/samples/spot-holed.off"})
    if (std::filesystem::exists(candidate)) return candidate;
  return {};
}

view::Scene make_scene(const app::StationView& v, const haptics::ToolState& tool) {
  view::Scene scene;
  scene.surface = v.surface;
  if (v.holes)
    for (const auto& h : *v.holes) scene.boundaries.push_back(h.vertices);
  scene.highlighted = v.highlighted;
  if (tool.device_ok) {
    scene.cursors.push_back({tool.device_position, {1.0f, 1.0f, 1.0f}, 8});
    scene.cursors.push_back(
        {tool.proxy,
         tool.in_contact ? Eigen::Vector3f(0.2f, 1.0f, 0.4f) : Eigen::Vector3f(0.3f, 0.8f, 1.0f),
         14});
  }
  for (const auto& c : v.cursors) scene.cursors.push_back({c.position, {1.0f, 0.3f, 1.0f}, 14});
  // Sharp-edge picks, numbered and coloured by number (P1 red, P2 orange, P3 green, P4 blue), the
  // previewed curve in cyan; the stitch being dragged in white, its snap candidate in yellow.
  const Eigen::Vector3f pick_colours[4] = {
      {1.0f, 0.2f, 0.2f}, {1.0f, 0.6f, 0.1f}, {0.2f, 0.9f, 0.3f}, {0.3f, 0.5f, 1.0f}};
  for (std::size_t i = 0; i < v.picks.size() && i < 4; ++i) {
    scene.cursors.push_back({v.picks[i], pick_colours[i], 16});
    scene.labels.push_back({v.picks[i], std::to_string(i + 1), pick_colours[i], 22});
  }
  if (v.curve.size() >= 2) scene.polylines.push_back({v.curve, {0.2f, 1.0f, 1.0f}});
  // The guiding surface being previewed: its bottom and top lines and rungs, dimmer.
  for (std::size_t i = 0; i + 2 < v.guide.size(); i += 3) {
    const std::size_t triangle = i / 3;
    if (triangle % 2 == 0) {  // (bottom k, bottom k+1, top k+1)
      scene.polylines.push_back({{v.guide[i], v.guide[i + 1], v.guide[i + 2]}, {0.1f, 0.5f, 0.5f}});
    } else {  // (bottom k, top k+1, top k)
      scene.polylines.push_back({{v.guide[i + 1], v.guide[i + 2], v.guide[i]}, {0.1f, 0.5f, 0.5f}});
    }
  }
  // Another operator's sharp-edge preview, in the remote cursors' magenta.
  if (v.remote_curve.size() >= 2) scene.polylines.push_back({v.remote_curve, {1.0f, 0.3f, 1.0f}});
  for (std::size_t i = 0; i + 2 < v.remote_guide.size(); i += 3)
    scene.polylines.push_back(
        {{v.remote_guide[i], v.remote_guide[i + 1], v.remote_guide[i + 2], v.remote_guide[i]},
         {0.5f, 0.15f, 0.5f}});
  if (v.stitch.size() >= 2) {
    scene.polylines.push_back({{v.stitch[0], v.stitch[1]}, {1.0f, 1.0f, 1.0f}});
    if (v.stitch.size() == 3) {
      scene.polylines.push_back({{v.stitch[0], v.stitch[2], v.stitch[1]}, {1.0f, 0.9f, 0.2f}});
      scene.cursors.push_back({v.stitch[2], {1.0f, 0.9f, 0.2f}, 16});
    }
  }
  return scene;
}

//! The status line's note on the highlighted hole: a loose fragment's outline says that a fill
//! press deletes the fragment instead.
std::string hole_under_tool(const app::HoleLoop& hole) {
  if (hole.fragment_faces == 0) return fmt::format(" (hole {} under the tool)", hole.id);
  return fmt::format(
      " (hole {} under the tool: the outline of a loose fragment of {} face{}, a fill press "
      "deletes it)",
      hole.id, hole.fragment_faces, hole.fragment_faces == 1 ? "" : "s");
}

std::string status_line(const app::StationView& v, const haptics::HapticLoop& loop,
                        const device::SafetyFilter& safe) {
  const haptics::LoopStats s = loop.stats();
  return fmt::format(
      "session {} v{} | {} | {} holes{} | loop {} ticks, period error p99 {:.0f} us | {} | {}",
      v.session_id, v.version, v.tool, v.holes ? v.holes->size() : 0,
      v.highlighted >= 0 ? hole_under_tool((*v.holes)[std::size_t(v.highlighted)]) : "", s.ticks,
      loop.period_error().percentile_us(0.99), device::to_string(safe.arm_state()), v.status);
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  CLI::App cli{
      "touchmend-client: the haptic station. Feel the mesh of a repair session through a haptic\n"
      "device (or a simulated or replayed one), see the hole under the tool highlighted, and "
      "press\n"
      "button 1 (space in the viewer) to have the server fill it. Without --session it creates a\n"
      "session and uploads --mesh (default: the bundled sample). Sim device in the viewer: arrows\n"
      "and W/S move the stylus, space is the button, F turns forces off and on, the mouse\n"
      "orbits, the wheel zooms.\n\n"
      "Exit codes: 0 done, 1 device or window problem, 2 usage, 4 server problem."};
  cli.add_option("--server", a.server, "touchmend-server address HOST:PORT")->capture_default_str();
  cli.add_option("--token", a.token, "Bearer token (default: $TOUCHMEND_TOKEN)");
  cli.add_option("--tls-ca", a.tls_ca, "Connect with TLS, verifying the server with this CA file");
  cli.add_flag("--tls", a.tls, "Connect with TLS, verifying with the system's CAs");
  cli.add_option("--session", a.session, "Join this session (others may be working in it)");
  cli.add_option("--mesh", a.mesh, "Create a session with this mesh (STL, OBJ, OFF, PLY)");
  cli.add_option("--device", a.device, "sim | replay:FILE | falcon[:INDEX]")->capture_default_str();
  cli.add_flag("--list-devices", a.list_devices, "List the devices and exit");
  cli.add_flag("--headless", a.headless, "No window (a simulated or replayed device)");
  cli.add_option("--duration", a.duration,
                 "Stop after this many seconds (0: until the replay ends or Ctrl-C)");
  cli.add_option("--screenshot", a.screenshot,
                 "Save the last frame as PNG when stopping (works under Xvfb)");
  cli.add_option("--record", a.record,
                 "Record the device's trajectory to FILE (replay it with --device replay:FILE)");
  cli.add_option(
         "--tool", a.tool,
         "What the button does. fill: press near a highlighted hole to fill it (on the\n"
         "outline of a loose fragment, a lone triangle or debris, the fragment is deleted;\n"
         "the status line says so while the tool is on such an outline).\n"
         "sharp-edge: press at four points along a crease around a filled hole (P1, P2\n"
         "on one side, P2 nearest the hole; P3, P4 on the other; button 2 takes the last\n"
         "back), the server previews the Hermite curve and the guiding surface; press\n"
         "and drag along the curve (P2 towards P3) to make both tangents longer, back to\n"
         "make them shorter, live (K / J: 10% longer / shorter); click to confirm it (the\n"
         "patch snaps onto the guiding surface); hold and sweep to push the patch down to the\n"
         "curve (the tool is held to the guiding surface); button 2 shapes the rest of the\n"
         "patch (--finish) and finishes (seed 000 §4.2). Keyboard stylus: space = button 1,\n"
         "B = button 2.\n"
         "stitch: press on a boundary edge, drag to the other surface (the nearest\n"
         "boundary vertex lights up), release: one stitch triangle (Algorithm VIII)")
      ->check(CLI::IsMember({"fill", "sharp-edge", "stitch"}))
      ->capture_default_str();
  cli.add_option("--finish", a.finish,
                 "sharp-edge, button 2: fair (each side of the curve faired with the curve\n"
                 "held), smooth (the thesis' normal propagation, Algorithm VII) or none")
      ->check(CLI::IsMember({"fair", "smooth", "none"}))
      ->capture_default_str();
  cli.add_option("--tangents", a.tangents,
                 "sharp-edge: where the curve's end directions come from. crease: where P1 (P4)\n"
                 "lies on a crease reaching the hole at P2 (P3), along that crease (a shaky\n"
                 "pick does not tilt the curve); chord: unit(P2-P1), unit(P4-P3) as the thesis")
      ->check(CLI::IsMember({"crease", "chord"}))
      ->capture_default_str();
  cli.add_option("--push-step", a.push_step,
                 "sharp-edge: push distance per tool step, model units (0 = 1/400 of the "
                 "model's diagonal)")
      ->check(CLI::NonNegativeNumber);
  cli.add_option("--rate", a.rate, "Haptic loop rate in Hz (100-4000)")
      ->check(CLI::Range(100.0, 4000.0))
      ->capture_default_str();
  cli.add_option("--stiffness", a.stiffness, "Contact stiffness, N/m (capped by the device)")
      ->capture_default_str();
  cli.add_option("--damping", a.damping, "Contact damping, N*s/m (capped by the device)")
      ->capture_default_str();
  cli.add_option("--friction", a.friction, "Static friction coefficient")->capture_default_str();
  cli.add_option("--force-cap", a.force_cap, "Force limit in N (0: the device's maximum)");
  cli.add_flag(
      "--no-realtime", a.no_realtime,
      "Do not ask for SCHED_FIFO and locked memory for the haptic thread (asked by default; "
      "refused without the privilege, which the startup line says)");
  cli.add_option("--falcon-firmware", a.falcon_firmware,
                 "Falcon firmware file to load if the device runs none (never shipped)");
  cli.add_option("--falcon-gain", a.falcon_gain, "Falcon motor counts per N*m (uncalibrated)")
      ->capture_default_str();
  cli.add_flag("--stats", a.stats, "Print the loop statistics every second");
  cli.add_option("--exit-after-fills", a.exit_after_fills,
                 "Stop after this many fill requests (scripts, tests)");
  CLI11_PARSE(cli, argc, argv);

  if (a.list_devices) {
    std::string notes;
    for (const auto& d : device::list_devices(notes))
      std::cout << fmt::format("{:<14} {}\n", d.spec, d.description);
    if (!notes.empty()) std::cout << "note: " << notes << "\n";
    return 0;
  }
  device::DeviceSpec spec;
  if (device::DeviceStatus s = device::parse_device_spec(a.device, spec); !s.ok) {
    std::cerr << "touchmend-client: " << s.message << "\n";
    return 2;
  }
  device::DeviceOptions device_options;
  device_options.falcon.firmware_file = a.falcon_firmware;
  device_options.falcon.gain = a.falcon_gain;
  std::unique_ptr<device::HapticDevice> raw;
  if (device::DeviceStatus s = device::make_device(spec, device_options, raw); !s.ok) {
    std::cerr << "touchmend-client: " << s.message << "\n";
    return 1;
  }
  std::unique_ptr<device::RecordingDevice> recorder;
  device::HapticDevice* chain = raw.get();
  if (!a.record.empty()) {
    recorder = std::make_unique<device::RecordingDevice>(*raw, a.record);
    chain = recorder.get();
  }
  device::SafetyOptions safety;
  safety.force_cap = a.force_cap;
  device::SafetyFilter safe(*chain, safety);
  if (device::DeviceStatus s = safe.open(); !s.ok) {
    std::cerr << "touchmend-client: " << raw->info().name << ": " << s.message << "\n";
    return 1;
  }

  // The server and the session.
  net::ChannelOptions channel_options;
  std::string error;
  if (!net::parse_server_address(a.server, channel_options, error)) {
    std::cerr << "touchmend-client: " << error << "\n";
    return 2;
  }
  if (a.token.empty())
    if (const char* t = std::getenv("TOUCHMEND_TOKEN")) a.token = t;
  channel_options.token = a.token;
  channel_options.tls = a.tls || !a.tls_ca.empty();
  channel_options.tls_ca = a.tls_ca;
  Status status;
  auto channel = net::Channel::connect(channel_options, status);
  if (!channel) {
    std::cerr << "touchmend-client: cannot reach " << a.server << ": " << status.to_string()
              << "\n";
    safe.close();
    return 4;
  }
  app::StationOptions station_options;
  station_options.session_id = a.session;
  station_options.tool = a.tool == "sharp-edge" ? app::StationTool::SharpEdge
                         : a.tool == "stitch"   ? app::StationTool::Stitch
                                                : app::StationTool::Fill;
  station_options.push_step = a.push_step;
  station_options.push_finish = a.finish == "smooth" ? v1::PUSH_FINISH_SMOOTH
                                : a.finish == "none" ? v1::PUSH_FINISH_NONE
                                                     : v1::PUSH_FINISH_FAIR;
  station_options.tangents =
      a.tangents == "chord" ? v1::PICK_TANGENTS_CHORD : v1::PICK_TANGENTS_CREASE;
  if (a.session.empty()) {
    const std::string mesh = a.mesh.empty() ? default_mesh() : a.mesh;
    std::ifstream in(mesh, std::ios::binary);
    if (mesh.empty() || !in) {
      std::cerr << "touchmend-client: cannot read the mesh '" << mesh << "'\n";
      safe.close();
      return 1;
    }
    station_options.mesh_bytes.assign(std::istreambuf_iterator<char>(in), {});
    station_options.mesh_name = std::filesystem::path(mesh).filename().string();
    station_options.mesh_format = format_of(mesh);
  }
  app::Station station(channel, station_options);
  if (Status s = station.start(); !s.is_ok()) {
    std::cerr << "touchmend-client: " << s.to_string() << "\n";
    safe.close();
    return 4;
  }
  std::cout << "session " << station.session_id() << " on " << a.server << " with "
            << raw->info().name << "\n";

  // Haptics: the workspace fits the model into the device's reach.
  haptics::HapticLoopOptions loop_options =
      app::loop_options_for(app::bounds_of(station.document()), raw->info().workspace);
  loop_options.rate_hz = a.rate;
  loop_options.stiffness = a.stiffness;
  loop_options.damping = a.damping;
  loop_options.contact.friction = a.friction;
  loop_options.realtime = !a.no_realtime;
  app::StationRuntime runtime(station, safe, loop_options);
  haptics::HapticLoop& loop = runtime.loop();
  runtime.start();
  std::signal(SIGINT, [](int) { g_interrupted = true; });
  std::signal(SIGTERM, [](int) { g_interrupted = true; });
  std::cout << "haptic loop: " << loop.stats().realtime_note << "\n";

  std::unique_ptr<view::Viewer> viewer;
  int code = 0;
  if (!a.headless || !a.screenshot.empty()) {
    view::ViewerOptions vo;
    vo.visible = !a.headless;
    vo.keep_frames = !a.screenshot.empty();
    vo.title = "touchmend — " + station.session_id();
    viewer = std::make_unique<view::Viewer>(vo);
    if (!viewer->open(error)) {
      std::cerr << "touchmend-client: " << error << "\n";
      viewer.reset();
      code = 1;
      g_interrupted = true;
    } else {
      std::cout << "viewer: OpenGL " << viewer->gl_version() << "\n";
    }
  }
  auto* sim = dynamic_cast<device::SimulatedDevice*>(raw.get());
  auto* replay = dynamic_cast<device::ReplayDevice*>(raw.get());
  const Eigen::Vector3d sim_home = raw->info().workspace.center();
  const auto started = std::chrono::steady_clock::now();
  auto last_stats = started;
  std::chrono::steady_clock::time_point replay_done{};
  int tangent_steps_seen = 0;
  while (!g_interrupted) {
    const auto now = std::chrono::steady_clock::now();
    const app::StationView v = station.view();
    auto& ui = loop.ui_state();
    ui.update();
    if (viewer) {
      view::Scene scene = make_scene(v, ui.front());
      scene.status = status_line(v, loop, safe);
      viewer->draw(scene);
      if (!viewer->should_close() && viewer->input().quit) break;
      if (viewer->should_close()) break;
      if (sim)
        sim->set_target(sim_home + viewer->input().target_offset,
                        (viewer->input().button ? 1u : 0u) | (viewer->input().button2 ? 2u : 0u));
      if (viewer->input().forces_off) safe.disarm();
      if (viewer->input().tangent_steps != tangent_steps_seen) {
        station.adjust_tangents(viewer->input().tangent_steps - tangent_steps_seen);
        tangent_steps_seen = viewer->input().tangent_steps;
      }
    }
    // Forces stay requested (unless the operator turned them off): after a homing loss or a
    // cleared fault the safety filter's gate re-arms only once the device is homed, at rest
    // and asked for almost no force, then ramps in.
    if ((!viewer || !viewer->input().forces_off) && safe.arm_state() == device::ArmState::Disarmed)
      safe.arm();
    if (!viewer) std::this_thread::sleep_for(16ms);
    if (a.stats && now - last_stats >= 1s) {
      last_stats = now;
      std::cout << status_line(v, loop, safe) << "\n";
    }
    if (a.duration > 0 && now - started >= std::chrono::duration<double>(a.duration)) break;
    if (a.exit_after_fills > 0 && station.fills_requested() >= std::uint64_t(a.exit_after_fills) &&
        v.fills >= std::uint64_t(a.exit_after_fills) && v.status.rfind("fill", 0) == 0)
      break;
    if (replay && replay->finished()) {
      if (replay_done == std::chrono::steady_clock::time_point{}) replay_done = now;
      if (a.duration <= 0 && now - replay_done > 1s) break;  // let the last fill land
    }
  }
  if (viewer && !a.screenshot.empty()) {
    if (!viewer->screenshot(a.screenshot, error)) {
      std::cerr << "touchmend-client: screenshot: " << error << "\n";
      code = 1;
    } else {
      std::cout << "screenshot " << a.screenshot << "\n";
    }
  }
  runtime.stop();
  safe.close();
  const app::StationView v = station.view();
  std::cout << status_line(v, loop, safe) << "\n";
  const haptics::LoopStats s = loop.stats();
  std::cout << fmt::format(
      "loop: {} ticks at {} Hz; period error p50 {:.0f} / p99 {:.0f} / p99.9 {:.0f} / max {:.0f} "
      "us; compute p99 {:.0f} us; "
      "{} overruns; {}\n",
      s.ticks, a.rate, loop.period_error().percentile_us(0.5),
      loop.period_error().percentile_us(0.99), loop.period_error().percentile_us(0.999),
      loop.period_error().max_us(), loop.compute_time().percentile_us(0.99), s.overruns,
      s.realtime_note);
  if (recorder) {
    if (recorder->recorded() == 0)
      std::cerr << "touchmend-client: nothing was recorded\n";
    else
      std::cout << "recorded " << recorder->recorded() << " samples to " << a.record << "\n";
  }
  return code;
}
