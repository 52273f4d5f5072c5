#pragma once
/// @file
/// Rigid transforms and the frame naming convention used throughout wbm.
///
/// Monogram notation (as in Drake): `X_AB` is the pose of frame B measured in frame A,
/// `R_AB` its rotation, `p_AB` the position of B's origin in A. `p_WQ` is point Q in the
/// world frame W. `J_WF` is a Jacobian whose rows give velocities of frame F expressed in
/// W. In the paper's notation, `A_CP` (rotation from P into C) is `R_CP` = `R_PC^T`.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace wbm {

using Vector3 = Eigen::Vector3d;
using Matrix3 = Eigen::Matrix3d;

/// Rigid transform X_AB = (R_AB, p_AB): maps coordinates in B to coordinates in A.
struct Transform {
  Matrix3 R = Matrix3::Identity();
  Vector3 p = Vector3::Zero();

  static Transform Identity() { return {}; }
  /// Composition X_AC = X_AB * X_BC.
  Transform operator*(const Transform& X_BC) const { return {R * X_BC.R, R * X_BC.p + p}; }
  /// Maps a point given in B into A.
  Vector3 operator*(const Vector3& p_BQ) const { return R * p_BQ + p; }
  /// X_BA from X_AB.
  Transform inverse() const { return {R.transpose(), -(R.transpose() * p)}; }
};

/// Rotation matrix from URDF roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll).
inline Matrix3 rotation_from_rpy(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw, Vector3::UnitZ()) * Eigen::AngleAxisd(pitch, Vector3::UnitY()) *
          Eigen::AngleAxisd(roll, Vector3::UnitX()))
      .toRotationMatrix();
}

/// Roll-pitch-yaw (URDF convention, R = Rz Ry Rx) of a rotation matrix.
Vector3 rpy_from_rotation(const Matrix3& R);

/// Skew-symmetric matrix with skew(a) * b = a x b (the paper's tilde operator).
inline Matrix3 skew(const Vector3& a) {
  Matrix3 S;
  S << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return S;
}

}  // namespace wbm
