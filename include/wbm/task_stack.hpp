#pragma once
/// @file
/// The task vector of any number of elements and its activation vector b_J (section IV.C).

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "wbm/task_element.hpp"

namespace wbm {

/// One flag per scalar row (b_J) or per dof (b_C).
using Mask = Eigen::Array<bool, Eigen::Dynamic, 1>;

/// Holds the task elements, their targets and the activation vector b_J, and assembles
/// the Jacobian and the commanded task velocity from the active rows only.
class TaskStack {
 public:
  explicit TaskStack(const Model& model);

  /// Adds an element (setup time; allocates). Returns its index. All rows start active.
  /// @throws ConfigError on a duplicate name, or on a controller's stack (Controller::tasks()):
  ///   add those with Controller::add_task(), which also gives them a trajectory filter.
  int add(std::unique_ptr<TaskElement> element);

  int num_elements() const { return static_cast<int>(elements_.size()); }
  /// Total rows of the task vector and total target entries.
  int num_rows() const { return static_cast<int>(activation_.size()); }
  int num_targets() const { return static_cast<int>(targets_.size()); }
  TaskElement& element(int i) { return *elements_.at(i); }
  const TaskElement& element(int i) const { return *elements_.at(i); }
  /// @throws ConfigError naming the element if unknown.
  int element_index(const std::string& name) const;
  int row_offset(int element) const { return row_offset_.at(element); }
  int target_offset(int element) const { return target_offset_.at(element); }

  /// Activation vector b_J, one flag per row; change it at any cycle.
  Mask& activation() { return activation_; }
  const Mask& activation() const { return activation_; }
  void set_element_active(int element, bool active);
  bool element_active(int element) const;
  /// Largest norm of an element's feedback term gain * e over its active rows [the
  /// element's units/s, e.g. m/s, rad/s]: beyond it the term is scaled down, direction kept
  /// (error clamping). Infinite unless set; Controller::add_task sets it to the element's
  /// trajectory speed limit (FilterParameters::max_speed), so that the commanded task
  /// velocity towards a target out of reach stays bounded as the error grows.
  /// @throws ConfigError if limit is NaN or <= 0.
  void set_feedback_limit(int element, double limit);
  double feedback_limit(int element) const { return feedback_limit_.at(element); }
  /// Targets and their time derivatives, in each element's reference frame.
  Eigen::VectorXd& targets() { return targets_; }
  Eigen::VectorXd& target_rates() { return rates_; }
  const Eigen::VectorXd& targets() const { return targets_; }

  /// Current values of all elements (num_targets entries). @pre forward kinematics done.
  void values(const Model& model, const Data& data, Eigen::Ref<Eigen::VectorXd> x);

  /// Evaluates every element with an active row and copies the active rows into the
  /// assembled Jacobian and task velocity rate + gain * error (the feedback term bounded by
  /// feedback_limit()). Returns the number m of
  /// active rows. Never allocates.
  int assemble(const Model& model, const Data& data);
  /// Assembled Jacobian (m x nq) and commanded task velocity (m) of the last assemble().
  Eigen::Block<const Eigen::MatrixXd> jacobian() const { return J_.topRows(active_rows_); }
  Eigen::VectorBlock<const Eigen::VectorXd> task_velocity() const { return xdot_.head(active_rows_); }
  /// Mutable view, for adding balance terms (eq. 21).
  Eigen::VectorBlock<Eigen::VectorXd> task_velocity() { return xdot_.head(active_rows_); }
  /// Errors of all rows (0 for rows of elements not evaluated).
  const Eigen::VectorXd& errors() const { return errors_; }
  /// Row of the full task vector for each assembled row.
  const std::vector<int>& active_row_indices() const { return active_index_; }

 private:
  friend class Controller;  // adds its elements with their filters; add() refuses others
  int add_element(std::unique_ptr<TaskElement> element);

  bool controller_owned_ = false;
  std::vector<std::unique_ptr<TaskElement>> elements_;
  std::vector<int> row_offset_, target_offset_;
  Mask activation_;
  Eigen::VectorXd targets_, rates_;
  int nq_;
  Eigen::MatrixXd J_full_, J_;
  Eigen::VectorXd errors_, feed_forward_, xdot_;
  std::vector<int> active_index_;
  std::vector<double> feedback_limit_;
  int active_rows_ = 0;
};

}  // namespace wbm
