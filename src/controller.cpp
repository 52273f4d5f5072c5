#include "wbm/controller.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "wbm/errors.hpp"

#include "braking.hpp"
#include "dot_kernels.hpp"
#include "rate_checks.hpp"

namespace wbm {
namespace {

/// to[k] = from[k] for k < n: a target's few entries, without the setup of Eigen's
/// dynamic-size copy (about 35 instructions each, three per element and cycle); three
/// entries (positions, directions) without a loop.
void copy_entries(const double* __restrict__ from, int n, double* __restrict__ to) {
  if (n == 3) {
    to[0] = from[0];
    to[1] = from[1];
    to[2] = from[2];
    return;
  }
  for (int k = 0; k < n; ++k) to[k] = from[k];
}

}  // namespace

Controller::Controller(const Model& model, const SolverParameters& solver)
    : model_(model), data_(model), stack_(model),
      criterion_(std::make_unique<CubicJointLimitCriterion>(model, 0.3)), solver_parameters_(solver),
      q_(model.home()), qdot_(Eigen::VectorXd::Zero(model.num_dofs())), q_next_(model.home()),
      gradient_(Eigen::VectorXd::Zero(model.num_dofs())) {
  WholeBodySolver check(model, 0, solver);  // validates the parameters now
  stack_.controller_owned_ = true;
}

int Controller::add_task(std::unique_ptr<TaskElement> element, const FilterParameters& filter) {
  if (!element) throw ConfigError("controller: null task element");
  TrajectoryFilter f(element->target_kind(), element->target_dim(), filter);
  needs_center_of_mass_ = needs_center_of_mass_ || element->needs_center_of_mass();
  any_periodic_targets_ = any_periodic_targets_ || element->target_period() > 0.0;
  const int index = stack_.add_element(std::move(element));
  stack_.set_feedback_limit(index, filter.max_speed);
  filters_.push_back(std::move(f));
  active_filters_.resize(filters_.size());
  active_targets_.resize(filters_.size());
  solver_.reset();
  return index;
}

void Controller::set_criterion(std::unique_ptr<NullSpaceCriterion> criterion) {
  if (!criterion) throw ConfigError("controller: null criterion");
  criterion_ = std::move(criterion);
}

void Controller::set_solver_parameters(const SolverParameters& parameters) {
  WholeBodySolver check(model_, 0, parameters);
  solver_parameters_ = parameters;
  if (solver_) solver_->set_parameters(parameters);
}

void Controller::update_kinematics() {
  forward_kinematics(model_, data_, q_);
  if (needs_center_of_mass_) center_of_mass(model_, data_);
  stack_.values(model_, data_, values_);
}

void Controller::reset(const Eigen::VectorXd& q) {
  model_.check_configuration(q);
  solver_ = std::make_unique<WholeBodySolver>(model_, stack_.num_rows(), solver_parameters_);
  q_ = q;
  q_next_ = q;
  q_total_.setZero(model_.num_dofs());
  external_.setZero(model_.num_dofs());
  qdot_.setZero();
  values_.setZero(stack_.num_targets());
  update_kinematics();
  previous_values_ = values_;
  value_rates_.setZero(stack_.num_targets());
  commanded_ = values_;
  was_active_.setConstant(stack_.num_elements(), false);
  was_row_active_.setConstant(stack_.num_rows(), false);
  limited_.setZero(model_.num_dofs());
  for (int i = 0; i < stack_.num_elements(); ++i) {
    const int t0 = stack_.target_offset(i), n = stack_.element(i).target_dim();
    filters_[i].reset(values_.segment(t0, n), value_rates_.segment(t0, n));
  }
  stack_.targets() = values_;
  stack_.target_rates().setZero();
}

Command Controller::make_command() const {
  Command c;
  c.targets = values_;
  c.task_active = Mask::Constant(stack_.num_rows(), true);
  c.free_dofs = Mask::Constant(model_.num_dofs(), true);
  return c;
}

ControllerStatus Controller::update(const Command& command, double dt) {
  ControllerStatus status;
  const int nt = stack_.num_targets();
  if (!solver_ || !(std::isfinite(dt) && dt > 0.0) || command.targets.size() != nt ||
      command.task_active.size() != stack_.num_rows() || command.free_dofs.size() != model_.num_dofs() ||
      (command.external_velocity.size() != 0 && command.external_velocity.size() != model_.num_dofs()) ||
      !command.external_velocity.allFinite()) {
    status.flags |= kInvalidCommand;
    qdot_.setZero();
    return status;
  }
  // Rows switched on or off since the last cycle? Mostly not: then every element is as
  // active as it was and no row needs its filter reset (no per-row scans).
  const bool rows_switched = std::memcmp(command.task_active.data(), was_row_active_.data(),
                                         sizeof(bool) * static_cast<std::size_t>(stack_.num_rows())) != 0;
  stack_.activation() = command.task_active;
  int active_count = 0;
  for (int i = 0; i < stack_.num_elements(); ++i) {
    const TaskElement& e = stack_.element(i);
    const int t0 = stack_.target_offset(i), n = e.target_dim();
    const bool active = rows_switched ? stack_.element_active(i) : bool(was_active_[i]);
    const auto target = command.targets.segment(t0, n);
    const bool valid = internal::all_finite(target.data(), n) &&
                       (e.target_kind() != TargetKind::kDirection || target.squaredNorm() > 1e-18);
    if (valid) {
      copy_entries(target.data(), n, commanded_.data() + t0);
    } else if (active) {
      status.flags |= kInvalidTarget;
    }
    const int r0 = stack_.row_offset(i);
    if (active && !was_active_[i]) {
      filters_[i].reset(values_.segment(t0, n), value_rates_.segment(t0, n));
    } else if (active && rows_switched) {
      // Rows switched on in an element that was already partly active.
      for (int r = 0; r < e.dim(); ++r) {
        if (!stack_.activation()[r0 + r] || was_row_active_[r0 + r]) continue;
        if (e.target_kind() == TargetKind::kVector && e.dim() == n)
          filters_[i].reset_component(r, values_[t0 + r], value_rates_[t0 + r]);
        else
          filters_[i].reset(values_.segment(t0, n), value_rates_.segment(t0, n));
      }
    }
    if (active && e.target_period() > 0.0) {
      // Angles: the commanded target moved by whole periods to within half a period of the
      // filter's output, so that the filtered target turns the short way round (from 3.1 to
      // -3.1 rad by 0.08 rad, not through zero).
      const double period = e.target_period();
      for (int k = 0; k < n; ++k) {
        const double from = filters_[i].value()[k];
        commanded_[t0 + k] = from + std::remainder(commanded_[t0 + k] - from, period);
      }
    }
    if (active) {
      active_filters_[active_count] = &filters_[i];
      active_targets_[active_count++] = commanded_.data() + t0;
    }
    was_active_[i] = active;
  }
  TrajectoryFilter::update_together(active_filters_.data(), active_targets_.data(), active_count, dt);
  for (int i = 0; i < stack_.num_elements(); ++i) {
    const int t0 = stack_.target_offset(i), n = stack_.element(i).target_dim();
    copy_entries(filters_[i].value().data(), n, stack_.targets().data() + t0);
    copy_entries(filters_[i].velocity().data(), n, stack_.target_rates().data() + t0);
  }
  if (rows_switched) was_row_active_ = stack_.activation();
  const int m = stack_.assemble(model_, data_);
  // The external velocity as it will be realised: within the dof's speed limit (limit_speeds);
  // on a dof frozen in b_C (the balance module's upper-body shift) it is that dof's whole
  // rate, whose change per cycle is bounded by k v_max dt as the solver's rates are below
  // (k > 0); braked before a limit as the solver brakes its own rates; and a dof at a limit
  // does not move further.
  const bool external = command.external_velocity.size() != 0;
  if (external)
    for (int i = 0; i < model_.num_dofs(); ++i) {
      double v = command.external_velocity[i];
      if (v == 0.0) {
        external_[i] = 0.0;
        continue;
      }
      const double lower = model_.lower_limits()[i], upper = model_.upper_limits()[i];
      const double vmax = model_.max_speeds()[i], k = solver_parameters_.nullspace_rate_change_limit;
      if (solver_parameters_.limit_speeds) v = std::clamp(v, -vmax, vmax);
      if (k > 0.0) {
        if (!command.free_dofs[i]) v = std::clamp(v, qdot_[i] - k * vmax * dt, qdot_[i] + k * vmax * dt);
        const double braked = internal::braked_rate(v, internal::distance_ahead(v, q_[i], lower, upper), k * vmax, dt);
        if (std::abs(braked) < std::abs(v)) status.flags |= kDofBraked;
        v = braked;
      }
      external_[i] = (std::clamp(q_[i] + v * dt, lower, upper) - q_[i]) / dt;
    }
  if (external && command.compensate_external && m > 0)
    stack_.task_velocity().noalias() -= stack_.jacobian() * external_;
  criterion_->gradient(q_, gradient_);
  const SolverStatus solved =
      solver_->solve(stack_.jacobian(), stack_.task_velocity(), gradient_, command.free_dofs, dt, &q_);
  status.flags |= solved.flags;
  if (!solved.ok()) {
    qdot_.setZero();
    return status;
  }
  // The change of every free dof's rate per cycle is limited to k v_max dt against the rate
  // realised in the last cycle (k the solver's nullspace_rate_change_limit; 0 switches it
  // off): the bound the paper puts on the null-space rates (IV.E), on the whole q_dot. It
  // binds where the solution jumps or swings: rows or dofs switched (an element switched off
  // while moving takes its rate away at once), dofs frozen at or released from their limits,
  // a damped solution leaving a singularity. Dofs frozen by b_C stop at once.
  const Eigen::VectorXd* qdot = &solver_->output().qdot;
  const double rate_limit = solver_parameters_.nullspace_rate_change_limit;
  if (!external) external_.setZero();
  if (rate_limit > 0.0 && internal::rate_change_exceeds(qdot->data(), qdot_.data(), external_.data(),
                                                        model_.max_speeds().data(), rate_limit * dt,
                                                        model_.num_dofs())) {
    const Eigen::VectorXd& vmax = model_.max_speeds();
    for (int i = 0; i < model_.num_dofs(); ++i) {
      double v = (*qdot)[i];
      const double step = rate_limit * vmax[i] * dt;
      // The rate realised last cycle less this cycle's external velocity (so that the whole
      // rate changes by at most step), within the speed limit: over a tiny dt its rounding
      // can put it an ulp / dt beyond.
      const double realised = qdot_[i] - external_[i];
      const double from = solver_parameters_.limit_speeds ? std::clamp(realised, -vmax[i], vmax[i]) : realised;
      if (std::abs(v - from) > step && command.free_dofs[i]) {
        v = from + std::copysign(step, v - from);
        // Not faster towards a limit than the solver's braking allows (where dt varies, a rate
        // within it last cycle may not be now): better a harder brake than the clamp.
        const double braked = internal::braked_rate(
            v, internal::distance_ahead(v, q_[i], model_.lower_limits()[i], model_.upper_limits()[i]),
            rate_limit * vmax[i], dt);
        if (std::abs(braked) < std::abs(v)) status.flags |= kDofBraked;
        v = braked;
      }
      limited_[i] = v;
    }
    qdot = &limited_;
  }
  if (external) q_total_ = *qdot + external_;
  status.flags |= integrate(model_, q_, external ? q_total_ : *qdot, dt, q_next_);
  qdot_ = (q_next_ - q_) * (1.0 / dt);
  // Swaps (of the buffers, no copies): q_next_ and values_ are overwritten whole next time.
  q_.swap(q_next_);
  previous_values_.swap(values_);
  update_kinematics();
  value_rates_ = (values_ - previous_values_) * (1.0 / dt);
  if (any_periodic_targets_) {  // angles that wrapped at +-pi between the two cycles
    for (int i = 0; i < stack_.num_elements(); ++i) {
      const double period = stack_.element(i).target_period();
      if (period == 0.0) continue;
      for (int k = stack_.target_offset(i); k < stack_.target_offset(i) + stack_.element(i).target_dim(); ++k)
        value_rates_[k] = std::remainder(values_[k] - previous_values_[k], period) * (1.0 / dt);
    }
  }
  return status;
}

}  // namespace wbm
