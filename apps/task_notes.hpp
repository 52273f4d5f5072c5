#pragma once
/// @file
/// What `wbm run` (its console lines, summary.json and the report) notes about a scenario's
/// task elements before it runs: an element that no dof free in the scenario can move.
#include <string>
#include <vector>

#include <Eigen/Core>

#include "wbm/model.hpp"
#include "wbm/task_stack.hpp"

namespace wbm {

/// A note, one sentence without a "note: " prefix, for each element of `stack` with
/// `considered[e]` whose Jacobian's columns of every dof with `ever_free[dof]` vanish (below
/// 1e-10) at `q0` and at four random configurations within the limits (fixed seed): no dof
/// the scenario leaves free, or releases later, moves it, so it stays where it is (a view
/// axis on a frame welded to the root of a robot on a fixed base, say). The note names the
/// dofs that do move it, all frozen, or says that none does. Its Jacobian, not its type,
/// decides, so it holds for every kind of element.
/// @pre ever_free.size() == model.num_dofs(), considered.size() == stack.num_elements(),
///      q0 within the limits.
std::vector<std::string> immovable_task_notes(const Model& model, TaskStack& stack, const std::vector<bool>& ever_free,
                                              const std::vector<bool>& considered, const Eigen::VectorXd& q0);

}  // namespace wbm
