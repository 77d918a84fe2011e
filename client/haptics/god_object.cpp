#include "client/haptics/god_object.h"

#include <cmath>

#include <Eigen/LU>

namespace touchmend::haptics {
namespace {

struct Plane {
  Vec3 normal;    // unit, facing the free side
  double offset;  // normal · y >= offset on the free side
};

//! The point nearest \p goal on the intersection of the planes (as equalities). With three
//! independent planes that is their corner; dependent planes are dropped.
Vec3 project_onto(const Plane* planes, int count, const Vec3& goal) {
  if (count == 0) return goal;
  if (count == 1) return goal - (planes[0].normal.dot(goal) - planes[0].offset) * planes[0].normal;
  // Lagrange: y = goal − Nᵀλ with N·y = d  →  (N Nᵀ) λ = N·goal − d.
  Eigen::Matrix<double, 3, 3> NNt = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  for (int i = 0; i < count; ++i) {
    for (int j = 0; j < count; ++j) NNt(i, j) = planes[i].normal.dot(planes[j].normal);
    rhs[i] = planes[i].normal.dot(goal) - planes[i].offset;
  }
  if (count == 2) {
    const Eigen::Matrix2d m = NNt.topLeftCorner<2, 2>();
    if (std::abs(m.determinant()) < 1e-12) return project_onto(planes + 1, 1, goal);
    const Eigen::Vector2d lambda = m.inverse() * rhs.head<2>();
    return goal - lambda[0] * planes[0].normal - lambda[1] * planes[1].normal;
  }
  if (std::abs(NNt.determinant()) < 1e-12) return project_onto(planes + 1, 2, goal);
  const Eigen::Vector3d lambda = NNt.inverse() * rhs;
  return goal - lambda[0] * planes[0].normal - lambda[1] * planes[1].normal -
         lambda[2] * planes[2].normal;
}

}  // namespace

void GodObject::reset(const Vec3& position) {
  proxy_ = position;
  initialized_ = true;
  was_in_contact_ = false;
}

bool GodObject::reseat(const TriangleSet& surface, double max_distance) {
  if (!initialized_ || !was_in_contact_) return false;
  ClosestHit hit;
  if (!surface.closest(proxy_, max_distance, hit)) return false;
  Vec3 n = surface.normal(hit.triangle);
  if (n.dot(contact_normal_) < 0) n = -n;
  proxy_ = hit.point + options_.epsilon * n;
  return true;
}

ContactResult GodObject::update(const TriangleSet& surface, const Vec3& goal) {
  ContactResult result;
  if (!initialized_ || !proxy_.allFinite()) reset(goal);
  if (!goal.allFinite()) {
    result.proxy = proxy_;
    return result;
  }
  const double eps = options_.epsilon;
  Plane planes[3];
  int count = 0;
  Vec3 x = proxy_;
  Vec3 target = goal;
  for (int iteration = 0; iteration <= options_.max_constraints; ++iteration) {
    if ((target - x).squaredNorm() <= eps * eps * 1e-4) {
      x = target;
      break;
    }
    SegmentHit hit;
    if (!surface.first_hit(x, target, hit)) {
      x = target;
      break;
    }
    Vec3 n = surface.normal(hit.triangle);
    const Vec3& on_plane = surface.corners(hit.triangle)[0];
    if (n.dot(x - on_plane) < 0) n = -n;  // two-sided: the free side is where we came from
    // Stop short of the surface: back along the path by what keeps eps off the plane.
    const Vec3 direction = target - x;
    const double approach = -n.dot(direction);  // > 0: moving into the plane
    double back = 0;
    if (approach > 0) back = std::min(hit.t, eps / approach);
    x = x + (hit.t - back) * direction;
    if (count == 0) {
      result.normal = n;
      result.face_id = surface.face_id(hit.triangle);
    }
    if (count == options_.max_constraints) break;  // a corner: the proxy stops here
    planes[count++] = {n, n.dot(on_plane) + eps};
    target = project_onto(planes, count, goal);
    // The projection must not undo the progress: if it points back into an active plane
    // (a dependent set), stay.
    bool inside = false;
    for (int i = 0; i < count; ++i)
      if (planes[i].normal.dot(target) < planes[i].offset - eps) inside = true;
    if (inside || !target.allFinite()) break;
  }
  // Static friction (a cone around the normal): while the pull along the surface is below
  // friction × the pull into it, the proxy does not slide.
  if (options_.friction > 0 && count > 0 && was_in_contact_) {
    const Vec3 slide = x - proxy_;
    const Vec3 pull = goal - x;
    const double into = std::abs(pull.dot(result.normal));
    const Vec3 tangential = slide - slide.dot(result.normal) * result.normal;
    if (tangential.norm() < options_.friction * into) {
      // Stay, but never inside the surface: keep the new normal offset.
      x = proxy_ + slide.dot(result.normal) * result.normal;
    }
  }
  proxy_ = x;
  result.proxy = x;
  result.constraints = count;
  result.in_contact = count > 0;
  was_in_contact_ = result.in_contact;
  if (result.in_contact) contact_normal_ = result.normal;
  return result;
}

}  // namespace touchmend::haptics
