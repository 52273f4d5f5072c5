#include "wbm/task_element.hpp"

#include <algorithm>
#include <cmath>

#include "wbm/errors.hpp"

namespace wbm {

TaskElement::TaskElement(std::string name, int dim, int target_dim, TargetKind kind, double target_period)
    : name_(std::move(name)),
      row_units_(static_cast<size_t>(std::max(dim, 0)), RowUnit::kLength),
      target_period_(target_period),
      dim_(dim),
      target_dim_(target_dim),
      kind_(kind) {
  if (!std::isfinite(target_period) || target_period < 0.0)
    throw ConfigError("task element '" + name_ + "': target period must be finite and >= 0, got " +
                      std::to_string(target_period));
}

void TaskElement::set_row_unit(int row, RowUnit unit) {
  if (row < 0 || row >= dim_)
    throw ConfigError("task element '" + name_ + "': row " + std::to_string(row) + " of " + std::to_string(dim_) +
                      " has no unit to set");
  row_units_[static_cast<size_t>(row)] = unit;
}

void TaskElement::set_gain(double gain) {
  if (!std::isfinite(gain) || gain < 0.0)
    throw ConfigError("task element '" + name_ + "': gain must be finite and >= 0 [1/s], got " + std::to_string(gain));
  gain_ = gain;
}

namespace {

/// Every column c of J (3 x n, world coordinates) becomes R_WR^T c.
void express_columns_in(const Matrix3& R_WR, Eigen::Ref<Eigen::MatrixXd>& J) {
  const Eigen::Index stride = J.outerStride();
  for (Eigen::Index c = 0; c < J.cols(); ++c) {
    double* col = J.data() + c * stride;
    const Vector3 v(col[0], col[1], col[2]);
    col[0] = R_WR.col(0).dot(v);
    col[1] = R_WR.col(1).dot(v);
    col[2] = R_WR.col(2).dot(v);
  }
}

}  // namespace

void express_point_jacobian_in_frame(const Model& model, const Data& data, int reference, const Vector3& p_WQ,
                                     Eigen::Ref<Eigen::MatrixXd> J) {
  // d/dt R_WR^T (p_WQ - p_WR) = R_WR^T (v_Q - v_R + (p_WQ - p_WR) x w_R). Only the dofs on
  // the reference's chain have non-zero v_R, w_R: their columns change, walking the chain;
  // then every column is rotated. Revolute dof (axis a through p_WB): v_R = a x (p_WR -
  // p_WB), w_R = a, so the change -v_R + (p_WQ - p_WR) x a is (p_WQ - p_WB) x a.
  // Prismatic: v_R = a, w_R = 0.
  const Body* bodies = model.bodies().data();
  const Eigen::Index stride = J.outerStride();
  for (const int b : model.moving_bodies(model.frames()[reference].body)) {
    const Body& B = bodies[b];
    const Vector3 a = B.multiplier * data.a_W[b];
    const Vector3 change = B.joint_type == JointType::kRevolute ? Vector3((p_WQ - data.X_WB[b].p).cross(a)) : Vector3(-a);
    double* col = J.data() + B.dof * stride;
    col[0] += change.x();
    col[1] += change.y();
    col[2] += change.z();
  }
  express_columns_in(frame_pose(model, data, reference).R, J);
}

namespace {

/// X_RF = X_WR^-1 X_WF, without an inverse pose to copy.
Transform relative_pose(const Model& model, const Data& data, int frame, int reference) {
  const Transform X_WF = frame_pose(model, data, frame);
  const Transform X_WR = frame_pose(model, data, reference);
  Transform X_RF;
  X_RF.R.noalias() = X_WR.R.transpose() * X_WF.R;
  X_RF.p.noalias() = X_WR.R.transpose() * (X_WF.p - X_WR.p);
  return X_RF;
}

}  // namespace

RelativeFrame::RelativeFrame(const Model& model, const std::string& frame, const std::string& reference)
    : frame_(model.frame_index(frame)),
      reference_(reference.empty() || reference == "world" ? -1 : model.frame_index(reference)) {}

Matrix3 RelativeFrame::reference_rotation(const Model& model, const Data& data) const {
  // Built in place (not copied out of a pose; see pose()).
  Matrix3 R_WR;
  if (reference_ < 0) {
    R_WR.setIdentity();
  } else {
    const Frame& f = model.frames()[reference_];
    R_WR.noalias() = data.X_WB[f.body].R * f.X_BF.R;
  }
  return R_WR;
}

Vector3 RelativeFrame::position(const Model& model, const Data& data) const {
  const Vector3 p_WF = frame_position(model, data, frame_);
  if (reference_ < 0) return p_WF;
  const Transform X_WR = frame_pose(model, data, reference_);
  return X_WR.R.transpose() * (p_WF - X_WR.p);
}

Vector3 RelativeFrame::z_axis(const Model& model, const Data& data) const {
  const Frame& f = model.frames()[frame_];
  const Vector3 z_W = data.X_WB[f.body].R * f.X_BF.R.col(2);
  if (reference_ < 0) return z_W;
  return frame_pose(model, data, reference_).R.transpose() * z_W;
}

Transform RelativeFrame::pose(const Model& model, const Data& data) const {
  // Either pose is built in the caller's slot: a copy of a local pose at the return (16-byte
  // moves across the 24-byte columns just stored) waits for failed store-to-load forwarding.
  return reference_ < 0 ? frame_pose(model, data, frame_) : relative_pose(model, data, frame_, reference_);
}

void RelativeFrame::translational_jacobian(const Model& model, const Data& data, Eigen::Ref<Eigen::MatrixXd> J) {
  const Vector3 p_WF = frame_position(model, data, frame_);
  point_jacobian(model, data, model.frames()[frame_].body, p_WF, J);
  if (reference_ >= 0) express_point_jacobian_in_frame(model, data, reference_, p_WF, J);
}

void RelativeFrame::rotational_jacobian(const Model& model, const Data& data, Eigen::Ref<Eigen::MatrixXd> J) {
  wbm::rotational_jacobian(model, data, model.frames()[frame_].body, J);
  if (reference_ < 0) return;
  // The relative angular velocity R_WR^T (w_F - w_R): subtract the reference chain's
  // revolute axes, then rotate every column.
  const Body* bodies = model.bodies().data();
  const Eigen::Index stride = J.outerStride();
  for (const int b : model.moving_bodies(model.frames()[reference_].body)) {
    const Body& B = bodies[b];
    if (B.joint_type != JointType::kRevolute) continue;
    double* col = J.data() + B.dof * stride;
    const Vector3 a = B.multiplier * data.a_W[b];
    col[0] -= a.x();
    col[1] -= a.y();
    col[2] -= a.z();
  }
  express_columns_in(frame_pose(model, data, reference_).R, J);
}

}  // namespace wbm
