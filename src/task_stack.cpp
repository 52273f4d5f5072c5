#include "wbm/task_stack.hpp"

#include <cmath>
#include <limits>

#include "wbm/errors.hpp"

namespace wbm {

TaskStack::TaskStack(const Model& model) : nq_(model.num_dofs()) {}

int TaskStack::add(std::unique_ptr<TaskElement> element) {
  if (controller_owned_)
    throw ConfigError("task stack: element '" + (element ? element->name() : std::string("(null)")) +
                      "' added to a controller's stack with tasks().add(); use Controller::add_task(), which also "
                      "gives it its trajectory filter");
  return add_element(std::move(element));
}

int TaskStack::add_element(std::unique_ptr<TaskElement> element) {
  if (!element) throw ConfigError("task stack: null task element");
  for (const auto& e : elements_)
    if (e->name() == element->name()) throw ConfigError("task stack: duplicate task element '" + element->name() + "'");
  const int rows = num_rows() + element->dim();
  const int targets = num_targets() + element->target_dim();
  row_offset_.push_back(num_rows());
  target_offset_.push_back(num_targets());
  activation_.conservativeResize(rows);
  activation_.tail(element->dim()).setConstant(true);
  targets_.conservativeResize(targets);
  rates_.conservativeResize(targets);
  targets_.tail(element->target_dim()).setZero();
  if (element->target_kind() == TargetKind::kDirection) targets_[targets - 1] = 1.0;
  rates_.tail(element->target_dim()).setZero();
  J_full_.setZero(rows, nq_);
  J_.setZero(rows, nq_);
  errors_.setZero(rows);
  feed_forward_.setZero(rows);
  xdot_.setZero(rows);
  active_index_.assign(rows, 0);
  feedback_limit_.push_back(std::numeric_limits<double>::infinity());
  elements_.push_back(std::move(element));
  return num_elements() - 1;
}

int TaskStack::element_index(const std::string& name) const {
  for (int i = 0; i < num_elements(); ++i)
    if (elements_[i]->name() == name) return i;
  throw ConfigError("task stack: no task element named '" + name + "'");
}

void TaskStack::set_element_active(int element, bool active) {
  activation_.segment(row_offset_.at(element), elements_.at(element)->dim()).setConstant(active);
}

void TaskStack::set_feedback_limit(int element, double limit) {
  const std::string& name = elements_.at(element)->name();
  if (!(limit > 0.0))
    throw ConfigError("task element '" + name + "': feedback limit must be > 0 (or infinite), got " +
                      std::to_string(limit));
  feedback_limit_[element] = limit;
}

bool TaskStack::element_active(int element) const {
  const int r0 = row_offset_.at(element);
  for (int r = r0; r < r0 + elements_[element]->dim(); ++r)
    if (activation_[r]) return true;
  return false;
}

void TaskStack::values(const Model& model, const Data& data, Eigen::Ref<Eigen::VectorXd> x) {
  for (int i = 0; i < num_elements(); ++i)
    elements_[i]->value(model, data, x.segment(target_offset_[i], elements_[i]->target_dim()));
}

int TaskStack::assemble(const Model& model, const Data& data) {
  active_rows_ = 0;
  errors_.setZero();
  for (int i = 0; i < num_elements(); ++i) {
    TaskElement& e = *elements_[i];
    const int r0 = row_offset_[i];
    int active = 0;
    for (int r = r0; r < r0 + e.dim(); ++r) active += activation_[r] ? 1 : 0;
    if (active == 0) continue;
    const int t0 = target_offset_[i];
    const bool all = active == e.dim();
    e.all_rows_active_ = all;
    // All rows active (the common case): the element writes straight into the assembled
    // Jacobian; otherwise into its full rows, and the active ones are copied.
    e.evaluate(model, data, targets_.segment(t0, e.target_dim()), rates_.segment(t0, e.target_dim()),
               all ? J_.middleRows(active_rows_, e.dim()) : J_full_.middleRows(r0, e.dim()),
               errors_.segment(r0, e.dim()), feed_forward_.segment(r0, e.dim()));
    const int first = active_rows_;
    const double gain = e.gain();
    double squared = 0.0;
    for (int r = r0; r < r0 + e.dim(); ++r) {
      if (!activation_[r]) continue;
      if (!all) J_.row(active_rows_) = J_full_.row(r);
      xdot_[active_rows_] = feed_forward_[r] + gain * errors_[r];
      squared += errors_[r] * errors_[r];
      active_index_[active_rows_] = r;
      ++active_rows_;
    }
    // The feedback term gain * e over the active rows, scaled down (direction kept) where
    // its norm exceeds the element's limit: error clamping, which keeps a target out of
    // reach from commanding ever faster motion as the error grows (docs/solver.md).
    const double limit = feedback_limit_[i];
    if (gain * gain * squared > limit * limit) [[unlikely]] {
      const double clamped = limit / std::sqrt(squared);
      for (int k = first; k < active_rows_; ++k)
        xdot_[k] = feed_forward_[active_index_[k]] + clamped * errors_[active_index_[k]];
    }
  }
  return active_rows_;
}

}  // namespace wbm
