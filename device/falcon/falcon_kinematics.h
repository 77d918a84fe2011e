#pragma once

//! \file falcon_kinematics.h
//! \brief Kinematics of the Falcon's three-legged delta (Stamper's translational parallel
//! manipulator), from the geometry facts of HAPTICS.md §2.10. Pure functions.
//!
//! \details Leg i's frame is the device frame turned by −φᵢ about z and shifted by (−r, −s, 0).
//! In it the leg closes when
//!   P_x + c − a·cos θ₁ = R·cos θ₂,   P_z − a·sin θ₁ = R·sin θ₂,   P_y + f = b·cos θ₃,
//! with R = d + e + b·sin θ₃ (θ₁ the motor arm, θ₂ and θ₃ the passive parallelogram joints).
//! Eliminating θ₂ gives (P_x + c − a cos θ₁)² + (P_z − a sin θ₁)² = R², a quadratic in
//! T = tan(θ₁/2) — inverse kinematics in closed form. Forward kinematics has no closed form:
//! Newton's method on the three motor angles, warm-started from the previous position. The
//! Jacobian of the motor angles with respect to the position follows by implicit
//! differentiation of the same equation; torques are Jᵀ·F with J = (∂θ/∂p)⁻¹.

#include <array>
#include <cstdint>

#include <Eigen/Core>

namespace touchmend::device::falcon {

struct Geometry {
  double a = 0.060;                                     //!< leg base to knee
  double b = 0.1025;                                    //!< parallelogram side
  double c = 0.01443;                                   //!< shin joint to effector centre, u
  double d = 0.01125;                                   //!< shin to effector joint
  double e = 0.01125;                                   //!< knee to shin joint
  double f = -0.025;                                    //!< shin joint to effector centre, v
  double r = 0.0400;                                    //!< frame origin to leg base, u
  double s = -0.02309;                                  //!< frame origin to leg base, v
  std::array<double, 3> phi_deg{105.0, -15.0, -135.0};  //!< leg angles about the device axis
  double encoder_deg_per_count = 0.01425 * 360.0 / (320.0 * 4.0 * 0.110);  //!< ≈ 0.036435°
  double theta_offset_deg = 35.0;                                          //!< θ₁ at count 0
};

using Angles = Eigen::Vector3d;  //!< the three motor-arm angles θ₁ (radians)

//! Encoder counts → motor angles.
Angles angles_from_encoders(const Geometry& g, const std::array<std::int16_t, 3>& encoders);
//! Motor angles → (fractional) encoder counts (for tests and the fake device).
Eigen::Vector3d encoders_from_angles(const Geometry& g, const Angles& angles);

//! θ₁ of each leg for an effector position (metres, device frame); false where the position
//! is out of reach (the quadratic has no real root or θ₃ is undefined).
bool inverse_kinematics(const Geometry& g, const Eigen::Vector3d& position, Angles& angles);

//! ∂θ₁/∂p, one row per leg; false out of reach or at a singular pose.
bool angle_jacobian(const Geometry& g, const Eigen::Vector3d& position, Eigen::Matrix3d& d_angles);

struct ForwardResult {
  bool converged = false;
  int iterations = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
};
//! Position for the motor angles by Newton's method from \p seed (the previous position; the
//! origin itself is singular, so start from (0, 0, 0.11) the first time). Stops when the
//! angle error is below 1e-9 rad or after 15 iterations.
ForwardResult forward_kinematics(const Geometry& g, const Angles& angles,
                                 const Eigen::Vector3d& seed);

//! Force (N, device frame) → motor commands: torques τ = Jᵀ·F, times −gain counts per N·m,
//! then scaled together so none exceeds ±4095 (the force direction is kept). The gain is
//! uncalibrated (HAPTICS.md §2.10: published values disagree ~5x): keep caps low.
bool motor_commands(const Geometry& g, const Eigen::Vector3d& position,
                    const Eigen::Vector3d& force, double gain,
                    std::array<std::int16_t, 3>& commands, bool* scaled = nullptr);

}  // namespace touchmend::device::falcon
