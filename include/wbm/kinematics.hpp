#pragma once
/// @file
/// Forward kinematics (eqs. 2-3), geometric Jacobians (eqs. 9-13) and the centre of mass.
/// None of these functions allocate.

#include <limits>
#include <vector>

#include <Eigen/Core>

#include "wbm/model.hpp"

namespace wbm {

/// Mutable kinematic workspace, sized once from a Model.
struct Data {
  /// @post every buffer is sized for `model`; nothing is allocated afterwards.
  explicit Data(const Model& model);

  Eigen::VectorXd q;              ///< Configuration of the last forward_kinematics().
  std::vector<Transform> X_WB;   ///< Pose of every body in the world.
  std::vector<Vector3> a_W;      ///< Joint axis of every body, in the world (unit).
  std::vector<Vector3> mc_W;     ///< Subtree sum of mass * com position, world [kg m].
  Vector3 p_WCm = Vector3::Zero();  ///< Whole-body centre of mass [m], after center_of_mass().

  /// Sine and cosine of a revolute joint's angle [rad] where the last libm call was made.
  struct AngleAnchor {
    double angle = std::numeric_limits<double>::quiet_NaN();  ///< NaN: none yet
    double sin = 0.0;
    double cos = 1.0;
  };
  /// Per body: forward_kinematics() rotates the anchor by the difference of the angles while
  /// it is within 1/8 rad of the anchor (a short series instead of a libm call; absolute
  /// error below 2.5e-16) and calls libm and moves the anchor otherwise.
  std::vector<AngleAnchor> angle_anchor;
};

/// Forward kinematics of all bodies for configuration q (eqs. 2-3).
/// The joint angles' sines and cosines come from an earlier call's where the angle moved by
/// at most 1/8 rad since (Data::angle_anchor): the results can differ from a fresh Data's in
/// the last bits.
/// @pre q.size() == model.num_dofs().
void forward_kinematics(const Model& model, Data& data, const Eigen::Ref<const Eigen::VectorXd>& q);

/// Pose of a named frame in the world, X_WF, from the last forward_kinematics().
inline Transform frame_pose(const Model& model, const Data& data, int frame) {
  const Frame& f = model.frame(frame);
  return data.X_WB[f.body] * f.X_BF;
}

/// Position of a named frame in the world, p_WF (frame_pose().p without the rotation product).
inline Vector3 frame_position(const Model& model, const Data& data, int frame) {
  const Frame& f = model.frames()[frame];
  return data.X_WB[f.body] * f.X_BF.p;
}

/// Translational Jacobian (3 x nq) of point Q fixed to `body`, given in the world:
/// column i is a_i x (p_WQ - p_i) for revolute and a_i for prismatic joints (eq. 13).
/// `J` is overwritten.
void point_jacobian(const Model& model, const Data& data, int body, const Vector3& p_WQ,
                    Eigen::Ref<Eigen::MatrixXd> J);

/// Rotational Jacobian (3 x nq) of `body`: angular velocity in the world (eqs. 10, 12).
void rotational_jacobian(const Model& model, const Data& data, int body,
                         Eigen::Ref<Eigen::MatrixXd> J);

/// Both at once, 6 x nq: rows 0-2 the translational velocity of the frame origin,
/// rows 3-5 the angular velocity, both in the world frame.
void frame_jacobian(const Model& model, const Data& data, int frame, Eigen::Ref<Eigen::MatrixXd> J);

/// Whole-body centre of mass p_WCm [m]; also fills data.mc_W for com_jacobian().
/// @pre forward_kinematics() was called; model.total_mass() > 0.
Vector3 center_of_mass(const Model& model, Data& data);

/// Whole-body centre of mass [m] from the last forward_kinematics(), without touching Data.
/// @pre model.total_mass() > 0.
Vector3 center_of_mass_position(const Model& model, const Data& data);

/// Jacobian (3 x nq) of the whole-body centre of mass. @pre center_of_mass() was called.
void com_jacobian(const Model& model, const Data& data, Eigen::Ref<Eigen::MatrixXd> J);

}  // namespace wbm
