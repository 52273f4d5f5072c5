#pragma once
#include "wbm/task_element.hpp"

namespace wbm {

/// 3-dof attitude of a frame as Kardan angles (section IV.B), 3 rows:
/// R_RF = Rx(a) Ry(b) Rz(c), target (a, b, c) [rad] in the reference frame.
///
/// The rows are the relative angular-velocity Jacobian projected on Kardan rates with
/// d(a,b,c)/dt = E(a,b)^-1 w, E = [e_x, Rx(a) e_y, Rx(a) Ry(b) e_z]. The representation is
/// singular at cos(b) = 0 (b = +-90 deg, gimbal lock): there cos(b) is kept at least 1e-3 in
/// magnitude so the rows stay finite.
///
/// Error: with some rows inactive, each active angle's difference to its target, wrapped
/// to (-pi, pi], the target first written with its pitch within +-90 deg (canonical_angles:
/// a pitch target past 90 deg alone is reached as the pitch of the same rotation, not
/// chased past gimbal lock for ever). With all three active, the rotation from the frame to the target,
/// E^-1 log(R_target R^T) (angle times axis, mapped on Kardan rates), and the feed-forward
/// rate E^-1 E_target d(target)/dt: both continuous across gimbal lock, where the angles of
/// the frame jump by pi, and for targets with |b| > 90 deg, which no angles of the frame
/// reach (the same rotation as (a + pi, pi - b, c + pi)). The two agree to first order (for
/// one active row and a pitch target within 90 deg, the rotation error with the other
/// angles at their current values is exactly the angle difference). Differences in angles
/// alone made a frame pitched past 90 degrees chatter at every cycle (docs/solver.md).
class AttitudeTask : public TaskElement {
 public:
  /// @throws ModelError if a frame is unknown.
  AttitudeTask(const Model& model, std::string name, const std::string& frame, const std::string& reference = "");
  void value(const Model& model, const Data& data, Eigen::Ref<Eigen::VectorXd> x) override;
  void evaluate(const Model& model, const Data& data, const Eigen::Ref<const Eigen::VectorXd>& target,
                const Eigen::Ref<const Eigen::VectorXd>& target_rate, Eigen::Ref<Eigen::MatrixXd> J,
                Eigen::Ref<Eigen::VectorXd> error, Eigen::Ref<Eigen::VectorXd> rate) override;
  /// Kardan angles (a, b, c) of R = Rx(a) Ry(b) Rz(c).
  static Vector3 kardan_angles(const Matrix3& R);
  static Matrix3 kardan_rotation(const Vector3& angles);
  /// The Kardan angles of the same rotation with the pitch b within [-pi/2, pi/2]:
  /// (a + pi, +-pi - b, c + pi) where |b| (wrapped to (-pi, pi]) exceeds pi/2, else unchanged.
  static Vector3 canonical_angles(const Vector3& angles);
  /// E(a, b): Kardan rates to angular velocity, w = E d(a,b,c)/dt.
  static Matrix3 kardan_rate_matrix(const Vector3& angles);

 private:
  RelativeFrame frame_;
  Eigen::MatrixXd J3_;
};

}  // namespace wbm
