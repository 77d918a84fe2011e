#include "client/view/viewer.h"

#include "client/view/stroke_font.h"

// GLFW's header brings in GL/gl.h, which glext.h needs first.
// clang-format off
#define GL_GLEXT_PROTOTYPES 1
#include <GLFW/glfw3.h>
#include <GL/glext.h>
// clang-format on
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <png.h>
#include <unistd.h>

#include <Eigen/Geometry>

namespace touchmend::view {
namespace {

const char* kVertexShader = R"(#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
uniform mat4 mvp;
uniform float point_size;
out vec3 v_normal;
void main() {
  gl_Position = mvp * vec4(position, 1.0);
  gl_PointSize = point_size;
  v_normal = normal;
}
)";

const char* kFragmentShader = R"(#version 330 core
in vec3 v_normal;
uniform vec3 colour;
uniform int lit;
uniform vec3 light;
out vec4 fragment;
void main() {
  if (lit == 1) {
    // Two-sided headlight: scans are open surfaces, both sides are seen.
    float d = abs(dot(normalize(v_normal), light));
    fragment = vec4(colour * (0.25 + 0.75 * d), 1.0);
  } else {
    fragment = vec4(colour, 1.0);
  }
}
)";

unsigned compile(unsigned kind, const char* source, std::string& error) {
  const unsigned shader = glCreateShader(kind);
  glShaderSource(shader, 1, &source, nullptr);
  glCompileShader(shader);
  int ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[1024];
    glGetShaderInfoLog(shader, sizeof log, nullptr, log);
    error = std::string("shader: ") + log;
  }
  return shader;
}

Eigen::Matrix4f perspective(float fovy, float aspect, float near_plane, float far_plane) {
  const float f = 1.0f / std::tan(fovy / 2);
  Eigen::Matrix4f m = Eigen::Matrix4f::Zero();
  m(0, 0) = f / aspect;
  m(1, 1) = f;
  m(2, 2) = (far_plane + near_plane) / (near_plane - far_plane);
  m(2, 3) = 2 * far_plane * near_plane / (near_plane - far_plane);
  m(3, 2) = -1;
  return m;
}

Eigen::Matrix4f look_at(const Eigen::Vector3f& eye, const Eigen::Vector3f& centre,
                        const Eigen::Vector3f& up) {
  const Eigen::Vector3f f = (centre - eye).normalized();
  const Eigen::Vector3f s = f.cross(up).normalized();
  const Eigen::Vector3f u = s.cross(f);
  Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
  m.block<1, 3>(0, 0) = s.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -s.dot(eye);
  m(1, 3) = -u.dot(eye);
  m(2, 3) = f.dot(eye);
  return m;
}

}  // namespace

std::vector<std::string> wrap_status(std::string_view status, std::size_t columns,
                                     std::size_t max_lines) {
  // Break at the " | " separators of the status line first, then at spaces; a word longer
  // than a line is cut.
  std::vector<std::string> lines;
  std::string line;
  std::size_t start = 0;
  while (start < status.size() && lines.size() < max_lines) {
    std::size_t end = status.find(' ', start);
    if (end == std::string_view::npos) end = status.size();
    std::string_view word = status.substr(start, end - start);
    start = end + 1;
    if (word.empty()) continue;
    const bool separator = word == "|";
    if (!line.empty() && line.size() + 1 + word.size() > columns) {
      lines.push_back(line);
      line.clear();
      if (separator) continue;  // a separator does not start a line
    }
    while (word.size() > columns && lines.size() < max_lines) {
      lines.emplace_back(word.substr(0, columns));
      word.remove_prefix(columns);
    }
    if (!line.empty()) line += ' ';
    line += word;
  }
  if (!line.empty() && lines.size() < max_lines) lines.push_back(line);
  return lines;
}

Viewer::Viewer(ViewerOptions options) : options_(std::move(options)) {}

Viewer::~Viewer() {
  if (window_) {
    glfwMakeContextCurrent(window_);
    glDeleteBuffers(1, &vbo_);
    glDeleteBuffers(1, &ebo_);
    glDeleteBuffers(1, &line_vbo_);
    glDeleteVertexArrays(1, &vao_);
    glDeleteVertexArrays(1, &line_vao_);
    glDeleteProgram(program_);
    glfwDestroyWindow(window_);
    glfwTerminate();
  }
}

bool Viewer::open(std::string& error) {
  glfwSetErrorCallback([](int, const char*) {});
  if (!glfwInit()) {
    error =
        "cannot open a window: no display (set DISPLAY, or run under xvfb-run, or use --headless)";
    return false;
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_VISIBLE, options_.visible ? GLFW_TRUE : GLFW_FALSE);
  window_ =
      glfwCreateWindow(options_.width, options_.height, options_.title.c_str(), nullptr, nullptr);
  if (!window_) {
    error = "cannot create an OpenGL 3.3 core window";
    glfwTerminate();
    return false;
  }
  glfwMakeContextCurrent(window_);
  glfwSwapInterval(1);
  gl_version_ = reinterpret_cast<const char*>(glGetString(GL_VERSION));
  glfwSetWindowUserPointer(window_, this);
  glfwSetScrollCallback(window_, [](GLFWwindow* w, double, double dy) {
    auto* self = static_cast<Viewer*>(glfwGetWindowUserPointer(w));
    self->zoom_ = std::clamp(self->zoom_ * std::pow(0.9, dy), 0.05, 20.0);
  });
  std::string shader_error;
  const unsigned vs = compile(GL_VERTEX_SHADER, kVertexShader, shader_error);
  const unsigned fs = compile(GL_FRAGMENT_SHADER, kFragmentShader, shader_error);
  program_ = glCreateProgram();
  glAttachShader(program_, vs);
  glAttachShader(program_, fs);
  glLinkProgram(program_);
  glDeleteShader(vs);
  glDeleteShader(fs);
  int linked = 0;
  glGetProgramiv(program_, GL_LINK_STATUS, &linked);
  if (!shader_error.empty() || !linked) {
    error = shader_error.empty() ? "shader program did not link" : shader_error;
    return false;
  }
  glGenVertexArrays(1, &vao_);
  glGenBuffers(1, &vbo_);
  glGenBuffers(1, &ebo_);
  glGenVertexArrays(1, &line_vao_);
  glGenBuffers(1, &line_vbo_);
  glEnable(GL_DEPTH_TEST);
  glEnable(GL_PROGRAM_POINT_SIZE);
  return true;
}

bool Viewer::should_close() const {
  return window_ && glfwWindowShouldClose(window_);
}

void Viewer::upload_surface(const haptics::SurfaceMesh& surface) {
  // Per-vertex normals (area-weighted) and positions, interleaved, as floats relative to the
  // mesh centre (keeps float precision for models far from the origin).
  bounds_.setEmpty();
  for (const auto& t : surface.triangles)
    for (auto v : t) bounds_.extend(surface.positions[v]);
  const Vec3 centre = bounds_.isEmpty() ? Vec3(Vec3::Zero()) : Vec3(bounds_.center());
  std::vector<Vec3> normals(surface.positions.size(), Vec3::Zero());
  for (const auto& t : surface.triangles) {
    const Vec3 n = (surface.positions[t[1]] - surface.positions[t[0]])
                       .cross(surface.positions[t[2]] - surface.positions[t[0]]);
    for (auto v : t) normals[v] += n;
  }
  std::vector<float> data;
  data.reserve(surface.positions.size() * 6);
  for (std::size_t i = 0; i < surface.positions.size(); ++i) {
    const Vec3 p = surface.positions[i] - centre;
    const Vec3 n = normals[i].norm() > 0 ? Vec3(normals[i].normalized()) : Vec3(0, 0, 1);
    for (int k = 0; k < 3; ++k) data.push_back(static_cast<float>(p[k]));
    for (int k = 0; k < 3; ++k) data.push_back(static_cast<float>(n[k]));
  }
  std::vector<std::uint32_t> indices;
  indices.reserve(surface.triangles.size() * 3);
  for (const auto& t : surface.triangles) indices.insert(indices.end(), t.begin(), t.end());
  index_count_ = indices.size();
  glBindVertexArray(vao_);
  glBindBuffer(GL_ARRAY_BUFFER, vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data.size() * sizeof(float)), data.data(),
               GL_STATIC_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, ebo_);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(indices.size() * sizeof(std::uint32_t)), indices.data(),
               GL_STATIC_DRAW);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                        reinterpret_cast<void*>(3 * sizeof(float)));
  glEnableVertexAttribArray(1);
  uploaded_version_ = surface.version;
  uploaded_surface_ = &surface;
}

void Viewer::handle_keys() {
  // Orbit with the left mouse button.
  double x = 0, y = 0;
  glfwGetCursorPos(window_, &x, &y);
  const bool down = glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
  if (down && dragging_) {
    yaw_ += 0.01 * (x - last_x_);
    pitch_ = std::clamp(pitch_ + 0.01 * (y - last_y_), -1.5, 1.5);
  }
  dragging_ = down;
  last_x_ = x;
  last_y_ = y;
  // The simulated stylus: arrows / W S move in the view plane and depth; space is the button.
  const double step = 0.0004;
  auto key = [&](int k) { return glfwGetKey(window_, k) == GLFW_PRESS; };
  if (key(GLFW_KEY_LEFT)) input_.target_offset.x() -= step;
  if (key(GLFW_KEY_RIGHT)) input_.target_offset.x() += step;
  if (key(GLFW_KEY_UP)) input_.target_offset.y() += step;
  if (key(GLFW_KEY_DOWN)) input_.target_offset.y() -= step;
  if (key(GLFW_KEY_W)) input_.target_offset.z() -= step;
  if (key(GLFW_KEY_S)) input_.target_offset.z() += step;
  input_.button = key(GLFW_KEY_SPACE);
  input_.button2 = key(GLFW_KEY_B);
  const bool k_down = key(GLFW_KEY_K), j_down = key(GLFW_KEY_J);
  if (k_down && !k_was_down_) ++input_.tangent_steps;
  if (j_down && !j_was_down_) --input_.tangent_steps;
  k_was_down_ = k_down;
  j_was_down_ = j_down;
  const bool f_down = key(GLFW_KEY_F);
  if (f_down && !f_was_down_) input_.forces_off = !input_.forces_off;
  f_was_down_ = f_down;
  input_.quit = key(GLFW_KEY_ESCAPE) || glfwWindowShouldClose(window_);
}

void Viewer::draw(const Scene& scene) {
  if (!window_) return;
  glfwMakeContextCurrent(window_);
  if (scene.surface &&
      (scene.surface.get() != uploaded_surface_ || scene.surface->version != uploaded_version_))
    upload_surface(*scene.surface);
  int width = 0, height = 0;
  glfwGetFramebufferSize(window_, &width, &height);
  glViewport(0, 0, width, height);
  glClearColor(0.08f, 0.09f, 0.11f, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  if (scene.status != title_status_) {  // the title only when it changed (a window-system call)
    title_status_ = scene.status;
    glfwSetWindowTitle(
        window_,
        (scene.status.empty() ? options_.title : options_.title + " — " + scene.status).c_str());
  }
  if (!scene.surface || bounds_.isEmpty()) {
    glfwSwapBuffers(window_);
    glfwPollEvents();
    handle_keys();
    return;
  }
  const Vec3 centre = bounds_.center();
  const float radius = static_cast<float>(0.5 * bounds_.diagonal().norm());
  const float distance = static_cast<float>(2.6 * radius * zoom_);
  const Eigen::Vector3f eye(distance * float(std::cos(pitch_) * std::sin(yaw_)),
                            distance * float(std::sin(pitch_)),
                            distance * float(std::cos(pitch_) * std::cos(yaw_)));
  const Eigen::Matrix4f mvp =
      perspective(0.8f, float(width) / float(std::max(height, 1)), 0.01f * radius, 20.0f * radius) *
      look_at(eye, Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitY());
  glUseProgram(program_);
  glUniformMatrix4fv(glGetUniformLocation(program_, "mvp"), 1, GL_FALSE, mvp.data());
  const Eigen::Vector3f light = eye.normalized();
  glUniform3f(glGetUniformLocation(program_, "light"), light.x(), light.y(), light.z());
  const int colour = glGetUniformLocation(program_, "colour");
  const int lit = glGetUniformLocation(program_, "lit");
  const int point_size = glGetUniformLocation(program_, "point_size");
  // The mesh.
  glUniform1i(lit, 1);
  glUniform3f(colour, 0.72f, 0.74f, 0.78f);
  glUniform1f(point_size, 1.0f);
  glEnable(GL_POLYGON_OFFSET_FILL);
  glPolygonOffset(1.0f, 1.0f);
  glBindVertexArray(vao_);
  glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(index_count_), GL_UNSIGNED_INT, nullptr);
  glDisable(GL_POLYGON_OFFSET_FILL);
  // Boundaries (lines) and cursors (points): positions only, same program unlit.
  glUniform1i(lit, 0);
  glBindVertexArray(line_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, line_vbo_);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                        reinterpret_cast<void*>(3 * sizeof(float)));
  glEnableVertexAttribArray(1);
  std::vector<float> buffer;
  auto push = [&](const Vec3& p) {
    const Vec3 q = p - centre;
    buffer.insert(buffer.end(), {float(q.x()), float(q.y()), float(q.z()), 0.f, 0.f, 1.f});
  };
  for (std::size_t h = 0; h < scene.boundaries.size(); ++h) {
    const bool highlighted = static_cast<int>(h) == scene.highlighted;
    const auto& loop = scene.boundaries[h];
    buffer.clear();
    for (std::size_t i = 0; i < loop.size(); ++i) {
      push(scene.surface->positions[loop[i]]);
      push(scene.surface->positions[loop[(i + 1) % loop.size()]]);
    }
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(buffer.size() * sizeof(float)),
                 buffer.data(), GL_STREAM_DRAW);
    if (highlighted) {
      glUniform3f(colour, 1.0f, 0.85f, 0.0f);  // the hole under the tool
      glUniform1f(point_size, 7.0f);
      glDrawArrays(GL_POINTS, 0, static_cast<GLsizei>(buffer.size() / 6));  // thick rim
    } else {
      glUniform3f(colour, 0.95f, 0.25f, 0.2f);
    }
    glDrawArrays(GL_LINES, 0, static_cast<GLsizei>(buffer.size() / 6));
  }
  glDisable(GL_DEPTH_TEST);  // overlays and cursors stay visible through the surface
  for (const Polyline& line : scene.polylines) {
    buffer.clear();
    for (std::size_t i = 0; i + 1 < line.points.size(); ++i) {
      push(line.points[i]);
      push(line.points[i + 1]);
    }
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(buffer.size() * sizeof(float)),
                 buffer.data(), GL_STREAM_DRAW);
    glUniform3f(colour, line.colour.x(), line.colour.y(), line.colour.z());
    glDrawArrays(GL_LINES, 0, static_cast<GLsizei>(buffer.size() / 6));
  }
  for (const Cursor& c : scene.cursors) {
    buffer.clear();
    push(c.position);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(buffer.size() * sizeof(float)),
                 buffer.data(), GL_STREAM_DRAW);
    glUniform3f(colour, c.colour.x(), c.colour.y(), c.colour.z());
    glUniform1f(point_size, c.size_px);
    glDrawArrays(GL_POINTS, 0, 1);
  }
  // Text in pixels (labels beside their anchors, the status line at the top left), drawn with
  // an identity transform in normalised device coordinates.
  const Eigen::Matrix4f identity = Eigen::Matrix4f::Identity();
  glUniformMatrix4fv(glGetUniformLocation(program_, "mvp"), 1, GL_FALSE, identity.data());
  const float px_x = 2.0f / float(std::max(width, 1)), px_y = 2.0f / float(std::max(height, 1));
  const auto draw_text = [&](std::string_view text, float x0, float y0, float height_px,
                             const Eigen::Vector3f& rgb) {
    const float unit = height_px / kGlyphHeight;
    buffer.clear();
    for (const auto& end : text_strokes(text))
      buffer.insert(buffer.end(),
                    {x0 + end[0] * unit * px_x, y0 + end[1] * unit * px_y, 0.f, 0.f, 0.f, 1.f});
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(buffer.size() * sizeof(float)),
                 buffer.data(), GL_STREAM_DRAW);
    glUniform3f(colour, rgb.x(), rgb.y(), rgb.z());
    glDrawArrays(GL_LINES, 0, static_cast<GLsizei>(buffer.size() / 6));
  };
  for (const Label& label : scene.labels) {
    const Vec3 q = label.anchor - centre;
    const Eigen::Vector4f clip = mvp * Eigen::Vector4f(float(q.x()), float(q.y()), float(q.z()), 1);
    if (!(clip.w() > 0)) continue;  // behind the eye
    // Up and to the right of the point, clear of its cursor.
    draw_text(label.text, clip.x() / clip.w() + 10 * px_x, clip.y() / clip.w() + 10 * px_y,
              label.height_px, label.colour);
  }
  if (!scene.status.empty()) {
    const float text_px = 12, line_px = 18;
    const std::size_t columns = static_cast<std::size_t>(
        std::max(8.0f, (float(width) - 16) / (text_px / kGlyphHeight * kGlyphAdvance)));
    const std::vector<std::string> lines = wrap_status(scene.status, columns, 3);
    for (std::size_t i = 0; i < lines.size(); ++i)
      draw_text(lines[i], -1 + 8 * px_x, 1 - (8 + text_px + float(i) * line_px) * px_y, text_px,
                {0.92f, 0.92f, 0.92f});
  }
  glUniformMatrix4fv(glGetUniformLocation(program_, "mvp"), 1, GL_FALSE, mvp.data());
  glEnable(GL_DEPTH_TEST);
  if (options_.keep_frames) {
    // From the back buffer before the swap: defined even for a hidden window.
    frame_width_ = width;
    frame_height_ = height;
    last_frame_.resize(std::size_t(width) * std::size_t(height) * 3);
    glReadBuffer(GL_BACK);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, last_frame_.data());
  }
  glfwSwapBuffers(window_);
  glfwPollEvents();
  handle_keys();
}

std::vector<std::uint8_t> Viewer::read_pixels(int& width, int& height) {
  width = frame_width_;
  height = frame_height_;
  return last_frame_;
}

bool Viewer::screenshot(const std::string& path, std::string& error) {
  int width = 0, height = 0;
  const std::vector<std::uint8_t> pixels = read_pixels(width, height);
  if (pixels.empty()) {
    error = "no frame to save (the viewer keeps frames only with keep_frames)";
    return false;
  }
  const std::string temp = path + ".tmp-" + std::to_string(::getpid());
  FILE* file = std::fopen(temp.c_str(), "wb");
  if (!file) {
    error = "cannot write " + temp;
    return false;
  }
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    std::fclose(file);
    std::remove(temp.c_str());
    error = "PNG encoding failed";
    return false;
  }
  png_init_io(png, file);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int row = height - 1; row >= 0; --row)  // OpenGL's first row is the bottom one
    png_write_row(png, pixels.data() + std::size_t(row) * std::size_t(width) * 3);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  const bool flushed = std::fflush(file) == 0;
  std::fclose(file);
  std::error_code ec;
  if (flushed) std::filesystem::rename(temp, path, ec);
  if (!flushed || ec) {
    std::filesystem::remove(temp, ec);
    error = "cannot write " + path;
    return false;
  }
  return true;
}

}  // namespace touchmend::view
