#pragma once
/// @file
/// The controller cycle: command -> trajectory filters -> tasks -> solver -> limits -> state.

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "wbm/kinematics.hpp"
#include "wbm/nullspace_criterion.hpp"
#include "wbm/solver.hpp"
#include "wbm/task_stack.hpp"
#include "wbm/trajectory_filter.hpp"

namespace wbm {

/// What the user commands each cycle; any part may change at any cycle.
/// Make one with Controller::make_command() (sized for the controller).
struct Command {
  Eigen::VectorXd targets;  ///< Targets of all elements (TaskStack::num_targets()), reference frames of the elements.
  Mask task_active;         ///< b_J: one flag per task row (TaskStack::num_rows()).
  Mask free_dofs;           ///< b_C: one flag per dof; false freezes the dof.
  /// Velocities of dofs driven by a separate controller (balance: upper-body x/y shift;
  /// walking: heel), nq entries or empty. They are integrated (within the dof's speed
  /// limit if SolverParameters::limit_speeds; on a dof frozen in b_C changing by at most
  /// k v_max dt per cycle as the solver's rates do; braked before a position limit as they
  /// are, kDofBraked; and clamped) whatever b_C says; those dofs should be frozen in b_C so
  /// the solver leaves them alone (section V). [m/s or rad/s]
  Eigen::VectorXd external_velocity;
  /// Feed the task velocity these cause, x_bal = J q_dot_external, into the solver:
  /// q_dot = J# (x_dot_task - x_bal) - alpha N W^-1 dH/dq (eqs. 19-21).
  bool compensate_external = true;
};

/// Flags of a controller cycle beyond the solver's (SolverFlag).
enum ControllerFlag : std::uint32_t {
  kInvalidCommand = 1u << 16,  ///< Wrong sizes or dt, or no reset() since add_task(): nothing moved, state kept.
  kInvalidTarget = 1u << 17,   ///< NaN/inf or zero-direction target: that element keeps its previous target.
};

struct ControllerStatus {
  std::uint32_t flags = 0;
  bool has(std::uint32_t f) const { return (flags & f) != 0; }
  /// True unless nothing could be computed this cycle.
  bool ok() const { return !has(kInvalidCommand) && !has(kInvalidInput); }
};

/// One controller: owns the workspace, the task stack, the filters and the solver state.
/// Usable as a real-time loop (update() allocates nothing and never throws) and as a
/// motion simulator (section VIII).
///
/// Setup: add elements with add_task(), optionally set_criterion(), then reset(q).
class Controller {
 public:
  /// @param model must outlive the controller.
  explicit Controller(const Model& model, const SolverParameters& solver = {});

  /// Adds a task element with its trajectory filter (setup time). Returns its index.
  /// @throws ConfigError on duplicate names or bad filter parameters.
  int add_task(std::unique_ptr<TaskElement> element, const FilterParameters& filter = {});
  /// Null-space criterion H (default: cubic joint-limit penalty, band 0.3).
  void set_criterion(std::unique_ptr<NullSpaceCriterion> criterion);
  /// @throws ConfigError for invalid parameters.
  void set_solver_parameters(const SolverParameters& parameters);
  /// Sets the state to q (at rest), all filters to the current values.
  /// @throws ModelError if q has the wrong size, a NaN, or lies outside the limits.
  void reset(const Eigen::VectorXd& q);
  /// A command sized for this controller: current values as targets, all rows active,
  /// all dofs free, no external velocity.
  Command make_command() const;

  /// One cycle of duration dt [s]. Never allocates, never throws, never writes NaN.
  ///
  /// A dof that sits at a position limit and would be driven further out is frozen for
  /// this cycle and the solve repeated (at most WholeBodySolver::kMaxFreezeRounds times),
  /// so that the other dofs take over its share instead of the task stalling against the
  /// clamp (IV.E clamps; this keeps the clamp from fighting the task).
  /// Each free dof's rate changes by at most k v_max dt per cycle (k the solver's
  /// nullspace_rate_change_limit; 0 turns this off): an element switched off while moving
  /// slows down instead of stopping within a cycle, and a damped solution leaving a
  /// singularity does not swing faster. Dofs frozen by b_C stop at once; an external
  /// velocity on such a dof (the balance shift) is its rate, bounded the same way.
  ControllerStatus update(const Command& command, double dt);

  const Model& model() const { return model_; }
  const Data& data() const { return data_; }
  /// The elements and their activation. Add elements with add_task(): tasks().add() throws
  /// ConfigError (the element would have no trajectory filter).
  TaskStack& tasks() { return stack_; }
  const TaskStack& tasks() const { return stack_; }
  /// @pre reset() was called.
  const WholeBodySolver& solver() const { return *solver_; }
  const Eigen::VectorXd& q() const { return q_; }
  const Eigen::VectorXd& qdot() const { return qdot_; }
  /// Current values of all elements (num_targets), updated after each cycle.
  const Eigen::VectorXd& values() const { return values_; }
  /// Filtered targets fed to the tasks in the last cycle (num_targets).
  const Eigen::VectorXd& filtered_targets() const { return stack_.targets(); }
  /// Null-space cost H(q) of the current state.
  double nullspace_cost() const { return criterion_->cost(q_); }
  const TrajectoryFilter& filter(int element) const { return filters_.at(element); }

 private:
  void update_kinematics();

  const Model& model_;
  Data data_;
  TaskStack stack_;
  std::vector<TrajectoryFilter> filters_;
  // The active elements' filters and their commanded targets of a cycle, advanced together
  // (TrajectoryFilter::update_together); one entry per element, filled in update().
  std::vector<TrajectoryFilter*> active_filters_;
  std::vector<const double*> active_targets_;
  std::unique_ptr<NullSpaceCriterion> criterion_;
  SolverParameters solver_parameters_;
  std::unique_ptr<WholeBodySolver> solver_;  // sized in reset() for the final task rows
  Eigen::VectorXd q_, qdot_, q_next_, gradient_, values_, previous_values_, value_rates_;
  Eigen::VectorXd q_total_;   // solver output plus external velocities
  Eigen::VectorXd external_;  // external velocities as realised within the limits (0: none)
  Mask was_active_, was_row_active_;
  bool needs_center_of_mass_ = false;
  bool any_periodic_targets_ = false;  // an element with a target period (angles)
  Eigen::VectorXd limited_;            // q_dot with its change per cycle limited
  Eigen::VectorXd commanded_;  // last valid target per element
};

}  // namespace wbm
