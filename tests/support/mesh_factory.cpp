#include "tests/support/mesh_factory.h"

#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <unordered_map>

#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_io.h"

namespace touchmend::testing {

MeshSoup grid(int nx, int ny, const std::function<double(double, double)>& height) {
  MeshSoup s;
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      const double x = i, y = j;
      s.points.emplace_back(x, y, height ? height(x, y) : 0.0);
    }
  auto id = [&](int i, int j) { return static_cast<std::uint32_t>(j * (nx + 1) + i); };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      s.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      s.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return s;
}

MeshSoup grid_with_round_hole(const std::function<double(double, double)>& height) {
  return remove_faces(grid(16, 16, height), [](const Vec3& c) {
    return (c[0] - 8) * (c[0] - 8) + (c[1] - 8) * (c[1] - 8) < 16;
  });
}

MeshSoup cylinder(double r, double height, int around, int rings) {
  MeshSoup s;
  for (int k = 0; k < rings; ++k)
    for (int i = 0; i < around; ++i) {
      const double a = 2 * std::numbers::pi * i / around;
      s.points.emplace_back(r * std::cos(a), r * std::sin(a), height * k / (rings - 1));
    }
  auto id = [&](int i, int k) { return static_cast<std::uint32_t>(k * around + (i % around)); };
  for (int k = 0; k + 1 < rings; ++k)
    for (int i = 0; i < around; ++i) {
      s.triangles.push_back({id(i, k), id(i + 1, k), id(i + 1, k + 1)});
      s.triangles.push_back({id(i, k), id(i + 1, k + 1), id(i, k + 1)});
    }
  return s;
}

MeshSoup comb_cut_cylinder(CombTeeth teeth) {
  return remove_faces(cylinder(0.05, 1.0, 48, 6), [teeth](const Vec3& c) {
    const double angle = std::atan2(c[1], c[0]);
    if (angle < 0.3 || angle > 1.3) return false;
    const double z = c[2];
    // The fourth band, and the third's triangles with one lower corner (their centroids lie
    // in its upper half).
    if ((z > 0.6 && z < 0.8) || (z > 0.5 && z < 0.6)) return true;
    // Lone teeth: also the second band, and all of the third past 1 radian, so that the chain
    // of teeth is free at that end and the cut is one hole around it.
    return teeth == CombTeeth::Lone &&
           ((z > 0.2 && z < 0.4) || (z > 0.4 && z < 0.6 && angle > 1.0));
  });
}

MeshSoup uv_sphere(double r, int around, int rings) {
  MeshSoup s;
  s.points.emplace_back(0, 0, -r);
  for (int k = 1; k < rings; ++k) {
    const double phi = std::numbers::pi * k / rings - std::numbers::pi / 2;
    for (int i = 0; i < around; ++i) {
      const double a = 2 * std::numbers::pi * i / around;
      s.points.emplace_back(r * std::cos(phi) * std::cos(a), r * std::cos(phi) * std::sin(a),
                            r * std::sin(phi));
    }
  }
  s.points.emplace_back(0, 0, r);
  const auto top = static_cast<std::uint32_t>(s.points.size() - 1);
  auto id = [&](int i, int k) {
    return static_cast<std::uint32_t>(1 + (k - 1) * around + (i % around));
  };
  for (int i = 0; i < around; ++i) s.triangles.push_back({0, id(i + 1, 1), id(i, 1)});
  for (int k = 1; k + 1 < rings; ++k)
    for (int i = 0; i < around; ++i) {
      s.triangles.push_back({id(i, k), id(i + 1, k), id(i + 1, k + 1)});
      s.triangles.push_back({id(i, k), id(i + 1, k + 1), id(i, k + 1)});
    }
  for (int i = 0; i < around; ++i)
    s.triangles.push_back({id(i, rings - 1), id(i + 1, rings - 1), top});
  return s;
}

MeshSoup cube(int n) {
  MeshSoup s;
  std::map<std::array<int, 3>, std::uint32_t> index;
  auto vertex = [&](int x, int y, int z) {
    const std::array<int, 3> key{x, y, z};
    auto [it, inserted] = index.try_emplace(key, static_cast<std::uint32_t>(s.points.size()));
    if (inserted) s.points.emplace_back(x, y, z);
    return it->second;
  };
  // Each side: origin, two in-plane axes (u, v) with u x v pointing outward.
  struct Side {
    std::array<int, 3> origin, u, v;
  };
  const Side sides[6] = {{{0, 0, 0}, {0, 1, 0}, {1, 0, 0}},   // z = 0, normal -z
                         {{0, 0, n}, {1, 0, 0}, {0, 1, 0}},   // z = n, normal +z
                         {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}},   // y = 0, normal -y
                         {{0, n, 0}, {0, 0, 1}, {1, 0, 0}},   // y = n, normal +y
                         {{0, 0, 0}, {0, 0, 1}, {0, 1, 0}},   // x = 0, normal -x
                         {{n, 0, 0}, {0, 1, 0}, {0, 0, 1}}};  // x = n, normal +x
  for (const Side& side : sides)
    for (int b = 0; b < n; ++b)
      for (int a = 0; a < n; ++a) {
        auto at = [&](int da, int db) {
          std::array<int, 3> p;
          for (int c = 0; c < 3; ++c)
            p[c] = side.origin[c] + (a + da) * side.u[c] + (b + db) * side.v[c];
          return vertex(p[0], p[1], p[2]);
        };
        s.triangles.push_back({at(0, 0), at(1, 0), at(1, 1)});
        s.triangles.push_back({at(0, 0), at(1, 1), at(0, 1)});
      }
  return s;
}

MeshSoup annulus(int inner, double r_in, int rings, double ring_width) {
  MeshSoup s;
  for (int k = 0; k <= rings; ++k)
    for (int i = 0; i < inner; ++i) {
      const double a = 2 * std::numbers::pi * i / inner;
      const double r = r_in + k * ring_width;
      s.points.emplace_back(r * std::cos(a), r * std::sin(a), 0);
    }
  auto id = [&](int i, int k) { return static_cast<std::uint32_t>(k * inner + (i % inner)); };
  for (int k = 0; k < rings; ++k)
    for (int i = 0; i < inner; ++i) {
      s.triangles.push_back({id(i, k), id(i + 1, k), id(i + 1, k + 1)});
      s.triangles.push_back({id(i, k), id(i + 1, k + 1), id(i, k + 1)});
    }
  return s;
}

MeshSoup remove_faces(const MeshSoup& soup, const std::function<bool(const Vec3&)>& remove,
                      std::vector<std::array<Vec3, 3>>* removed) {
  MeshSoup out;
  std::vector<std::int64_t> map(soup.points.size(), -1);
  for (const auto& t : soup.triangles) {
    const Vec3 c = (soup.points[t[0]] + soup.points[t[1]] + soup.points[t[2]]) / 3.0;
    if (remove(c)) {
      if (removed) removed->push_back({soup.points[t[0]], soup.points[t[1]], soup.points[t[2]]});
      continue;
    }
    geometry::Triangle nt;
    for (int k = 0; k < 3; ++k) {
      if (map[t[k]] < 0) {
        map[t[k]] = static_cast<std::int64_t>(out.points.size());
        out.points.push_back(soup.points[t[k]]);
      }
      nt[k] = static_cast<std::uint32_t>(map[t[k]]);
    }
    out.triangles.push_back(nt);
  }
  return out;
}

MeshSoup cut_leaving_an_island(const MeshSoup& soup, const Vec3& centre, double radius) {
  const auto centroid = [&](const geometry::Triangle& t) {
    return (soup.points[t[0]] + soup.points[t[1]] + soup.points[t[2]]) / 3.0;
  };
  const auto cut = [&](const geometry::Triangle& t) {
    return (centroid(t) - centre).norm() < radius;
  };
  std::vector<int> kept_faces_at(soup.points.size(), 0);
  for (const auto& t : soup.triangles)
    if (!cut(t))
      for (const auto c : t) ++kept_faces_at[c];
  std::optional<Vec3> island;
  for (const auto& t : soup.triangles) {
    if (!cut(t)) continue;
    int on_rim = 0;
    for (const auto c : t) on_rim += kept_faces_at[c] > 0 ? 1 : 0;
    if (on_rim == 1) {
      island = centroid(t);
      break;
    }
  }
  return remove_faces(soup, [&](const Vec3& c) {
    return (c - centre).norm() < radius && !(island && c == *island);
  });
}

MeshSoup plate_with_a_pocket(int around, double radius, double depth, int wall_rows) {
  MeshSoup s;
  constexpr int kPlateRings = 3;
  // Rings 0..3 of the plate in z = 0, then the wall's rings down to the floor's in z = -depth,
  // and the floor's centre.
  const int floor = kPlateRings + wall_rows;
  for (int k = 0; k <= floor; ++k)
    for (int i = 0; i < around; ++i) {
      const double a = 2 * std::numbers::pi * i / around;
      const double r = k <= kPlateRings ? radius + k : radius;
      const double z = k <= kPlateRings ? 0.0 : -depth * (k - kPlateRings) / wall_rows;
      s.points.emplace_back(r * std::cos(a), r * std::sin(a), z);
    }
  const auto centre = static_cast<std::uint32_t>(s.points.size());
  s.points.emplace_back(0, 0, -depth);
  const auto id = [&](int i, int k) { return static_cast<std::uint32_t>(k * around + i % around); };
  for (int k = 0; k < kPlateRings; ++k)
    for (int i = 0; i < around; ++i) {
      s.triangles.push_back({id(i, k), id(i + 1, k + 1), id(i + 1, k)});
      s.triangles.push_back({id(i, k), id(i, k + 1), id(i + 1, k + 1)});
    }
  // The wall's rows: ring 0 (the mouth), then rings kPlateRings + 1 ... floor.
  for (int row = 0; row < wall_rows; ++row) {
    const int upper = row == 0 ? 0 : kPlateRings + row, lower = kPlateRings + row + 1;
    for (int i = 0; i < around; ++i) {
      s.triangles.push_back({id(i, upper), id(i + 1, upper), id(i + 1, lower)});
      s.triangles.push_back({id(i, upper), id(i + 1, lower), id(i, lower)});
    }
  }
  for (int i = 0; i < around; ++i) s.triangles.push_back({id(i, floor), id(i + 1, floor), centre});
  return s;
}

MeshSoup plate_with_a_counterbore(int around, double radius, double depth, double bore_radius,
                                  double bore_depth) {
  MeshSoup s;
  // Rings from the plate's rim inwards and down: (radius, z) of each.
  const std::vector<std::pair<double, double>> rings = {
      {radius + 3, 0.0}, {radius + 2, 0.0},     {radius + 1, 0.0},         {radius, 0.0},
      {radius, -depth},  {bore_radius, -depth}, {bore_radius, -bore_depth}};
  for (const auto& [r, z] : rings)
    for (int i = 0; i < around; ++i) {
      const double a = 2 * std::numbers::pi * i / around;
      s.points.emplace_back(r * std::cos(a), r * std::sin(a), z);
    }
  const auto centre = static_cast<std::uint32_t>(s.points.size());
  s.points.emplace_back(0, 0, -bore_depth);
  const auto id = [&](int i, std::size_t k) {
    return static_cast<std::uint32_t>(k * static_cast<std::size_t>(around) + i % around);
  };
  // Each band between ring k (outer or upper) and k + 1, facing +z or the axis.
  for (std::size_t k = 0; k + 1 < rings.size(); ++k)
    for (int i = 0; i < around; ++i) {
      s.triangles.push_back({id(i, k + 1), id(i, k), id(i + 1, k)});
      s.triangles.push_back({id(i, k + 1), id(i + 1, k), id(i + 1, k + 1)});
    }
  for (int i = 0; i < around; ++i)
    s.triangles.push_back({id(i, rings.size() - 1), id(i + 1, rings.size() - 1), centre});
  return s;
}

MeshSoup grid_with_a_slot_along_a_fold(double fold_deg) {
  const double fold = fold_deg * std::numbers::pi / 180;
  const std::vector<double> rows{-5, -4, -3, -2, -1, -0.1, 0, 0.1, 1, 2, 3, 4, 5};
  const std::size_t crease_row = 6, columns = 11;
  MeshSoup soup;
  for (const double s : rows)
    for (std::size_t i = 0; i < columns; ++i)
      soup.points.push_back(
          s >= 0 ? Vec3(static_cast<double>(i), s, 0)
                 : Vec3(static_cast<double>(i), s * std::cos(fold), -s * std::sin(fold)));
  const auto id = [&](std::size_t i, std::size_t j) {
    return static_cast<std::uint32_t>(j * columns + i);
  };
  const auto slot = [&](std::uint32_t v) {
    const std::size_t i = v % columns;
    return v / columns == crease_row && i >= 5 && i <= 7;
  };
  for (std::size_t j = 0; j + 1 < rows.size(); ++j)
    for (std::size_t i = 0; i + 1 < columns; ++i) {
      std::array<geometry::Triangle, 2> quad;
      if (j < crease_row)  // below the crease: the diagonal from (i, j + 1) to (i + 1, j)
        quad = {geometry::Triangle{id(i, j), id(i + 1, j), id(i, j + 1)},
                geometry::Triangle{id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)}};
      else
        quad = {geometry::Triangle{id(i, j), id(i + 1, j), id(i + 1, j + 1)},
                geometry::Triangle{id(i, j), id(i + 1, j + 1), id(i, j + 1)}};
      for (const geometry::Triangle& t : quad)
        if (!slot(t[0]) && !slot(t[1]) && !slot(t[2])) soup.triangles.push_back(t);
    }
  return soup;
}

MeshSoup with_lone_triangle(MeshSoup soup, const Vec3& corner) {
  const auto base = static_cast<std::uint32_t>(soup.points.size());
  soup.points.push_back(corner);
  soup.points.push_back(corner + Vec3(1, 0, 0));
  soup.points.push_back(corner + Vec3(0, 1, 0));
  soup.triangles.push_back({base, base + 1, base + 2});
  return soup;
}

MeshSoup cube_with_hole(int n, const Vec3& centre, double radius) {
  return remove_faces(cube(n), [&](const Vec3& c) { return (c - centre).norm() < radius; });
}

MeshSoup two_plates(int n, double gap) {
  MeshSoup soup = grid(n, n);
  const MeshSoup right = grid(n, n);
  const auto offset = static_cast<std::uint32_t>(soup.points.size());
  for (const Vec3& p : right.points) soup.points.push_back(p + Vec3(n + gap, 0, 0));
  for (const auto& t : right.triangles)
    soup.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  return soup;
}

std::string to_off(const MeshSoup& soup) {
  std::string off;
  geometry::serialize_mesh(geometry::build_mesh(soup).mesh, geometry::MeshFormat::Off, {}, off);
  return off;
}

MeshSoup subdivide_midpoint(const MeshSoup& soup) {
  MeshSoup out;
  out.points = soup.points;
  std::unordered_map<std::uint64_t, std::uint32_t> mid;
  auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
    const std::uint64_t key = (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
    auto [it, inserted] = mid.try_emplace(key, static_cast<std::uint32_t>(out.points.size()));
    if (inserted) out.points.push_back(0.5 * (soup.points[a] + soup.points[b]));
    return it->second;
  };
  for (const auto& t : soup.triangles) {
    const std::uint32_t ab = midpoint(t[0], t[1]), bc = midpoint(t[1], t[2]),
                        ca = midpoint(t[2], t[0]);
    out.triangles.push_back({t[0], ab, ca});
    out.triangles.push_back({ab, t[1], bc});
    out.triangles.push_back({ca, bc, t[2]});
    out.triangles.push_back({ab, bc, ca});
  }
  return out;
}

MeshSoup cut_band(const MeshSoup& soup, double width_edges, std::size_t* removed) {
  if (soup.points.empty() || soup.triangles.empty()) return soup;
  Vec3 lo = soup.points.front(), hi = lo;
  for (const Vec3& p : soup.points) {
    lo.minimize(p);
    hi.maximize(p);
  }
  double edges = 0;
  for (const auto& t : soup.triangles)
    for (int k = 0; k < 3; ++k) edges += (soup.points[t[k]] - soup.points[t[(k + 1) % 3]]).norm();
  const double mean_edge = edges / (3.0 * static_cast<double>(soup.triangles.size()));
  const Vec3 size = hi - lo;
  const int axis = size[0] >= size[1] && size[0] >= size[2] ? 0 : (size[1] >= size[2] ? 1 : 2);
  const double centre = 0.5 * (lo[axis] + hi[axis]);
  const double half = 0.5 * width_edges * mean_edge;
  MeshSoup banded;
  banded.points = soup.points;
  for (const auto& t : soup.triangles) {
    bool inside = false;
    for (const auto v : t) inside = inside || std::abs(soup.points[v][axis] - centre) < half;
    if (!inside) banded.triangles.push_back(t);
  }
  if (removed) *removed = soup.triangles.size() - banded.triangles.size();
  return banded;
}

}  // namespace touchmend::testing
