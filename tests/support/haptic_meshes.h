#pragma once

//! \file haptic_meshes.h
//! \brief Plain-array test surfaces for the haptics tests and benchmark, and the allocation
//! probe (include allocation_probe.h in exactly one file of a binary).

#include <cmath>
#include <numbers>

#include "client/haptics/triangle_set.h"

namespace touchmend::testing {

//! A UV sphere of radius r (rings × around cells, poles as fans). With bumps > 0 the radius
//! varies by that fraction, so the surface is not locally convex everywhere.
inline haptics::SurfaceMesh uv_sphere_surface(double r, int around, int rings, double bumps = 0) {
  using haptics::Vec3;
  haptics::SurfaceMesh m;
  auto radius = [&](double th, double ph) {
    return r * (1.0 + bumps * std::sin(12 * th) * std::cos(9 * ph));
  };
  m.positions.push_back(Vec3(0, 0, radius(0, 0)));
  for (int i = 1; i < rings; ++i) {
    const double th = std::numbers::pi * i / rings;
    for (int j = 0; j < around; ++j) {
      const double ph = 2 * std::numbers::pi * j / around;
      const double rr = radius(th, ph);
      m.positions.push_back(Vec3(rr * std::sin(th) * std::cos(ph), rr * std::sin(th) * std::sin(ph),
                                 rr * std::cos(th)));
    }
  }
  m.positions.push_back(Vec3(0, 0, -radius(std::numbers::pi, 0)));
  const auto ring = [&](int i, int j) {
    return std::uint32_t(1 + (i - 1) * around + (j % around));
  };
  const auto south = std::uint32_t(m.positions.size() - 1);
  for (int j = 0; j < around; ++j) {
    m.triangles.push_back({0, ring(1, j), ring(1, j + 1)});
    for (int i = 1; i + 1 < rings; ++i) {
      m.triangles.push_back({ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)});
      m.triangles.push_back({ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)});
    }
    m.triangles.push_back({ring(rings - 1, j), south, ring(rings - 1, j + 1)});
  }
  return m;
}

}  // namespace touchmend::testing
