#pragma once
#include "wbm/task_element.hpp"

namespace wbm {

/// Whole-body centre of mass, 3 rows, in the world or relative to a reference frame
/// (e.g. "heel"). Target: p_RCm [m].
class CenterOfMassTask : public TaskElement {
 public:
  /// @throws ModelError if the reference frame is unknown or the model has no mass.
  CenterOfMassTask(const Model& model, std::string name, const std::string& reference = "");
  bool needs_center_of_mass() const override { return true; }
  void value(const Model& model, const Data& data, Eigen::Ref<Eigen::VectorXd> x) override;
  void evaluate(const Model& model, const Data& data, const Eigen::Ref<const Eigen::VectorXd>& target,
                const Eigen::Ref<const Eigen::VectorXd>& target_rate, Eigen::Ref<Eigen::MatrixXd> J,
                Eigen::Ref<Eigen::VectorXd> error, Eigen::Ref<Eigen::VectorXd> rate) override;

 private:
  int reference_ = -1;
};

}  // namespace wbm
