#include "wbm/tasks/joint_task.hpp"

#include "wbm/errors.hpp"

#include "../zero_block.hpp"

namespace wbm {

JointTask::JointTask(const Model& model, std::string name, const std::vector<std::string>& dofs)
    : TaskElement(std::move(name), static_cast<int>(dofs.size()), static_cast<int>(dofs.size()), TargetKind::kVector) {
  if (dofs.empty()) throw ConfigError("joint task '" + this->name() + "': no dofs listed");
  for (const std::string& d : dofs) {
    const int index = model.dof_index(d);
    for (const int earlier : dofs_)  // two equal rows: singular in every configuration
      if (earlier == index) throw ConfigError("joint task '" + this->name() + "': dof '" + d + "' is listed twice");
    dofs_.push_back(index);
    if (model.dof(index).type == JointType::kRevolute) set_row_unit(static_cast<int>(dofs_.size()) - 1, RowUnit::kAngle);
  }
}

void JointTask::value(const Model&, const Data& data, Eigen::Ref<Eigen::VectorXd> x) {
  for (size_t i = 0; i < dofs_.size(); ++i) x[i] = data.q[dofs_[i]];
}

void JointTask::evaluate(const Model&, const Data& data, const Eigen::Ref<const Eigen::VectorXd>& target,
                         const Eigen::Ref<const Eigen::VectorXd>& target_rate, Eigen::Ref<Eigen::MatrixXd> J,
                         Eigen::Ref<Eigen::VectorXd> error, Eigen::Ref<Eigen::VectorXd> rate) {
  internal::zero_block(J);
  for (size_t i = 0; i < dofs_.size(); ++i) {
    J(i, dofs_[i]) = 1.0;
    error[i] = target[i] - data.q[dofs_[i]];
  }
  rate = target_rate;
}

}  // namespace wbm
