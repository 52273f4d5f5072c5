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

void express_point_jacobian_in_frame(const Model& model, const Data& data, int reference, const Vector3& p_WQ,
                                     Eigen::Ref<Eigen::MatrixXd> J, Eigen::MatrixXd& scratch) {
  // d/dt R_WR^T (p_WQ - p_WR) = R_WR^T (v_Q - v_R + (p_WQ - p_WR) x w_R).
  frame_jacobian(model, data, reference, scratch);
  const Transform X_WR = frame_pose(model, data, reference);
  const Vector3 d = p_WQ - X_WR.p;
  const Matrix3 Rt = X_WR.R.transpose();
  for (int c = 0; c < J.cols(); ++c)
    J.col(c) = Rt * (J.col(c) - scratch.col(c).head<3>() + d.cross(scratch.col(c).tail<3>()));
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

void RelativeFrame::translational_jacobian(const Model& model, const Data& data, Eigen::Ref<Eigen::MatrixXd> J) {
  const Frame& f = model.frames()[frame_];
  const Vector3 p_WF = data.X_WB[f.body] * f.X_BF.p;
  point_jacobian(model, data, f.body, p_WF, J);
  if (reference_ >= 0) express_point_jacobian_in_frame(model, data, reference_, p_WF, J, J_reference_);
}

void RelativeFrame::rotational_jacobian(const Model& model, const Data& data, Eigen::Ref<Eigen::MatrixXd> J) {
  wbm::rotational_jacobian(model, data, model.frames()[frame_].body, J);
  if (reference_ < 0) return;
  // The relative angular velocity R_WR^T (w_F - w_R).
  wbm::rotational_jacobian(model, data, model.frames()[reference_].body, J_reference_.topRows<3>());
  const Matrix3 Rt = frame_pose(model, data, reference_).R.transpose();
  for (int c = 0; c < J.cols(); ++c) J.col(c) = Rt * (J.col(c) - J_reference_.col(c).head<3>());
}

}  // namespace wbm
