#pragma once

//! \file viewer.h
//! \brief The station's GLFW window with an OpenGL 3.3 core context: the shaded mesh, hole
//! boundaries in colour with the hole under the tool highlighted, the tool (device) and proxy
//! cursors, other operators' cursors, overlay polylines and text labels, an orbit/zoom camera,
//! and a status line (drawn in the frame with a stroke font, and in the title bar). Screenshots
//! are PNG, written atomically. Under Xvfb (Mesa llvmpipe) the same code draws without a
//! display, which is how the tests check the pixels.

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "client/haptics/triangle_set.h"

struct GLFWwindow;

namespace touchmend::view {

using haptics::Vec3;

struct Cursor {
  Vec3 position = Vec3::Zero();
  Eigen::Vector3f colour{1, 1, 1};
  float size_px = 12;
};

//! A line strip drawn over the mesh (a previewed curve, a stitch being dragged).
struct Polyline {
  std::vector<Vec3> points;
  Eigen::Vector3f colour{1, 1, 1};
};

//! A short text drawn in screen space beside a model point (the sharp-edge picks' numbers).
struct Label {
  Vec3 anchor = Vec3::Zero();
  std::string text;
  Eigen::Vector3f colour{1, 1, 1};
  float height_px = 16;
};

//! Everything one frame shows (built by the application from the station's view).
struct Scene {
  std::shared_ptr<const haptics::SurfaceMesh> surface;
  //! Boundary loops as vertex index lists into surface->positions.
  std::vector<std::vector<std::uint32_t>> boundaries;
  int highlighted = -1;
  std::vector<Cursor> cursors;
  std::vector<Polyline> polylines;
  std::vector<Label> labels;
  std::string status;
};

struct ViewerOptions {
  int width = 960;
  int height = 720;
  bool visible = true;
  bool keep_frames = false;  //!< read each frame back (for screenshots and tests)
  std::string title = "touchmend";
};

//! Input the application maps onto the simulated device (sim) or ignores.
struct InputState {
  Vec3 target_offset = Vec3::Zero();  //!< keyboard-driven tool offset, device metres
  bool button = false;                //!< space bar
  bool forces_off = false;            //!< toggled by F: the operator turned forces off
  bool button2 = false;               //!< B: the second button
  int tangent_steps = 0;              //!< K / J presses: +1 / -1 (sharp-edge tangent lengths)
  bool quit = false;
};

//! The status text as at most \p max_lines lines of at most \p columns characters, broken at
//! its " | " separators and spaces.
std::vector<std::string> wrap_status(std::string_view status, std::size_t columns,
                                     std::size_t max_lines);

class Viewer {
 public:
  explicit Viewer(ViewerOptions options = {});
  ~Viewer();
  Viewer(const Viewer&) = delete;
  Viewer& operator=(const Viewer&) = delete;

  //! Creates the window and the GL objects; false with \p error when there is no display or
  //! no OpenGL 3.3.
  bool open(std::string& error);
  //! Draws one frame and processes window events.
  void draw(const Scene& scene);
  bool should_close() const;
  const InputState& input() const { return input_; }
  //! Writes the last frame kept (keep_frames) as a PNG, atomically.
  bool screenshot(const std::string& path, std::string& error);
  //! The last frame's pixels, RGB, bottom row first (for tests).
  std::vector<std::uint8_t> read_pixels(int& width, int& height);
  std::string gl_version() const { return gl_version_; }

 private:
  void upload_surface(const haptics::SurfaceMesh& surface);
  void handle_keys();

  ViewerOptions options_;
  GLFWwindow* window_ = nullptr;
  std::string gl_version_;
  std::string title_status_;
  unsigned program_ = 0, vao_ = 0, vbo_ = 0, ebo_ = 0;
  unsigned line_vao_ = 0, line_vbo_ = 0;
  std::size_t index_count_ = 0;
  std::uint64_t uploaded_version_ = ~0ull;
  const haptics::SurfaceMesh* uploaded_surface_ = nullptr;
  Eigen::AlignedBox3d bounds_;
  double yaw_ = 0.6, pitch_ = 0.4, zoom_ = 1.0;
  double last_x_ = 0, last_y_ = 0;
  bool dragging_ = false;
  bool f_was_down_ = false;
  bool k_was_down_ = false;
  bool j_was_down_ = false;
  InputState input_;
  std::vector<std::uint8_t> last_frame_;
  int frame_width_ = 0, frame_height_ = 0;
};

}  // namespace touchmend::view
