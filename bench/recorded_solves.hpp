#pragma once
/// @file
/// The solver's inputs of consecutive controller cycles, recorded for the benchmarks that
/// time `WholeBodySolver::solve` alone (the fixtures' and the scaling study's solve stage),
/// and the check that the stage solves the cycle's own problem.

#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "wbm/controller.hpp"
#include "wbm/solver.hpp"

namespace wbm_bench {

struct RecordedSolves {
  std::vector<Eigen::MatrixXd> J;          ///< the stack's Jacobian the controller solved with
  std::vector<Eigen::VectorXd> xdot;       ///< its task velocity
  std::vector<Eigen::VectorXd> qdot_task;  ///< the controller's J# x_dot; empty: not compared

  void clear() {
    J.clear();
    xdot.clear();
    qdot_task.clear();
  }
  std::size_t size() const { return J.size(); }

  /// Records the cycle `controller.update` just ran and returned `status` for. Cycles that
  /// froze a dof at its limit or braked one before it (the stage solves without q, so
  /// without either) or damped (sigma_min estimated from another warm start) are recorded
  /// but not compared.
  void record(const wbm::Controller& controller, const wbm::ControllerStatus& status) {
    J.emplace_back(controller.tasks().jacobian());
    xdot.emplace_back(controller.tasks().task_velocity());
    qdot_task.push_back(status.has(wbm::kDofAtLimitFrozen) || status.has(wbm::kDofBraked) || status.has(wbm::kDamped)
                            ? Eigen::VectorXd()
                            : Eigen::VectorXd(controller.solver().output().qdot_task));
  }

  /// @throws std::logic_error (naming `what`) unless `solver`, having just solved recorded
  /// cycle k, gave the controller's J# x_dot (the null-space part may differ: the stage's
  /// solver has no previous cycle for its jerk limit).
  void check(std::size_t k, const wbm::WholeBodySolver& solver, const std::string& what) const {
    const Eigen::VectorXd& expected = qdot_task[k];
    if (expected.size() != 0 && !((solver.output().qdot_task - expected).norm() <= 1e-9 * (1.0 + expected.norm())))
      throw std::logic_error(what + ": the solve stage's inputs at recorded state " + std::to_string(k) +
                             " do not give the controller's task velocities");
  }
};

}  // namespace wbm_bench
