#pragma once

//! \file station.h
//! \brief The haptic station's non-real-time side: the session replica (network thread),
//! the client's copy of the mesh for the proxy-update thread and the viewer, hole boundaries
//! and the hole under the tool (seed 000 §3.3), fill requests on a button press, tool samples
//! streamed to the server in batches, and the other operators' cursors.
//!
//! \details Threads: the haptic thread (HapticLoop) and the proxy-update thread (ProxyUpdater)
//! run on their own; Station::run_network() is the network thread; the UI thread (viewer or
//! the headless main loop) reads view() snapshots. Connection loss: the replica reconnects
//! with backoff and resumes from its version; meanwhile the haptic loop keeps rendering the
//! last surface it has.

#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "client/haptics/proxy_updater.h"
#include "client/net/repair_client.h"

namespace touchmend::app {

using haptics::Vec3;
using rpc::Status;
using rpc::StatusCode;

//! A boundary loop of the client's mesh (a hole), in document vertex ids.
struct HoleLoop {
  std::uint32_t id = 0;  //!< smallest vertex id on the loop (the server's hole id)
  std::vector<std::uint32_t> vertices;
  Vec3 centroid = Vec3::Zero();
  //! The loop is the whole border of a separate piece of this many faces, no more than the loop
  //! has edges (a loose fragment: a fill press deletes it), or 0. The server's Hole.fragment_faces.
  std::size_t fragment_faces = 0;
};

//! Boundary loops of a surface: directed edges without their reverse, chained; each with its
//! fragment piece, if it borders one.
std::vector<HoleLoop> find_boundary_loops(const haptics::SurfaceMesh& mesh);

//! The client's copy of the document as a surface (alive faces only).
std::shared_ptr<haptics::SurfaceMesh> surface_from_document(const rpc::MeshDocument& document);

struct RemoteCursor {
  std::string principal;
  std::uint32_t client_id = 0;
  Vec3 position = Vec3::Zero();
  std::chrono::steady_clock::time_point seen;
};

//! What the UI draws, consistent as of one moment.
struct StationView {
  std::shared_ptr<const haptics::SurfaceMesh> surface;
  std::shared_ptr<const std::vector<HoleLoop>> holes;
  int highlighted = -1;  //!< index into holes, -1 none
  std::vector<RemoteCursor> cursors;
  std::string session_id;
  std::uint64_t version = 0;
  std::string status;  //!< last event worth showing (fill result, connection state)
  std::uint64_t fills = 0;
  std::string tool;          //!< "fill", "sharp-edge" or "stitch", and the tool's step
  std::vector<Vec3> picks;   //!< sharp edge: the points picked so far (1..4, in order)
  std::vector<Vec3> curve;   //!< sharp edge: the Hermite curve the server previewed
  std::vector<Vec3> guide;   //!< sharp edge: the guiding surface (3 points per triangle)
  double k1 = 0, k4 = 0;     //!< sharp edge: the previewed tangent lengths
  std::vector<Vec3> stitch;  //!< stitch: the dragged edge's two ends, then the snap candidate
  //! The session's sharp-edge preview when another client drives the tool (what its operator
  //! sees: the curve and, before confirmation, the guiding surface); empty otherwise.
  std::vector<Vec3> remote_curve, remote_guide;
  std::string remote_tool_principal;
};

//! What the button does at the station (seed 000 ch. 4's interactions).
enum class StationTool {
  Fill,       //!< press near a highlighted hole: fill it
  SharpEdge,  //!< press 4 times: P1..P4 (button 2 takes the last back) -> the server previews
              //!< the Hermite curve; drag along P2 -> P3: scale k live; click: confirm (snap
              //!< onto the guiding surface); hold and
              //!< sweep: push down (one tool sample per step); button 2: smooth, done
  Stitch,     //!< press on a boundary edge, drag to the other surface, release: one stitch
              //!< triangle to the boundary vertex nearest the tool (Algorithm VIII)
};
const char* to_string(StationTool tool);

struct StationOptions {
  std::string session_id;  //!< open this session (empty: create one and upload mesh_bytes)
  std::string mesh_bytes;  //!< the mesh to upload into a new session
  std::string mesh_name = "mesh.off";
  v1::MeshFormat mesh_format = v1::OFF;
  double highlight_distance = 0;  //!< model units; 0 = 4% of the mesh diagonal
  int samples_per_message = 10;
  std::uint32_t fill_button = 1;    //!< button mask of the main button (fill, pick, push)
  std::uint32_t second_button = 2;  //!< button mask of the second button (take back, finish)
  StationTool tool = StationTool::Fill;
  double push_step = 0;  //!< sharp edge: push distance per sample; 0 = 1/400 of the diagonal
  //! sharp edge, button 2: how the rest of the patch is shaped after the pushes
  v1::PushFinish push_finish = v1::PUSH_FINISH_FAIR;
  //! sharp edge: the curve leaves along the crease P1 (P4) lies on (default) or the chord
  v1::PickTangents tangents = v1::PICK_TANGENTS_CREASE;
};

class Station {
 public:
  Station(std::shared_ptr<net::Channel> channel, StationOptions options);
  ~Station();

  //! Creates or opens the session, downloads the mesh and subscribes.
  Status start();
  //! Connects the haptics: tool samples and state come from \p loop, surfaces go to \p updater.
  void attach(haptics::HapticLoop& loop, haptics::ProxyUpdater& updater);
  //! The network thread's body: returns when stop() is called.
  void run_network();
  void stop() { running_.store(false); }

  StationView view() const;
  const std::string& session_id() const { return options_.session_id; }
  std::uint64_t version() const { return version_.load(); }
  std::uint64_t fills_requested() const { return fills_.load(); }
  std::uint64_t samples_sent() const { return samples_sent_.load(); }
  //! Sharp-edge push samples the server accepted.
  std::uint64_t pushes() const { return pushes_done_.load(); }
  //! Sharp edge, while the curve is previewed: scale both tangent lengths by 1.1^steps (any
  //! thread; the network thread asks the server for the new preview).
  void adjust_tangents(int steps) { tangent_steps_.fetch_add(steps); }
  //! Tool samples the server acknowledged (network thread).
  std::uint64_t samples_acked() const { return samples_acked_; }
  std::size_t reconnects() const;
  //! The replica's document (network thread only, or after it stopped).
  const rpc::MeshDocument& document() const { return replica_->document(); }

 private:
  void publish_surface();
  void send_samples();
  void update_highlight(const Vec3& tool);
  void request_fill(const Vec3& tool);
  void set_status(std::string text);
  // The sharp-edge and stitch tools (network thread).
  void sharp_edge_press(const Vec3& tool);
  void sharp_edge_hold(const Vec3& tool);
  void sharp_edge_second();
  void sharp_edge_release(const Vec3& tool);
  double drag_factor(const Vec3& tool) const;
  void adjust_by_drag(const Vec3& tool);
  void apply_tangent_steps();
  void take_preview(const v1::SharpEdgeResponse& response);
  //! The guiding surface's tangent plane at the curve point nearest \p tool (the fixture).
  void constrain_to_guide(const Vec3& tool);
  void stitch_press(const Vec3& tool);
  void stitch_hold(const Vec3& tool);
  void stitch_release();
  void publish_tool_state();
  //! The boundary edge (document ids, in loop order) nearest \p tool within reach, if any.
  bool nearest_boundary_edge(const Vec3& tool, std::uint32_t& a, std::uint32_t& b) const;

  std::shared_ptr<net::Channel> channel_;
  net::RepairClient client_;
  StationOptions options_;
  std::unique_ptr<net::SessionReplica> replica_;
  std::unique_ptr<net::Stream> interact_;
  haptics::HapticLoop* loop_ = nullptr;
  haptics::ProxyUpdater* updater_ = nullptr;
  std::atomic<bool> running_{false};
  std::atomic<std::uint64_t> version_{0};
  std::atomic<std::uint64_t> fills_{0};
  std::atomic<std::uint64_t> samples_sent_{0};
  std::atomic<std::uint64_t> pushes_done_{0};
  std::atomic<int> tangent_steps_{0};
  // Network-thread state.
  std::uint64_t published_version_ = ~0ull;
  std::uint32_t previous_buttons_ = 0;
  std::uint64_t sample_seq_ = 0;
  v1::InteractionMessage batch_;
  double highlight_distance_ = 0;
  double push_step_ = 0;  //!< sharp edge: options_.push_step, or 1/400 of the diagonal
  Vec3 last_tool_ = Vec3::Zero();
  std::atomic<std::uint32_t> own_client_id_{0};  //!< from the interact acks
  std::uint64_t samples_acked_ = 0;
  enum class SharpPhase { Picking, Previewed, Snapped };
  SharpPhase sharp_phase_ = SharpPhase::Picking;
  std::vector<Vec3> picks_;
  std::vector<Vec3> curve_;
  std::vector<Vec3> guide_;  //!< the guiding surface, 3 points per triangle
  double k1_ = 0, k4_ = 0;   //!< tangent lengths of the previewed curve
  //! A press while the curve is previewed: a drag along P2 -> P3 scales k, a click confirms.
  struct KDrag {
    bool active = false;
    bool moved = false;  //!< left the dead zone: a drag, not a click
    Vec3 start = Vec3::Zero();
    double k1 = 0, k4 = 0;  //!< k at the press
    double sent_factor = 1;
  } k_drag_;
  //! Drag distance (in chords |P3 - P2|) that doubles k, and the dead zone of a click.
  static constexpr double kDragDoublingChords = 0.25;
  static constexpr double kDragDeadZoneChords = 0.04;
  Vec3 guide_normal_ = Vec3::UnitZ();  //!< the guiding surface's extrusion direction
  Vec3 last_push_ = Vec3::Zero();
  std::uint64_t pushes_ = 0;
  bool stitching_ = false;
  std::uint32_t stitch_a_ = 0, stitch_b_ = 0;
  std::int64_t stitch_target_ = -1;
  Vec3 stitch_target_position_ = Vec3::Zero();
  // Shared with the UI thread.
  mutable std::mutex mutex_;
  StationView view_;
  std::map<std::uint32_t, RemoteCursor> cursors_;
};

//! Loop options for a model in a device's workspace: the model scaled into the workspace, the
//! proxy kept a millionth of the model's size off the surface; the rest are the defaults.
haptics::HapticLoopOptions loop_options_for(const Eigen::AlignedBox3d& model,
                                            const Eigen::AlignedBox3d& device_workspace);
//! The model's bounding box (alive and dead slots alike: dead ones were part of it).
Eigen::AlignedBox3d bounds_of(const rpc::MeshDocument& document);

//! The running station: the haptic loop and proxy updater on a device, wired to a Station,
//! and the network thread. start() and stop() keep the order that is safe for the device
//! (forces only once everything feeds the loop; zero before the device closes).
class StationRuntime {
 public:
  StationRuntime(Station& station, device::SafetyFilter& device,
                 haptics::HapticLoopOptions options);
  ~StationRuntime();
  //! Starts the proxy updater, the haptic loop and the network thread, then arms the device.
  void start();
  //! Stops the network thread, the loop (zero force) and the updater. Safe to call twice.
  void stop();
  haptics::HapticLoop& loop() { return loop_; }
  haptics::ProxyUpdater& updater() { return updater_; }

 private:
  Station& station_;
  device::SafetyFilter& device_;
  haptics::ProxyPatchExchange patches_;
  haptics::HapticLoop loop_;
  haptics::ProxyUpdater updater_;
  std::thread network_;
  bool started_ = false;
};

}  // namespace touchmend::app
