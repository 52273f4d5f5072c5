#include "wbm/tasks/com_task.hpp"

#include "wbm/errors.hpp"

namespace wbm {

CenterOfMassTask::CenterOfMassTask(const Model& model, std::string name, const std::string& reference)
    : TaskElement(std::move(name), 3, 3, TargetKind::kVector),
      reference_(reference.empty() || reference == "world" ? -1 : model.frame_index(reference)) {
  if (!(model.total_mass() > 0.0)) throw ModelError("centre-of-mass task '" + this->name() + "': the model has no mass");
}

void CenterOfMassTask::value(const Model& model, const Data& data, Eigen::Ref<Eigen::VectorXd> x) {
  if (reference_ < 0) {
    x = data.p_WCm;
    return;
  }
  const Transform X_WR = frame_pose(model, data, reference_);
  x = X_WR.R.transpose() * (data.p_WCm - X_WR.p);
}

void CenterOfMassTask::evaluate(const Model& model, const Data& data, const Eigen::Ref<const Eigen::VectorXd>& target,
                                const Eigen::Ref<const Eigen::VectorXd>& target_rate, Eigen::Ref<Eigen::MatrixXd> J,
                                Eigen::Ref<Eigen::VectorXd> error, Eigen::Ref<Eigen::VectorXd> rate) {
  com_jacobian(model, data, J);
  if (reference_ >= 0) express_point_jacobian_in_frame(model, data, reference_, data.p_WCm, J);
  Vector3 x;
  value(model, data, x);
  error = target - x;
  rate = target_rate;
}

}  // namespace wbm
