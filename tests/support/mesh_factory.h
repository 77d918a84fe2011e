#pragma once

//! \file mesh_factory.h
//! \brief Synthetic meshes built in the tests (grids, cylinders, spheres, cubes, annuli) and
//! helpers that cut holes into them.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "server/geometry/mesh.h"

namespace touchmend::testing {

using geometry::MeshSoup;
using geometry::Vec3;

//! A (nx x ny)-cell grid in the z = f(x, y) graph over [0, nx] x [0, ny], counter-clockwise
//! seen from +z.
MeshSoup grid(int nx, int ny, const std::function<double(double, double)>& height = {});

//! grid(16, 16, height) with a round hole of radius 4 in the middle (about 30 boundary edges).
MeshSoup grid_with_round_hole(const std::function<double(double, double)>& height = {});

//! An open cylinder of radius r around the z axis, `around` vertices per ring, `rings`
//! rings from z = 0 to z = height, outward-facing.
MeshSoup cylinder(double r, double height, int around, int rings);

//! Closed sphere (latitude-longitude) of radius r, outward-facing.
MeshSoup uv_sphere(double r, int around, int rings);

//! Closed axis-aligned cube [0, n]^3 with n x n cells per side, outward-facing.
MeshSoup cube(int n);

//! A flat annulus in z = 0 around a hole of `inner` boundary vertices (radius r_in),
//! with `rings` rings of quads outward: a planar hole of exactly `inner` edges.
MeshSoup annulus(int inner, double r_in, int rings, double ring_width);

//! Removes the faces whose predicate is true (and then unreferenced vertices, compacting
//! indices). Returns the removed triangles' corner positions via \p removed if given.
MeshSoup remove_faces(const MeshSoup& soup, const std::function<bool(const Vec3& centroid)>& remove,
                      std::vector<std::array<Vec3, 3>>* removed = nullptr);

//! \p soup with the faces whose centroid lies within \p radius of \p centre removed, but for
//! one that touches the faces kept at exactly one vertex: an island attached at a vertex inside
//! the hole, whose loop then passes that vertex twice (a pinched hole). The whole disk is removed
//! when no face qualifies.
MeshSoup cut_leaving_an_island(const MeshSoup& soup, const Vec3& centre, double radius);

//! A comb, as random cuts leave it on couplingdown's cylinder walls (strips of long triangles):
//! cylinder(0.05, 1.0, 48, 6), bands 0.2 high, cut in a sector of 1 radian through its fourth
//! band and the triangles of its third band with one corner on the lower ring, so that only
//! the teeth between them stay (each with two corners on the lower ring). The gaps between
//! the teeth have 1.9° corners at the lower ring.
//!  - Attached: the teeth stand on the second band; the hole's loop zigzags along them, each
//!    gap a narrow notch of it.
//!  - Lone: the second band is cut too, and the third past 1 radian, so the teeth touch each
//!    other at their lower corners only and the last is free: the hole's one loop passes each
//!    shared corner twice. The chords across the lower ring under them would have 3.75° corners.
enum class CombTeeth { Attached, Lone };
MeshSoup comb_cut_cylinder(CombTeeth teeth);

//! A grid folded by \p fold_deg along the x axis (the crease; 0: flat), x in [0, 10], with a
//! slot cut along the crease from x = 4 to 8: the faces of the crease vertices at x = 5, 6, 7.
//! The half y >= 0 lies in z = 0 facing +z; the other half turns up by the fold (a valley for a
//! positive angle, a ridge for a negative one).
//! Rows lie at 0.1 on either side of the crease and then 1 apart, and the diagonals of the two
//! rows beside it run from the crease outwards, so the slot ends at crease vertex (4, 0, 0) in a
//! narrow notch between (5, 0.1) on one side and (5, -0.1) on the other (8.1° folded by 90°,
//! 11.4° flat), whose ear spans the slot across the crease.
MeshSoup grid_with_a_slot_along_a_fold(double fold_deg);

//! A round pocket of \p radius and \p depth (axis z, \p around sides) in a plate at z = 0: the
//! plate's annulus (rings 1 apart out to radius + 3) and the pocket's floor (a fan in z = -depth)
//! facing +z, the wall (\p wall_rows rows of quads, rings evenly spaced down it; vertex i of the
//! mouth at angle 2πi / around) facing the axis. The plate's outer border is open.
MeshSoup plate_with_a_pocket(int around, double radius, double depth, int wall_rows = 1);

//! A counterbore in a plate at z = 0 (axis z, \p around sides): the plate's annulus (rings 1 apart
//! out to radius + 3), the counterbore's wall (radius \p radius, down to -\p depth), its floor
//! (an annulus in z = -depth in to \p bore_radius), the bore's wall (one row of strips down to
//! -\p bore_depth: vertex i of its top ring at angle 2πi / around) and the bore's floor (a fan).
//! Floors and plate face +z, walls the axis; the plate's outer border is open.
MeshSoup plate_with_a_counterbore(int around, double radius, double depth, double bore_radius,
                                  double bore_depth);

//! \p soup with a separate right triangle of unit legs added at \p corner (in z = corner's z):
//! a fragment, whose outline is a three-edge loop.
MeshSoup with_lone_triangle(MeshSoup soup, const Vec3& corner);

//! The cube [0, n]³ with the faces whose centroid lies within \p radius of \p centre removed
//! (a hole across an edge or a corner when the centre is on one).
MeshSoup cube_with_hole(int n, const Vec3& centre, double radius);

//! Two n x n-cell grids in z = 0 facing +z, the second shifted by n + gap along x: two
//! registered surfaces with a straight gap (left vertex (x, y) = y(n+1)+x, right = (n+1)² + that).
MeshSoup two_plates(int n, double gap);

//! \p soup as OFF text (through the mesh builder, as a client would upload it).
std::string to_off(const MeshSoup& soup);

//! \p soup with a band cut out across its middle: every face with a corner in the slab
//! \p width_edges mean edge lengths wide through the bounding-box centre, normal to the longest
//! axis (two registered surfaces with a gap between them). \p removed gets the number of faces
//! cut.
MeshSoup cut_band(const MeshSoup& soup, double width_edges, std::size_t* removed = nullptr);

//! 1-to-4 midpoint subdivision (same surface, twice the boundary vertices).
MeshSoup subdivide_midpoint(const MeshSoup& soup);

}  // namespace touchmend::testing
