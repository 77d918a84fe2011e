#pragma once

//! \file god_object.h
//! \brief God-object contact on a triangle set (Zilles & Salisbury 1995; Ruspini, Kolarov &
//! Khatib 1997; HAPTICS.md §4.1, §6.3).
//!
//! \details The proxy is a point that never crosses the surface. Each tick it moves toward the
//! goal (the device position in model space): a segment sweep finds the first triangle in the
//! way; the proxy stops `epsilon` short of it on the side it came from, the triangle's plane
//! becomes a constraint, and the goal is projected onto the active constraint planes (one:
//! a plane, two: their line, three: a corner) before sweeping again — all constraints are
//! resolved in the same tick, not one per tick as CHAI3D's static mode does. The sweep is an
//! exact segment test, so thin plates and open scan surfaces cannot be tunnelled through and
//! both of their sides are touchable: the side is wherever the proxy already is. A hole is a
//! place with no triangles, so the proxy falls through it (the intended feel for finding holes).
//! Optional static friction keeps the proxy in place while the tangential pull stays inside
//! the friction cone.

#include "client/haptics/triangle_set.h"

namespace touchmend::haptics {

struct ContactOptions {
  double epsilon = 1e-5;  //!< model units the proxy keeps off the surface
  double friction = 0;    //!< static friction coefficient (0 = frictionless)
  int max_constraints = 3;
};

struct ContactResult {
  Vec3 proxy = Vec3::Zero();
  bool in_contact = false;
  int constraints = 0;
  Vec3 normal = Vec3::Zero();  //!< of the first constraint, facing the proxy
  std::uint32_t face_id = 0;   //!< document face under the proxy (valid when in_contact)
};

class GodObject {
 public:
  explicit GodObject(ContactOptions options = {}) : options_(options) {}
  //! Puts the proxy at \p position (no sweep): at start-up and after losing track.
  void reset(const Vec3& position);
  //! After the surface under the proxy changed (a remote edit): if the proxy was in contact,
  //! put it back on the new surface at the nearest point within \p max_distance, on the side
  //! it was touching from, so it does not end up behind the new surface (HAPTICS.md §6.3
  //! step 2). True if it moved.
  bool reseat(const TriangleSet& surface, double max_distance);
  //! One tick against \p surface toward \p goal (both in model space). No allocation.
  ContactResult update(const TriangleSet& surface, const Vec3& goal);
  const Vec3& proxy() const { return proxy_; }
  bool initialized() const { return initialized_; }
  void set_options(const ContactOptions& options) { options_ = options; }

 private:
  ContactOptions options_;
  Vec3 proxy_ = Vec3::Zero();
  bool initialized_ = false;
  bool was_in_contact_ = false;
  Vec3 contact_normal_ = Vec3::Zero();
};

}  // namespace touchmend::haptics
