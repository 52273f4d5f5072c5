#include "wbm/task_element.hpp"

#include <cmath>

#include "wbm/errors.hpp"

namespace wbm {

TaskElement::TaskElement(std::string name, int dim, int target_dim, TargetKind kind)
    : name_(std::move(name)), dim_(dim), target_dim_(target_dim), kind_(kind) {}

void TaskElement::set_gain(double gain) {
  if (!std::isfinite(gain) || gain < 0.0)
    throw ConfigError("task element '" + name_ + "': gain must be finite and >= 0 [1/s], got " + std::to_string(gain));
  gain_ = gain;
}

RelativeFrame::RelativeFrame(const Model& model, const std::string& frame, const std::string& reference)
    : frame_(model.frame_index(frame)),
      reference_(reference.empty() || reference == "world" ? -1 : model.frame_index(reference)),
      J_reference_(6, model.num_dofs()) {}

Matrix3 RelativeFrame::reference_rotation(const Model& model, const Data& data) const {
  return reference_ < 0 ? Matrix3::Identity() : frame_pose(model, data, reference_).R;
}

Transform RelativeFrame::pose(const Model& model, const Data& data) const {
  const Transform X_WF = frame_pose(model, data, frame_);
  if (reference_ < 0) return X_WF;
  return frame_pose(model, data, reference_).inverse() * X_WF;
}

void RelativeFrame::jacobian(const Model& model, const Data& data, Eigen::Ref<Eigen::MatrixXd> J) {
  frame_jacobian(model, data, frame_, J);
  if (reference_ < 0) return;
  // d/dt R_WR^T (p_WF - p_WR) = R_WR^T (v_F - v_R + (p_WF - p_WR) x w_R), and the relative
  // angular velocity R_WR^T (w_F - w_R).
  frame_jacobian(model, data, reference_, J_reference_);
  const Transform X_WR = frame_pose(model, data, reference_);
  const Vector3 d = frame_pose(model, data, frame_).p - X_WR.p;
  const Matrix3 Rt = X_WR.R.transpose();
  const int n = static_cast<int>(J.cols());
  for (int c = 0; c < n; ++c) {
    const Vector3 v = J.col(c).head<3>() - J_reference_.col(c).head<3>() + d.cross(J_reference_.col(c).tail<3>());
    const Vector3 w = J.col(c).tail<3>() - J_reference_.col(c).tail<3>();
    J.col(c).head<3>() = Rt * v;
    J.col(c).tail<3>() = Rt * w;
  }
}

}  // namespace wbm
