#include "wbm/tasks/position_task.hpp"

namespace wbm {

PositionTask::PositionTask(const Model& model, std::string name, const std::string& frame, const std::string& reference)
    : TaskElement(std::move(name), 3, 3, TargetKind::kVector), frame_(model, frame, reference) {}

void PositionTask::value(const Model& model, const Data& data, Eigen::Ref<Eigen::VectorXd> x) {
  x.head<3>() = frame_.position(model, data);  // fixed size: see AxisTask::value()
}

void PositionTask::evaluate(const Model& model, const Data& data, const Eigen::Ref<const Eigen::VectorXd>& target,
                            const Eigen::Ref<const Eigen::VectorXd>& target_rate, Eigen::Ref<Eigen::MatrixXd> J,
                            Eigen::Ref<Eigen::VectorXd> error, Eigen::Ref<Eigen::VectorXd> rate) {
  frame_.translational_jacobian(model, data, J);
  error.head<3>() = target.head<3>() - frame_.position(model, data);
  rate = target_rate;
}

}  // namespace wbm
