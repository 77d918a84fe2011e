#include "device/falcon/falcon_kinematics.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/LU>

#include "device/falcon/falcon_protocol.h"

namespace touchmend::device::falcon {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

//! The rotation taking device coordinates into leg i's frame (turn by −φᵢ about z).
Eigen::Matrix3d leg_rotation(const Geometry& g, int leg) {
  const double phi = g.phi_deg[static_cast<std::size_t>(leg)] * kDeg;
  Eigen::Matrix3d m;
  m << std::cos(phi), std::sin(phi), 0, -std::sin(phi), std::cos(phi), 0, 0, 0, 1;
  return m;
}

Eigen::Vector3d leg_point(const Geometry& g, int leg, const Eigen::Vector3d& p) {
  return leg_rotation(g, leg) * p - Eigen::Vector3d(g.r, g.s, 0);
}

struct LegSolution {
  bool ok = false;
  double theta = 0;
  double sin3 = 0;
  double radius = 0;  // R = d + e + b sin θ₃
};

LegSolution solve_leg(const Geometry& g, const Eigen::Vector3d& P) {
  LegSolution s;
  const double cos3 = (P.y() + g.f) / g.b;
  if (!(std::abs(cos3) < 1.0)) return s;
  s.sin3 = std::sqrt(1.0 - cos3 * cos3);
  s.radius = g.d + g.e + g.b * s.sin3;
  const double X = P.x() + g.c;
  const double K = X * X + P.z() * P.z() + g.a * g.a - s.radius * s.radius;
  const double l2 = K + 2 * g.a * X;
  const double l1 = -4 * g.a * P.z();
  const double l0 = K - 2 * g.a * X;
  double T = 0;
  if (std::abs(l2) < 1e-15) {
    if (std::abs(l1) < 1e-15) return s;
    T = -l0 / l1;
  } else {
    const double disc = l1 * l1 - 4 * l0 * l2;
    if (disc < 0) return s;
    T = (-l1 - std::sqrt(disc)) / (2 * l2);
  }
  s.theta = 2 * std::atan(T);
  s.ok = std::isfinite(s.theta);
  return s;
}

}  // namespace

Angles angles_from_encoders(const Geometry& g, const std::array<std::int16_t, 3>& encoders) {
  Angles a;
  for (int i = 0; i < 3; ++i)
    a[i] = (encoders[static_cast<std::size_t>(i)] * g.encoder_deg_per_count + g.theta_offset_deg) *
           kDeg;
  return a;
}

Eigen::Vector3d encoders_from_angles(const Geometry& g, const Angles& angles) {
  return (angles / kDeg - Eigen::Vector3d::Constant(g.theta_offset_deg)) / g.encoder_deg_per_count;
}

bool inverse_kinematics(const Geometry& g, const Eigen::Vector3d& position, Angles& angles) {
  for (int i = 0; i < 3; ++i) {
    const LegSolution s = solve_leg(g, leg_point(g, i, position));
    if (!s.ok) return false;
    angles[i] = s.theta;
  }
  return true;
}

bool angle_jacobian(const Geometry& g, const Eigen::Vector3d& position, Eigen::Matrix3d& d_angles) {
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d P = leg_point(g, i, position);
    const LegSolution s = solve_leg(g, P);
    if (!s.ok || s.sin3 < 1e-9) return false;
    // G(P, θ) = (X − a cos θ)² + (P_z − a sin θ)² − R(P_y)² = 0, X = P_x + c.
    const double X = P.x() + g.c;
    const double ct = std::cos(s.theta), st = std::sin(s.theta);
    const double dG_dtheta = 2 * g.a * (X * st - P.z() * ct);
    if (std::abs(dG_dtheta) < 1e-12) return false;  // singular pose
    const Eigen::RowVector3d dG_dP(
        2 * (X - g.a * ct), 2 * s.radius * (P.y() + g.f) / (g.b * s.sin3), 2 * (P.z() - g.a * st));
    d_angles.row(i) = -(dG_dP / dG_dtheta) * leg_rotation(g, i);
  }
  return true;
}

ForwardResult forward_kinematics(const Geometry& g, const Angles& angles,
                                 const Eigen::Vector3d& seed) {
  ForwardResult out;
  Eigen::Vector3d p = seed;
  Angles current;
  if (!inverse_kinematics(g, p, current)) {
    p = Eigen::Vector3d(0, 0, 0.11);
    if (!inverse_kinematics(g, p, current)) return out;
  }
  double error = (angles - current).norm();
  for (out.iterations = 1; out.iterations <= 15; ++out.iterations) {
    Eigen::Matrix3d D;
    if (!angle_jacobian(g, p, D)) break;
    const Eigen::FullPivLU<Eigen::Matrix3d> lu(D);
    if (!lu.isInvertible()) break;
    Eigen::Vector3d step = lu.solve(angles - current);
    // Damped Newton: halve the step while it does not reduce the angle error.
    for (int halving = 0; halving < 20; ++halving) {
      Angles trial;
      const Eigen::Vector3d q = p + step;
      if (inverse_kinematics(g, q, trial) && (angles - trial).norm() < error) {
        p = q;
        current = trial;
        error = (angles - trial).norm();
        break;
      }
      step *= 0.5;
    }
    if (error < 1e-9) {
      out.converged = true;
      break;
    }
  }
  out.position = p;
  out.converged = out.converged || error < 1e-9;
  return out;
}

bool motor_commands(const Geometry& g, const Eigen::Vector3d& position,
                    const Eigen::Vector3d& force, double gain,
                    std::array<std::int16_t, 3>& commands, bool* scaled) {
  commands = {0, 0, 0};
  if (scaled) *scaled = false;
  if (!force.allFinite() || !position.allFinite()) return false;
  Eigen::Matrix3d D;
  if (!angle_jacobian(g, position, D)) return false;
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(D);
  if (!lu.isInvertible()) return false;
  // J = D⁻¹ maps motor rates to effector velocity; torque τ = Jᵀ F = D⁻ᵀ F.
  const Eigen::Vector3d torque = D.transpose().fullPivLu().solve(force);
  Eigen::Vector3d counts = -gain * torque;
  const double largest = counts.cwiseAbs().maxCoeff();
  if (largest > double(kMaxMotorCommand)) {
    counts *= double(kMaxMotorCommand) / largest;  // all three together: the direction holds
    if (scaled) *scaled = true;
  }
  for (int i = 0; i < 3; ++i)
    commands[static_cast<std::size_t>(i)] = static_cast<std::int16_t>(std::lround(counts[i]));
  return true;
}

}  // namespace touchmend::device::falcon
