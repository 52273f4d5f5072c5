#include "wbm/tasks/axis_task.hpp"

#include <cmath>

namespace wbm {

AxisTask::AxisTask(const Model& model, std::string name, const std::string& frame, const std::string& reference)
    : TaskElement(std::move(name), 2, 3, TargetKind::kDirection), frame_(model, frame, reference),
      J3_(3, model.num_dofs()) {}

void AxisTask::value(const Model& model, const Data& data, Eigen::Ref<Eigen::VectorXd> x) {
  x = frame_.pose(model, data).R.col(2);
}

Matrix3 AxisTask::sl_frame(const Vector3& a_g, const Vector3& a_t, const Vector3& fallback_y, double* phi) {
  const Vector3 z = a_g.normalized();
  const Vector3 t = a_t.normalized();
  const Vector3 c = z.cross(t);
  const double s = c.norm();
  *phi = std::atan2(s, z.dot(t));
  Vector3 y = s > 1e-12 ? Vector3(c / s) : Vector3((fallback_y - fallback_y.dot(z) * z).normalized());
  Matrix3 R;
  R.col(0) = y.cross(z);
  R.col(1) = y;
  R.col(2) = z;
  return R;
}

void AxisTask::evaluate(const Model& model, const Data& data, const Eigen::Ref<const Eigen::VectorXd>& target,
                        const Eigen::Ref<const Eigen::VectorXd>& target_rate, Eigen::Ref<Eigen::MatrixXd> J,
                        Eigen::Ref<Eigen::VectorXd> error, Eigen::Ref<Eigen::VectorXd> rate) {
  const Matrix3 R_RF = frame_.pose(model, data).R;
  const Vector3 a_t = target.head<3>();
  double phi = 0.0;
  const Matrix3 R_sl = sl_frame(R_RF.col(2), a_t, R_RF.col(1), &phi);
  frame_.rotational_jacobian(model, data, J3_);
  // eq. (18): rows x and y of A_sl-I * J_R.
  for (int c = 0; c < J.cols(); ++c) {
    const Vector3 w = J3_.col(c);
    J(0, c) = R_sl.col(0).dot(w);
    J(1, c) = R_sl.col(1).dot(w);
  }
  error << 0.0, phi;
  // Angular velocity of the moving unit target: w = a_t x d(a_t)/dt.
  const Vector3 unit_target = a_t.normalized();
  const Vector3 w = unit_target.cross(target_rate.head<3>());
  rate = R_sl.leftCols<2>().transpose() * w;
}

}  // namespace wbm
