#include "wbm/tasks/axis_task.hpp"

#include <cmath>

#include "wbm/errors.hpp"

#include "../fast_trig.hpp"
#include "../zero_block.hpp"

namespace wbm {

AxisTask::AxisTask(const Model& model, std::string name, const std::string& frame, const std::string& reference,
                   const Vector3& axis)
    : TaskElement(std::move(name), 2, 3, TargetKind::kDirection), frame_(model, frame, reference) {
  const double norm = axis.stableNorm();
  if (!(norm > 0.0 && std::isfinite(norm)))
    throw ConfigError("axis task '" + this->name() + "': the axis in frame '" + frame +
                      "' must be a finite, non-zero vector");
  a_F_ = axis / norm;
  z_axis_ = a_F_ == Vector3::UnitZ();
  // The fallback y: the frame's y-axis made perpendicular to the axis (y itself for z).
  y_F_ = Vector3::UnitY() - a_F_.y() * a_F_;
  if (y_F_.norm() < 1e-6) y_F_ = Vector3::UnitZ() - a_F_.z() * a_F_;
  y_F_.normalize();
}

void AxisTask::value(const Model& model, const Data& data, Eigen::Ref<Eigen::VectorXd> x) {
  if (z_axis_)
    x = frame_.z_axis(model, data);
  else
    x = frame_.pose(model, data).R * a_F_;
}

Matrix3 AxisTask::sl_frame(const Vector3& a_g, const Vector3& a_t, const Vector3& fallback_y, double* phi) {
  const Vector3 z = internal::normalized_near_unit(a_g);
  const Vector3 t = internal::normalized_near_unit(a_t);
  const Vector3 c = z.cross(t);
  const double s2 = c.squaredNorm();
  const double s = std::sqrt(s2);
  *phi = internal::angle_between_unit_vectors(s, s2, z.dot(t));  // the tracking error: mostly small
  Vector3 y = s > 1e-12 ? Vector3(c * (1.0 / s)) : Vector3((fallback_y - fallback_y.dot(z) * z).normalized());
  Matrix3 R;
  R.col(0) = y.cross(z);
  R.col(1) = y;
  R.col(2) = z;
  return R;
}

namespace {

/// J += sign * P * (rotational Jacobian of `body`): the chain's joint axes projected on the
/// two rows of P (world coordinates), without a 3 x n intermediate. Plain scalars and column
/// pointers, inlined: with the Eigen version (2 x 3 product, Ref indexing, a call per
/// chain) GCC's task assembly took 3-7 % longer (bench/README.md, "Tried").
[[gnu::always_inline]] inline void add_projected_axes(const Model& model, const Data& data, int body,
                                                      const Eigen::Matrix<double, 2, 3>& P, double sign,
                                                      Eigen::Ref<Eigen::MatrixXd>& J) {
  const Body* bodies = model.bodies().data();
  double* const columns = J.data();
  const Eigen::Index stride = J.outerStride();
  const double p00 = sign * P(0, 0), p01 = sign * P(0, 1), p02 = sign * P(0, 2);
  const double p10 = sign * P(1, 0), p11 = sign * P(1, 1), p12 = sign * P(1, 2);
  for (const int b : model.moving_bodies(body)) {
    const Body& B = bodies[b];
    if (B.joint_type != JointType::kRevolute) continue;
    const Vector3& a = data.a_W[b];
    double* col = columns + B.dof * stride;
    col[0] += B.multiplier * (p00 * a.x() + p01 * a.y() + p02 * a.z());
    col[1] += B.multiplier * (p10 * a.x() + p11 * a.y() + p12 * a.z());
  }
}

}  // namespace

void AxisTask::evaluate(const Model& model, const Data& data, const Eigen::Ref<const Eigen::VectorXd>& target,
                        const Eigen::Ref<const Eigen::VectorXd>& target_rate, Eigen::Ref<Eigen::MatrixXd> J,
                        Eigen::Ref<Eigen::VectorXd> error, Eigen::Ref<Eigen::VectorXd> rate) {
  const Transform X_RF = frame_.pose(model, data);  // in place: no copy of the rotation to wait on
  const Matrix3& R_RF = X_RF.R;
  const Vector3 a_t = target.head<3>();
  double phi = 0.0;
  const Matrix3 R_sl = z_axis_ ? sl_frame(R_RF.col(2), a_t, R_RF.col(1), &phi)
                               : sl_frame(R_RF * a_F_, a_t, R_RF * y_F_, &phi);
  // eq. (18): rows x and y of A_sl-I * J_R. The relative angular velocity in the reference
  // frame is R_WR^T (w_F - w_R), so the rows are P (w_F - w_R) with P = R_sl^T R_WR^T (rows
  // x, y); the joints the frame and the reference share cancel.
  Eigen::Matrix<double, 2, 3> P = R_sl.leftCols<2>().transpose();
  if (frame_.reference() >= 0) P = P * frame_.reference_rotation(model, data).transpose();
  internal::zero_block(J);
  add_projected_axes(model, data, model.frames()[frame_.frame()].body, P, 1.0, J);
  if (frame_.reference() >= 0) add_projected_axes(model, data, model.frames()[frame_.reference()].body, P, -1.0, J);
  error << 0.0, phi;
  // Angular velocity of the moving unit target: w = a_t x d(a_t)/dt (a_t of any length).
  const Vector3 w = internal::normalized_near_unit(a_t).cross(Vector3(target_rate.head<3>()));
  rate = R_sl.leftCols<2>().transpose() * w;
}

}  // namespace wbm
