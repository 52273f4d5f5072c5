#include "wbm/tasks/attitude_task.hpp"

#include <cmath>

namespace wbm {
namespace {

double wrap(double angle) { return std::remainder(angle, 2.0 * M_PI); }

}  // namespace

AttitudeTask::AttitudeTask(const Model& model, std::string name, const std::string& frame, const std::string& reference)
    : TaskElement(std::move(name), 3, 3, TargetKind::kVector, 2.0 * M_PI), frame_(model, frame, reference),
      J3_(3, model.num_dofs()) {
  for (int row = 0; row < 3; ++row) set_row_unit(row, RowUnit::kAngle);
}

Vector3 AttitudeTask::kardan_angles(const Matrix3& R) {
  // R = Rx(a) Ry(b) Rz(c): R(0,2) = sin b, R(1,2) = -sin a cos b, R(2,2) = cos a cos b,
  // R(0,1) = -cos b sin c, R(0,0) = cos b cos c.
  const double b = std::atan2(R(0, 2), std::hypot(R(1, 2), R(2, 2)));
  const double a = std::atan2(-R(1, 2), R(2, 2));
  const double c = std::atan2(-R(0, 1), R(0, 0));
  return {a, b, c};
}

Matrix3 AttitudeTask::kardan_rotation(const Vector3& angles) {
  return (Eigen::AngleAxisd(angles.x(), Vector3::UnitX()) * Eigen::AngleAxisd(angles.y(), Vector3::UnitY()) *
          Eigen::AngleAxisd(angles.z(), Vector3::UnitZ()))
      .toRotationMatrix();
}

Vector3 AttitudeTask::canonical_angles(const Vector3& angles) {
  const double b = wrap(angles.y());
  if (std::abs(b) <= 0.5 * M_PI) return angles;
  return {angles.x() + M_PI, std::copysign(M_PI, b) - b, angles.z() + M_PI};
}

Matrix3 AttitudeTask::kardan_rate_matrix(const Vector3& angles) {
  const double sa = std::sin(angles.x()), ca = std::cos(angles.x());
  const double sb = std::sin(angles.y()), cb = std::cos(angles.y());
  Matrix3 E;
  E << 1.0, 0.0, sb, 0.0, ca, -sa * cb, 0.0, sa, ca * cb;
  return E;
}

void AttitudeTask::value(const Model& model, const Data& data, Eigen::Ref<Eigen::VectorXd> x) {
  x = kardan_angles(frame_.pose(model, data).R);
}

void AttitudeTask::evaluate(const Model& model, const Data& data, const Eigen::Ref<const Eigen::VectorXd>& target,
                            const Eigen::Ref<const Eigen::VectorXd>& target_rate, Eigen::Ref<Eigen::MatrixXd> J,
                            Eigen::Ref<Eigen::VectorXd> error, Eigen::Ref<Eigen::VectorXd> rate) {
  const Matrix3 R = frame_.pose(model, data).R;
  const Vector3 angles = kardan_angles(R);
  const double sa = std::sin(angles.x()), ca = std::cos(angles.x());
  const double sb = std::sin(angles.y());
  double cb = std::cos(angles.y());
  if (std::abs(cb) < 1e-3) cb = std::copysign(1e-3, cb);
  // Inverse of E = [[1, 0, sb], [0, ca, -sa cb], [0, sa, ca cb]].
  Matrix3 E_inv;
  E_inv << 1.0, sa * sb / cb, -ca * sb / cb, 0.0, ca, sa, 0.0, -sa / cb, ca / cb;
  frame_.rotational_jacobian(model, data, J3_);
  for (int c = 0; c < J.cols(); ++c) J.col(c) = E_inv * Vector3(J3_.col(c));
  if (!all_rows_active()) {
    const Vector3 t = canonical_angles(target);
    for (int i = 0; i < 3; ++i) error[i] = wrap(t[i] - angles[i]);
    rate = target_rate;
    if (t.y() != target[1]) rate[1] = -target_rate[1];  // the canonical pitch moves the other way
    return;
  }
  const Vector3 t = target;
  const Eigen::AngleAxisd to_target(kardan_rotation(t) * R.transpose());
  error = E_inv * (to_target.angle() * to_target.axis());
  rate = E_inv * (kardan_rate_matrix(t) * Vector3(target_rate));
}

}  // namespace wbm
