#pragma once
#include "wbm/task_element.hpp"

namespace wbm {

/// Position of a frame's origin, 3 rows (section III: hand reference points), expressed
/// in the world or in a reference frame (e.g. "heel"). Target: p_RF [m].
class PositionTask : public TaskElement {
 public:
  /// @throws ModelError if a frame is unknown.
  PositionTask(const Model& model, std::string name, const std::string& frame, const std::string& reference = "");
  void value(const Model& model, const Data& data, Eigen::Ref<Eigen::VectorXd> x) override;
  void evaluate(const Model& model, const Data& data, const Eigen::Ref<const Eigen::VectorXd>& target,
                const Eigen::Ref<const Eigen::VectorXd>& target_rate, Eigen::Ref<Eigen::MatrixXd> J,
                Eigen::Ref<Eigen::VectorXd> error, Eigen::Ref<Eigen::VectorXd> rate) override;

 private:
  RelativeFrame frame_;
};

}  // namespace wbm
