#pragma once
#include <vector>

#include "wbm/task_element.hpp"

namespace wbm {

/// Joint positions (posture), one row per listed dof. Target: the dof values.
class JointTask : public TaskElement {
 public:
  /// @throws ModelError if a dof is unknown; ConfigError if the list is empty or names a dof twice.
  JointTask(const Model& model, std::string name, const std::vector<std::string>& dofs);
  void value(const Model& model, const Data& data, Eigen::Ref<Eigen::VectorXd> x) override;
  void evaluate(const Model& model, const Data& data, const Eigen::Ref<const Eigen::VectorXd>& target,
                const Eigen::Ref<const Eigen::VectorXd>& target_rate, Eigen::Ref<Eigen::MatrixXd> J,
                Eigen::Ref<Eigen::VectorXd> error, Eigen::Ref<Eigen::VectorXd> rate) override;

 private:
  std::vector<int> dofs_;
};

}  // namespace wbm
