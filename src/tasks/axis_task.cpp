#include "wbm/tasks/axis_task.hpp"

#include <cmath>

#include "wbm/errors.hpp"

#include "../fast_trig.hpp"
#include "../zero_block.hpp"

namespace wbm {

AxisTask::AxisTask(const Model& model, std::string name, const std::string& frame, const std::string& reference,
                   const Vector3& axis)
    : TaskElement(std::move(name), 2, 3, TargetKind::kDirection), frame_(model, frame, reference) {
  set_row_unit(0, RowUnit::kAngle);
  set_row_unit(1, RowUnit::kAngle);
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
  // Fixed-size writes: Eigen's dynamic-size copy peels an entry to align the destination and
  // then loads the returned vector across the halves it was stored in (a failed
  // store-to-load forwarding).
  if (z_axis_)
    x.head<3>() = frame_.z_axis(model, data);
  else
    x.head<3>() = frame_.pose(model, data).R * a_F_;
}

namespace {

/// The sl-frame's axes x, y, z (the reference frame's coordinates) and the angle phi.
[[gnu::always_inline]] inline void sl_axes(const Vector3& a_g, const Vector3& a_t, const Vector3& fallback_y,
                                           double* phi, Vector3& x, Vector3& y, Vector3& z) {
  z = internal::normalized_near_unit(a_g);
  const Vector3 t = internal::normalized_near_unit(a_t);
  const Vector3 c = z.cross(t);
  const double s2 = c.squaredNorm();
  const double s = std::sqrt(s2);
  *phi = internal::angle_between_unit_vectors(s, s2, z.dot(t));  // the tracking error: mostly small
  y = s > 1e-12 ? Vector3(c * (1.0 / s)) : Vector3((fallback_y - fallback_y.dot(z) * z).normalized());
  x = y.cross(z);
}

}  // namespace

Matrix3 AxisTask::sl_frame(const Vector3& a_g, const Vector3& a_t, const Vector3& fallback_y, double* phi) {
  Vector3 x, y, z;
  sl_axes(a_g, a_t, fallback_y, phi, x, y, z);
  Matrix3 R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  return R;
}

namespace {

/// J += sign * P * (rotational Jacobian of `body`), P the 2 x 3 matrix of rows u^T and v^T:
/// the chain's joint axes projected on u and v (world coordinates), without a 3 x n
/// intermediate. Plain scalars and column pointers, inlined: with the Eigen version (2 x 3
/// product, Ref indexing, a call per chain) GCC's task assembly took 3-7 % longer
/// (bench/optimization_log.md, "Tried and dropped").
[[gnu::always_inline]] inline void add_projected_axes(const Model& model, const Data& data, int body,
                                                      const Vector3& u, const Vector3& v, double sign,
                                                      Eigen::Ref<Eigen::MatrixXd>& J) {
  const Body* bodies = model.bodies().data();
  double* const columns = J.data();
  const Eigen::Index stride = J.outerStride();
  const double p00 = sign * u.x(), p01 = sign * u.y(), p02 = sign * u.z();
  const double p10 = sign * v.x(), p11 = sign * v.y(), p12 = sign * v.z();
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
  Vector3 x_sl, y_sl, z_sl;  // the sl-frame's axes (no matrix to transpose: its loads would
                             // wait on the stores of its columns)
  // The axis and the fallback y in the reference frame (one inlined sl_axes for both cases).
  Vector3 a_g, y_g;
  if (z_axis_) {
    a_g = R_RF.col(2);
    y_g = R_RF.col(1);
  } else {
    a_g.noalias() = R_RF * a_F_;
    y_g.noalias() = R_RF * y_F_;
  }
  sl_axes(a_g, a_t, y_g, &phi, x_sl, y_sl, z_sl);
  // eq. (18): rows x and y of A_sl-I * J_R. The relative angular velocity in the reference
  // frame is R_WR^T (w_F - w_R), so the rows are P (w_F - w_R) with P = R_sl^T R_WR^T, whose
  // rows are the world's x_sl and y_sl: (R_WR x_sl)^T, (R_WR y_sl)^T; the joints the frame
  // and the reference share cancel.
  Vector3 u = x_sl, v = y_sl;
  if (frame_.reference() >= 0) {
    const Matrix3 R_WR = frame_.reference_rotation(model, data);
    u = R_WR * x_sl;
    v = R_WR * y_sl;
  }
  internal::zero_block(J);
  add_projected_axes(model, data, model.frames()[frame_.frame()].body, u, v, 1.0, J);
  if (frame_.reference() >= 0) add_projected_axes(model, data, model.frames()[frame_.reference()].body, u, v, -1.0, J);
  error << 0.0, phi;
  // Angular velocity of the moving unit target: w = a_t x d(a_t)/dt (a_t of any length).
  const Vector3 w = internal::normalized_near_unit(a_t).cross(Vector3(target_rate.head<3>()));
  rate << x_sl.dot(w), y_sl.dot(w);
}

}  // namespace wbm
