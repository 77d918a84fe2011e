#include "client/app/station.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <unordered_set>

#include <fmt/format.h>

namespace touchmend::app {
namespace {

double distance_to_segment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

Vec3 closest_on_segment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return a + t * ab;
}

//! Key of the directed edge a -> b.
std::uint64_t directed_key(std::uint32_t a, std::uint32_t b) {
  return (std::uint64_t(a) << 32) | b;
}

//! The faces of the piece the loop \p loop borders, if the loop is that piece's whole border and
//! the piece has no more faces than the loop has edges (as the server's fragment_piece), else 0.
//! \p directed: each directed triangle edge (key a << 32 | b) to its triangle.
std::size_t fragment_faces(const haptics::SurfaceMesh& mesh,
                           const std::unordered_map<std::uint64_t, std::uint32_t>& directed,
                           const std::vector<std::uint32_t>& loop) {
  const std::size_t limit = loop.size();
  std::unordered_set<std::uint32_t> piece;
  std::vector<std::uint32_t> stack;
  for (std::size_t i = 0; i < loop.size(); ++i) {
    // The loop runs v_i -> v_i+1 along the reversed boundary edge (v_i+1, v_i) of a triangle.
    const auto it = directed.find(directed_key(loop[(i + 1) % loop.size()], loop[i]));
    if (it != directed.end() && piece.insert(it->second).second) stack.push_back(it->second);
  }
  std::size_t border = 0;
  while (!stack.empty()) {
    if (piece.size() > limit) return 0;
    const auto& t = mesh.triangles[stack.back()];
    stack.pop_back();
    for (int k = 0; k < 3; ++k) {
      const auto twin = directed.find(directed_key(t[(k + 1) % 3], t[k]));
      if (twin == directed.end())
        ++border;
      else if (piece.insert(twin->second).second)
        stack.push_back(twin->second);
    }
  }
  return piece.size() <= limit && border == loop.size() ? piece.size() : 0;
}

}  // namespace

std::vector<HoleLoop> find_boundary_loops(const haptics::SurfaceMesh& mesh) {
  // Directed edges of all triangles, each with its triangle; a boundary edge (a, b) has no twin
  // (b, a). The hole runs along the reversed boundary edges.
  std::unordered_map<std::uint64_t, std::uint32_t> directed;
  directed.reserve(mesh.triangles.size() * 3);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    for (int k = 0; k < 3; ++k)
      directed.emplace(directed_key(t[k], t[(k + 1) % 3]), std::uint32_t(f));
  }
  std::unordered_multimap<std::uint32_t, std::uint32_t> next;  // along the hole: b -> a
  for (const auto& [k, face] : directed) {
    const auto a = static_cast<std::uint32_t>(k >> 32), b = static_cast<std::uint32_t>(k);
    if (!directed.contains(directed_key(b, a))) next.emplace(b, a);
  }
  std::vector<HoleLoop> loops;
  while (!next.empty()) {
    HoleLoop loop;
    auto it = next.begin();
    const std::uint32_t start = it->first;
    std::uint32_t v = start;
    for (std::size_t guard = 0; guard <= mesh.positions.size(); ++guard) {
      it = next.find(v);
      if (it == next.end()) break;
      loop.vertices.push_back(v);
      const std::uint32_t w = it->second;
      next.erase(it);
      v = w;
      if (v == start) break;
    }
    if (loop.vertices.size() < 3) continue;
    loop.id = *std::min_element(loop.vertices.begin(), loop.vertices.end());
    for (const auto u : loop.vertices) loop.centroid += mesh.positions[u];
    loop.centroid /= double(loop.vertices.size());
    loop.fragment_faces = fragment_faces(mesh, directed, loop.vertices);
    loops.push_back(std::move(loop));
  }
  std::sort(loops.begin(), loops.end(),
            [](const HoleLoop& a, const HoleLoop& b) { return a.id < b.id; });
  return loops;
}

std::shared_ptr<haptics::SurfaceMesh> surface_from_document(const rpc::MeshDocument& document) {
  auto s = std::make_shared<haptics::SurfaceMesh>();
  s->version = document.version;
  s->positions.reserve(document.positions.size());
  for (const auto& p : document.positions) s->positions.emplace_back(p[0], p[1], p[2]);
  for (std::size_t f = 0; f < document.faces.size(); ++f) {
    if (!document.face_alive[f]) continue;
    s->triangles.push_back(document.faces[f]);
    s->face_ids.push_back(static_cast<std::uint32_t>(f));
  }
  return s;
}

Station::Station(std::shared_ptr<net::Channel> channel, StationOptions options)
    : channel_(std::move(channel)), client_(channel_), options_(std::move(options)) {}

Station::~Station() {
  stop();
}

std::size_t Station::reconnects() const {
  return replica_ ? replica_->reconnects() : 0;
}

void Station::set_status(std::string text) {
  std::lock_guard lock(mutex_);
  view_.status = std::move(text);
}

Status Station::start() {
  if (options_.session_id.empty()) {
    v1::SessionInfo info;
    if (Status s = client_.create_session("haptic station", info); !s.is_ok()) return s;
    options_.session_id = info.session_id();
    v1::LoadMeshResponse loaded;
    if (Status s = client_.upload_mesh(options_.session_id, options_.mesh_bytes,
                                       options_.mesh_format, options_.mesh_name, loaded);
        !s.is_ok())
      return s;
  } else {
    v1::SessionInfo info;
    if (Status s = client_.open_session(options_.session_id, info); !s.is_ok()) return s;
  }
  replica_ = std::make_unique<net::SessionReplica>(client_, options_.session_id);
  replica_->on_presence = [this](const v1::Presence& p) {
    if (p.client_id() == 0 && p.principal().empty()) return;
    const std::uint32_t own = own_client_id_.load();
    if (own != 0 && p.client_id() == own) return;  // our own tool: drawn from the local state
    RemoteCursor c;
    c.principal = p.principal();
    c.client_id = p.client_id();
    c.position = Vec3(p.tool_position().x(), p.tool_position().y(), p.tool_position().z());
    c.seen = std::chrono::steady_clock::now();
    std::lock_guard lock(mutex_);
    cursors_[p.client_id()] = c;
  };
  replica_->on_tool_preview = [this](const v1::ToolPreview& t) {
    const auto points = [](const auto& wire_points) {
      std::vector<Vec3> out;
      out.reserve(static_cast<std::size_t>(wire_points.size()));
      for (const auto& p : wire_points) out.emplace_back(p.x(), p.y(), p.z());
      return out;
    };
    std::lock_guard lock(mutex_);
    view_.remote_curve = t.active() ? points(t.curve()) : std::vector<Vec3>{};
    view_.remote_guide = t.active() ? points(t.guide()) : std::vector<Vec3>{};
    view_.remote_tool_principal = t.active() ? t.principal() : std::string{};
  };
  if (Status s = replica_->start(); !s.is_ok()) return s;
  interact_ = client_.interact();
  batch_.set_session_id(options_.session_id);
  publish_surface();
  {
    std::lock_guard lock(mutex_);
    view_.session_id = options_.session_id;
  }
  publish_tool_state();
  return {};
}

void Station::attach(haptics::HapticLoop& loop, haptics::ProxyUpdater& updater) {
  loop_ = &loop;
  updater_ = &updater;
  std::shared_ptr<const haptics::SurfaceMesh> surface;
  {
    std::lock_guard lock(mutex_);
    surface = view_.surface;
  }
  if (surface) updater_->set_surface(surface);
}

void Station::publish_surface() {
  const rpc::MeshDocument& doc = replica_->document();
  if (doc.version == published_version_) return;
  published_version_ = doc.version;
  std::shared_ptr<const haptics::SurfaceMesh> surface = surface_from_document(doc);
  auto holes = std::make_shared<const std::vector<HoleLoop>>(find_boundary_loops(*surface));
  if (highlight_distance_ <= 0) {
    // Scales from the first surface: the highlight reach and the push-down step.
    Eigen::AlignedBox3d box;
    for (const auto& p : surface->positions) box.extend(p);
    const double diagonal = box.isEmpty() ? 1.0 : box.diagonal().norm();
    highlight_distance_ =
        options_.highlight_distance > 0 ? options_.highlight_distance : 0.04 * diagonal;
    push_step_ = options_.push_step > 0 ? options_.push_step : diagonal / 400;
  }
  {
    std::lock_guard lock(mutex_);
    view_.surface = surface;
    view_.holes = holes;
    view_.highlighted = -1;
    view_.version = doc.version;
  }
  version_.store(doc.version);
  if (updater_) updater_->set_surface(surface);
}

void Station::update_highlight(const Vec3& tool) {
  std::shared_ptr<const haptics::SurfaceMesh> surface;
  std::shared_ptr<const std::vector<HoleLoop>> holes;
  {
    std::lock_guard lock(mutex_);
    surface = view_.surface;
    holes = view_.holes;
  }
  int best = -1;
  double best_distance = highlight_distance_;
  if (surface && holes) {
    for (std::size_t h = 0; h < holes->size(); ++h) {
      const auto& loop = (*holes)[h].vertices;
      for (std::size_t i = 0; i < loop.size(); ++i) {
        const double d = distance_to_segment(tool, surface->positions[loop[i]],
                                             surface->positions[loop[(i + 1) % loop.size()]]);
        if (d < best_distance) {
          best_distance = d;
          best = static_cast<int>(h);
        }
      }
    }
  }
  std::lock_guard lock(mutex_);
  view_.highlighted = best;
}

void Station::request_fill(const Vec3& tool) {
  std::shared_ptr<const haptics::SurfaceMesh> surface;
  std::shared_ptr<const std::vector<HoleLoop>> holes;
  int highlighted = -1;
  {
    std::lock_guard lock(mutex_);
    surface = view_.surface;
    holes = view_.holes;
    highlighted = view_.highlighted;
  }
  if (highlighted < 0 || !surface || !holes) {
    set_status("no hole under the tool: move within reach of a highlighted boundary");
    return;
  }
  // The point on the highlighted boundary nearest the tool: the server fills the hole
  // nearest to it, which is this one.
  const auto& loop = (*holes)[static_cast<std::size_t>(highlighted)].vertices;
  Vec3 on_boundary = surface->positions[loop[0]];
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < loop.size(); ++i) {
    const Vec3 q = closest_on_segment(tool, surface->positions[loop[i]],
                                      surface->positions[loop[(i + 1) % loop.size()]]);
    if ((q - tool).norm() < best) {
      best = (q - tool).norm();
      on_boundary = q;
    }
  }
  v1::FillHolesRequest request;
  request.set_session_id(options_.session_id);
  request.mutable_selection()->mutable_near()->set_x(on_boundary.x());
  request.mutable_selection()->mutable_near()->set_y(on_boundary.y());
  request.mutable_selection()->mutable_near()->set_z(on_boundary.z());
  // A press on the outline of a loose fragment (a lone triangle, debris) closes it the only way
  // it can be closed: the piece is deleted. The operator chose that loop; undo brings it back.
  request.mutable_options()->set_remove_fragments(true);
  fills_.fetch_add(1);
  v1::EditResponse response;
  const Status s = client_.fill_holes(request, response);
  if (!s.is_ok()) {
    set_status("fill failed: " + s.to_string());
    return;
  }
  std::string text = "fill:";
  for (const auto& h : response.report().holes())
    text += fmt::format(
        " hole {} {}", h.hole_id(),
        h.filled() ? fmt::format("filled ({} faces, {})", h.faces_added(), h.shape())
        : h.fragment_faces_removed() > 0
            ? fmt::format("removed: a fragment of {} face{}", h.fragment_faces_removed(),
                          h.fragment_faces_removed() == 1 ? "" : "s")
            : "left open: " + h.reason());
  set_status(text);
}

void Station::send_samples() {
  if (!loop_ || !interact_) return;
  haptics::ToolSampleOut sample;
  while (loop_->samples().pop(sample)) {
    // Button edges against the previous sample.
    const bool held = (sample.buttons & options_.fill_button) != 0;
    const bool was_held = (previous_buttons_ & options_.fill_button) != 0;
    const bool pressed = held && !was_held;
    const bool released = !held && was_held;
    const bool second = (sample.buttons & options_.second_button) != 0 &&
                        (previous_buttons_ & options_.second_button) == 0;
    previous_buttons_ = sample.buttons;
    last_tool_ = sample.proxy;
    auto* t = batch_.mutable_tools()->add_samples();
    t->set_seq(++sample_seq_);
    t->set_time_us(sample.time_ns / 1000);
    t->mutable_position()->set_x(sample.proxy.x());
    t->mutable_position()->set_y(sample.proxy.y());
    t->mutable_position()->set_z(sample.proxy.z());
    t->set_buttons(sample.buttons);
    if (batch_.tools().samples_size() >= options_.samples_per_message) {
      interact_->send(batch_);
      samples_sent_.fetch_add(static_cast<std::uint64_t>(batch_.tools().samples_size()));
      batch_.mutable_tools()->clear_samples();
    }
    switch (options_.tool) {
      case StationTool::Fill:
        if (pressed) {
          update_highlight(sample.proxy);
          request_fill(sample.proxy);
        }
        break;
      case StationTool::SharpEdge:
        if (pressed)
          sharp_edge_press(sample.proxy);
        else if (held)
          sharp_edge_hold(sample.proxy);
        else if (released)
          sharp_edge_release(sample.proxy);
        if (second) sharp_edge_second();
        break;
      case StationTool::Stitch:
        if (pressed)
          stitch_press(sample.proxy);
        else if (held)
          stitch_hold(sample.proxy);
        else if (released)
          stitch_release();
        break;
    }
  }
}

const char* to_string(StationTool tool) {
  switch (tool) {
    case StationTool::Fill:
      return "fill";
    case StationTool::SharpEdge:
      return "sharp-edge";
    case StationTool::Stitch:
      return "stitch";
  }
  return "?";
}

namespace {

v1::Point3 wire(const Vec3& p) {
  v1::Point3 q;
  q.set_x(p.x());
  q.set_y(p.y());
  q.set_z(p.z());
  return q;
}

}  // namespace

void Station::publish_tool_state() {
  std::string phase;
  if (options_.tool == StationTool::SharpEdge) {
    switch (sharp_phase_) {
      case SharpPhase::Picking:
        phase = fmt::format(": pick P{} of 4", picks_.size() + 1);
        break;
      case SharpPhase::Previewed:
        phase = ": click to confirm the curve, drag along it to change k";
        break;
      case SharpPhase::Snapped:
        phase = fmt::format(": sweep to push down ({} pushes), button 2 to smooth", pushes_);
        break;
    }
  }
  std::lock_guard lock(mutex_);
  view_.tool = to_string(options_.tool) + phase;
  view_.picks = picks_;
  view_.curve = curve_;
  view_.guide = sharp_phase_ == SharpPhase::Previewed ? guide_ : std::vector<Vec3>{};
  view_.k1 = k1_;
  view_.k4 = k4_;
  view_.stitch.clear();
  if (stitching_) {
    const auto& s = view_.surface;
    if (s && stitch_a_ < s->positions.size() && stitch_b_ < s->positions.size()) {
      view_.stitch.push_back(s->positions[stitch_a_]);
      view_.stitch.push_back(s->positions[stitch_b_]);
      if (stitch_target_ >= 0) view_.stitch.push_back(stitch_target_position_);
    }
  }
}

void Station::sharp_edge_press(const Vec3& tool) {
  v1::SharpEdgeRequest request;
  request.set_session_id(options_.session_id);
  v1::SharpEdgeResponse response;
  if (sharp_phase_ == SharpPhase::Picking) {
    k_drag_.active = false;  // the press that previews the curve is not a drag on it
    picks_.push_back(tool);
    if (picks_.size() == 4) {
      for (const Vec3& p : picks_) *request.mutable_begin()->add_points() = wire(p);
      request.mutable_begin()->set_tangents(options_.tangents);
      const Status s = client_.sharp_edge(request, response);
      if (!s.is_ok()) {
        set_status("sharp edge: " + s.to_string() + " (pick again)");
        picks_.clear();
      } else {
        take_preview(response);
        sharp_phase_ = SharpPhase::Previewed;
        const auto end = [](bool crease) { return crease ? "crease" : "chord"; };
        set_status(
            fmt::format("sharp edge: curve through the patch of {} faces (tangents: {} at "
                        "P2, {} at P3); click to confirm, drag to change k",
                        response.patch_faces(), end(response.crease_tangent_start()),
                        end(response.crease_tangent_end())));
      }
    }
  } else if (sharp_phase_ == SharpPhase::Previewed) {
    // A click confirms, a drag adjusts k (decided on release: sharp_edge_release).
    k_drag_.active = true;
    k_drag_.moved = false;
    k_drag_.start = tool;
    k_drag_.k1 = k1_;
    k_drag_.k4 = k4_;
    k_drag_.sent_factor = 1;
  } else {
    last_push_ = tool;  // a new sweep starts here
    constrain_to_guide(tool);
  }
  publish_tool_state();
}

void Station::take_preview(const v1::SharpEdgeResponse& response) {
  curve_.clear();
  for (const auto& q : response.curve()) curve_.emplace_back(q.x(), q.y(), q.z());
  guide_.clear();
  for (const auto& q : response.guide()) guide_.emplace_back(q.x(), q.y(), q.z());
  k1_ = response.k1();
  k4_ = response.k4();
  // The extrusion direction: bottom to top of the guiding surface's first quad.
  if (guide_.size() >= 3) {
    const Vec3 up = guide_[2] - guide_[1];
    if (up.norm() > 0) guide_normal_ = up.normalized();
  }
}

void Station::apply_tangent_steps() {
  const int steps = tangent_steps_.exchange(0);
  if (steps == 0 || sharp_phase_ != SharpPhase::Previewed) return;
  // Live k (the thesis lists real-time adjustment as future work, seed 000 §6.2): the server
  // answers the new curve and guiding surface, nothing is committed.
  const double factor = std::pow(1.1, steps);
  v1::SharpEdgeRequest request;
  request.set_session_id(options_.session_id);
  request.mutable_adjust()->set_k1(k1_ * factor);
  request.mutable_adjust()->set_k4(k4_ * factor);
  v1::SharpEdgeResponse response;
  const Status s = client_.sharp_edge(request, response);
  if (!s.is_ok()) {
    set_status("sharp edge: " + s.to_string());
    return;
  }
  take_preview(response);
  set_status(fmt::format("sharp edge: k1 {:.4g}, k4 {:.4g}; click to confirm", k1_, k4_));
  publish_tool_state();
}

void Station::constrain_to_guide(const Vec3& tool) {
  if (!loop_ || curve_.size() < 2) return;
  // The curve segment nearest the tool; the plane holds that segment and the extrusion
  // direction (the guiding surface locally).
  std::size_t best = 0;
  double best_distance = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < curve_.size(); ++i) {
    const double d = distance_to_segment(tool, curve_[i], curve_[i + 1]);
    if (d < best_distance) {
      best_distance = d;
      best = i;
    }
  }
  const Vec3 tangent = curve_[best + 1] - curve_[best];
  const Vec3 normal = tangent.cross(guide_normal_);
  if (!(normal.norm() > 0)) return;
  haptics::PlaneConstraint plane;
  plane.active = true;
  plane.point = closest_on_segment(tool, curve_[best], curve_[best + 1]);
  plane.normal = normal.normalized();
  loop_->set_constraint(plane);
}

void Station::sharp_edge_release(const Vec3& tool) {
  if (loop_) loop_->set_constraint({});  // the sweep is over: free the tool
  if (sharp_phase_ != SharpPhase::Previewed || !k_drag_.active) return;
  k_drag_.active = false;
  if (k_drag_.moved) {  // the drag set k: keep the preview, a click confirms
    set_status(fmt::format("sharp edge: k1 {:.4g}, k4 {:.4g}; click to confirm", k1_, k4_));
    publish_tool_state();
    return;
  }
  v1::SharpEdgeRequest request;
  request.set_session_id(options_.session_id);
  request.set_confirm(true);
  v1::SharpEdgeResponse response;
  const Status s = client_.sharp_edge(request, response);
  if (!s.is_ok()) {
    set_status("sharp edge: " + s.to_string());
  } else {
    sharp_phase_ = SharpPhase::Snapped;
    last_push_ = tool;
    set_status(fmt::format("sharp edge: {} vertices on the guiding surface; sweep to push",
                           response.curtain_vertices()));
  }
  publish_tool_state();
}

double Station::drag_factor(const Vec3& tool) const {
  // Along P2 -> P3: a quarter of the chord forward doubles both tangent lengths, backward
  // halves them (a device-only way to set k, so the operator needs no keyboard).
  if (picks_.size() < 4) return 1;
  const Vec3 chord = picks_[2] - picks_[1];
  if (!(chord.norm() > 0)) return 1;
  const double along = (tool - k_drag_.start).dot(chord.normalized());
  return std::exp2(std::clamp(along / (kDragDoublingChords * chord.norm()), -6.0, 6.0));
}

void Station::adjust_by_drag(const Vec3& tool) {
  if (picks_.size() < 4) return;
  const double chord = (picks_[2] - picks_[1]).norm();
  if (!k_drag_.moved && (tool - k_drag_.start).norm() < kDragDeadZoneChords * chord) return;
  k_drag_.moved = true;
  const double factor = drag_factor(tool);
  // A request only when k changes by more than 2% (the preview is a round trip).
  if (std::abs(std::log(factor / k_drag_.sent_factor)) < std::log(1.02)) return;
  v1::SharpEdgeRequest request;
  request.set_session_id(options_.session_id);
  request.mutable_adjust()->set_k1(k_drag_.k1 * factor);
  request.mutable_adjust()->set_k4(k_drag_.k4 * factor);
  v1::SharpEdgeResponse response;
  const Status s = client_.sharp_edge(request, response);
  if (!s.is_ok()) {
    set_status("sharp edge: " + s.to_string());
    return;
  }
  k_drag_.sent_factor = factor;
  take_preview(response);
  set_status(fmt::format("sharp edge: k1 {:.4g}, k4 {:.4g} (dragging)", k1_, k4_));
  publish_tool_state();
}

void Station::sharp_edge_hold(const Vec3& tool) {
  if (sharp_phase_ == SharpPhase::Previewed && k_drag_.active) {
    adjust_by_drag(tool);
    return;
  }
  if (sharp_phase_ != SharpPhase::Snapped) return;
  const double step = push_step_;
  // Algorithm VI moves a vertex by the step per tool sample; a push goes out once the tool has
  // moved a step, and the server cuts the motion since the last push into samples of one step,
  // so a slow round trip sends fewer, longer pushes but loses none of the sweep.
  constrain_to_guide(tool);
  if ((tool - last_push_).norm() < step) return;
  v1::SharpEdgeRequest request;
  request.set_session_id(options_.session_id);
  auto* push = request.mutable_push();
  *push->mutable_proxy() = wire(tool);
  *push->mutable_previous() = wire(last_push_);
  push->set_face(0xFFFFFFFFu);
  push->set_step(step);
  last_push_ = tool;
  v1::SharpEdgeResponse response;
  const Status s = client_.sharp_edge(request, response);
  if (s.is_ok()) {
    const std::uint64_t before = pushes_;
    pushes_ += std::max<std::uint64_t>(1, response.push_samples());
    pushes_done_.fetch_add(pushes_ - before);
    if (before / 10 != pushes_ / 10) publish_tool_state();
  }
}

void Station::sharp_edge_second() {
  k_drag_.active = false;  // button 2 ends any drag (its release neither confirms nor sets k)
  v1::SharpEdgeRequest request;
  request.set_session_id(options_.session_id);
  v1::SharpEdgeResponse response;
  switch (sharp_phase_) {
    case SharpPhase::Picking:
      if (!picks_.empty()) picks_.pop_back();  // take the last pick back
      break;
    case SharpPhase::Previewed:
      request.set_cancel(true);
      client_.sharp_edge(request, response);
      picks_.clear();
      curve_.clear();
      guide_.clear();
      sharp_phase_ = SharpPhase::Picking;
      set_status("sharp edge: cancelled");
      break;
    case SharpPhase::Snapped: {
      if (loop_) loop_->set_constraint({});
      request.set_smooth(true);
      request.set_finish(options_.push_finish);
      const Status s = client_.sharp_edge(request, response);
      set_status(s.is_ok() ? fmt::format("sharp edge: {} pushes; {}", pushes_, response.summary())
                           : "sharp edge: " + s.to_string());
      picks_.clear();
      curve_.clear();
      guide_.clear();
      pushes_ = 0;
      sharp_phase_ = SharpPhase::Picking;
      break;
    }
  }
  publish_tool_state();
}

bool Station::nearest_boundary_edge(const Vec3& tool, std::uint32_t& a, std::uint32_t& b) const {
  std::shared_ptr<const haptics::SurfaceMesh> surface;
  std::shared_ptr<const std::vector<HoleLoop>> holes;
  {
    std::lock_guard lock(mutex_);
    surface = view_.surface;
    holes = view_.holes;
  }
  if (!surface || !holes) return false;
  double best = highlight_distance_;
  bool found = false;
  for (const HoleLoop& h : *holes)
    for (std::size_t i = 0; i < h.vertices.size(); ++i) {
      const std::uint32_t u = h.vertices[i], w = h.vertices[(i + 1) % h.vertices.size()];
      const double d = distance_to_segment(tool, surface->positions[u], surface->positions[w]);
      if (d < best) {
        best = d;
        a = u;
        b = w;
        found = true;
      }
    }
  return found;
}

void Station::stitch_press(const Vec3& tool) {
  stitching_ = nearest_boundary_edge(tool, stitch_a_, stitch_b_);
  stitch_target_ = -1;
  set_status(stitching_ ? fmt::format("stitch: edge {}-{}; drag to the other surface", stitch_a_,
                                      stitch_b_)
                        : "stitch: press on a boundary edge");
  publish_tool_state();
}

void Station::stitch_hold(const Vec3& tool) {
  if (!stitching_) return;
  std::shared_ptr<const haptics::SurfaceMesh> surface;
  std::shared_ptr<const std::vector<HoleLoop>> holes;
  {
    std::lock_guard lock(mutex_);
    surface = view_.surface;
    holes = view_.holes;
  }
  if (!surface || !holes) return;
  // Snap candidates: boundary vertices within reach of the tool; the nearest lights up.
  const std::int64_t before = stitch_target_;
  double best = highlight_distance_;
  stitch_target_ = -1;
  for (const HoleLoop& h : *holes)
    for (const std::uint32_t v : h.vertices) {
      if (v == stitch_a_ || v == stitch_b_) continue;
      const double d = (surface->positions[v] - tool).norm();
      if (d < best) {
        best = d;
        stitch_target_ = v;
        stitch_target_position_ = surface->positions[v];
      }
    }
  if (stitch_target_ != before) publish_tool_state();
}

void Station::stitch_release() {
  if (!stitching_) return;
  stitching_ = false;
  if (stitch_target_ < 0) {
    set_status("stitch: no boundary vertex near the tool at release");
  } else {
    v1::StitchRequest request;
    request.set_session_id(options_.session_id);
    request.set_a(stitch_a_);
    request.set_b(stitch_b_);
    request.set_t(static_cast<std::uint32_t>(stitch_target_));
    v1::EditResponse response;
    const Status s = client_.stitch(request, response);
    set_status(s.is_ok()
                   ? fmt::format("stitch: triangle {}-{}-{}", stitch_a_, stitch_b_, stitch_target_)
                   : "stitch: " + s.to_string());
  }
  stitch_target_ = -1;
  publish_tool_state();
}

void Station::run_network() {
  running_.store(true);
  auto last_highlight = std::chrono::steady_clock::now();
  while (running_.load()) {
    const Status s = replica_->poll(std::chrono::milliseconds(5));
    if (!s.is_ok()) {
      set_status("connection: " + s.to_string() + " (rendering the last surface)");
      if (s.code == StatusCode::NotFound) break;  // the session is gone
    }
    publish_surface();
    apply_tangent_steps();
    // The interact stream dies with the connection; reopen it once the replica is back.
    if (s.is_ok() && interact_ && interact_->finished()) interact_ = client_.interact();
    send_samples();
    // Acks tell us our client id (to skip our own presence) and keep the stream drained.
    v1::InteractionEvent event;
    while (interact_ && interact_->read(event, std::chrono::milliseconds(0))) {
      if (event.has_ack()) {
        own_client_id_.store(event.ack().client_id());
        std::lock_guard lock(mutex_);
        cursors_.erase(event.ack().client_id());
        samples_acked_ = event.ack().tool_samples_received();
      }
    }
    const auto now = std::chrono::steady_clock::now();
    if (now - last_highlight > std::chrono::milliseconds(16)) {
      last_highlight = now;
      update_highlight(last_tool_);
      std::lock_guard lock(mutex_);
      view_.cursors.clear();
      for (auto it = cursors_.begin(); it != cursors_.end();) {
        if (now - it->second.seen > std::chrono::seconds(5)) {
          it = cursors_.erase(it);
        } else {
          view_.cursors.push_back(it->second);
          ++it;
        }
      }
    }
  }
  if (interact_ && batch_.tools().samples_size() > 0) interact_->send(batch_);
}

StationView Station::view() const {
  std::lock_guard lock(mutex_);
  StationView v = view_;
  v.fills = fills_.load();
  if (!v.curve.empty()) {  // the session's tool is this station's own: drawn from local state
    v.remote_curve.clear();
    v.remote_guide.clear();
    v.remote_tool_principal.clear();
  }
  return v;
}

haptics::HapticLoopOptions loop_options_for(const Eigen::AlignedBox3d& model,
                                            const Eigen::AlignedBox3d& device_workspace) {
  haptics::HapticLoopOptions options;
  options.workspace = haptics::WorkspaceMap::fit(model, device_workspace);
  options.contact.epsilon = 1e-6 * (model.isEmpty() ? 1.0 : model.diagonal().norm());
  return options;
}

Eigen::AlignedBox3d bounds_of(const rpc::MeshDocument& document) {
  Eigen::AlignedBox3d box;
  for (const auto& p : document.positions) box.extend(Eigen::Vector3d(p[0], p[1], p[2]));
  return box;
}

StationRuntime::StationRuntime(Station& station, device::SafetyFilter& device,
                               haptics::HapticLoopOptions options)
    : station_(station),
      device_(device),
      loop_(device, patches_, std::move(options)),
      updater_(loop_, patches_) {}

StationRuntime::~StationRuntime() {
  stop();
}

void StationRuntime::start() {
  if (started_) return;
  started_ = true;
  station_.attach(loop_, updater_);
  updater_.start();
  loop_.start();
  network_ = std::thread([this] { station_.run_network(); });
  device_.arm();
}

void StationRuntime::stop() {
  if (!started_) return;
  started_ = false;
  station_.stop();
  if (network_.joinable()) network_.join();
  loop_.stop();
  updater_.stop();
}

}  // namespace touchmend::app
