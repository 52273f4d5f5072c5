#pragma once
#include "wbm/task_element.hpp"

namespace wbm {

/// 3-dof attitude of a frame as Kardan angles (section IV.B), 3 rows:
/// R_RF = Rx(a) Ry(b) Rz(c), target (a, b, c) [rad] in the reference frame.
///
/// The rows are the relative angular-velocity Jacobian projected on Kardan rates with
/// d(a,b,c)/dt = E(a,b)^-1 w, E = [e_x, Rx(a) e_y, Rx(a) Ry(b) e_z]. The representation is
/// singular at cos(b) = 0 (b = +-90 deg, gimbal lock): there cos(b) is kept at least 1e-3 in
/// magnitude so the rows stay finite; the solver's damping bounds the joint rates. Errors
/// are angle differences wrapped to (-pi, pi].
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

 private:
  RelativeFrame frame_;
  Eigen::MatrixXd J3_;
};

}  // namespace wbm
