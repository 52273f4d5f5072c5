#pragma once
/// @file
/// Runs a scenario as a motion simulation and records every cycle.

#include <array>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "scenario.hpp"
#include "wbm/balance.hpp"
#include "wbm/controller.hpp"
#include "wbm/walking.hpp"

namespace wbm {

/// Everything recorded, one entry per cycle (index 0 is the initial state).
struct ScenarioRun {
  Scenario scenario;
  std::unique_ptr<Model> model;
  std::unique_ptr<Controller> controller;
  std::vector<std::string> element_types;
  std::vector<double> time;
  std::vector<Eigen::VectorXd> q, qdot;
  std::vector<Eigen::VectorXd> commanded, filtered, actual;  ///< num_targets each
  std::vector<Eigen::VectorXd> error, tracking_error;        ///< per element: distance to commanded / filtered target
  std::vector<Eigen::VectorXd> active;                       ///< per element 0/1
  std::vector<std::uint32_t> flags;
  std::vector<double> cost, cycle_us, min_singular_value;
  std::vector<Eigen::VectorXd> balance;  ///< com x, y, support centroid x, y, ub shift x, y, com margin (balance on)
  std::vector<Eigen::VectorXd> walking;  ///< real heel x, y, yaw, walking 0/1, walking flags (walking on)
  std::vector<Footstep> footsteps;
  WalkingParameters walking_parameters;  ///< those the walk used (the file's, else scaled to the robot)
  FootGeometry feet;                     ///< the feet used for the support polygon
  std::vector<SupportPolygon> support;   ///< per cycle when balance or walking runs (empty otherwise)
  bool balance_on_at_end = false;        ///< balance was switched on in the last cycle (scenario or its events)
  /// Where balance drove an upper-body shift dof (x, then y) at its position limit further out
  /// (BalanceFlag kShiftAtLimit): the cycles, the limit (+1 upper, -1 lower; the last such
  /// cycle's), and the farthest shift the centre of mass would have needed to reach the law's
  /// target (the shift plus the centre of mass's offset from the support's centroid along
  /// the dof) [m].
  struct ShiftAtLimit {
    int cycles = 0, side = 0;
    double needed = 0.0;
  };
  std::array<ShiftAtLimit, 2> shift_at_limit;
  int balanced_cycles = 0;  ///< cycles with balance on
  /// Elements no dof free in the scenario moves (immovable_task_notes) and joint targets outside
  /// their dofs' ranges, found before the run.
  std::vector<std::string> task_notes;

  int num_cycles() const { return static_cast<int>(time.size()); }
  int element(const std::string& name) const { return controller->tasks().element_index(name); }
  /// Target entries of an element at cycle k.
  Eigen::VectorXd actual_of(const std::string& name, int k) const;
  Eigen::VectorXd commanded_of(const std::string& name, int k) const;
};

struct RunOptions {
  bool progress = false;  ///< progress bar on stderr
  /// Build the model, the controller and the modules and look up every name, then return
  /// without simulating (the run holds no cycles): to check several files before any runs.
  bool check_only = false;
};

/// Builds the model and controller and simulates the scenario.
/// @throws ConfigError / ModelError naming the scenario line for unknown names or sizes.
std::unique_ptr<ScenarioRun> run_scenario(const Scenario& scenario, const RunOptions& options = {});

/// How far the body's heel (the heel dofs, where the floating heel took the upper body) is
/// ahead of the real heel between the feet in recorded cycle k [m]. @pre walking ran.
double body_lead(const ScenarioRun& run, size_t k);

/// The unit summary.json and the report give an element's errors in: "deg" (axis,
/// attitude), "mm" (position, com), and for joints by the element's row units
/// (TaskElement::row_unit): "rad", "m" (prismatic dofs) or "rad, m".
std::string error_unit(const ScenarioTask& task, const TaskElement& element);
/// The factor from the element's error (m, rad) to that unit: 1000, 180 / pi or 1.
double error_scale(const ScenarioTask& task);

/// Per-element final and maximum errors, joint speed/acceleration maxima, limit distances,
/// cycle-time statistics and status counts.
nlohmann::json summarize(const ScenarioRun& run);

/// One entry of summary.json's `balance.shift_at_limit` in words, for the console and the
/// report: "upper_body_x held at its limit 14.0 cm in 4770 of 5000 balanced cycles (95.4 %);
/// the centre of mass would have needed 21.2 cm: widen ...".
std::string describe_shift_at_limit(const nlohmann::json& entry, int balanced_cycles);

/// summary.json's `at_end` in words, for the console and the report: "damped (near a
/// singularity, or a target out of reach); at a position limit: right_joint_2 (lower)", or
/// "" when nothing held the last cycle.
std::string describe_last_cycle(const nlohmann::json& at_end);
/// summarize()'s "walking" in words: the footsteps and walks with the step limits used, and
/// a second line when max_steps ended a walk (how far the feet then stand from the body).
std::vector<std::string> describe_walking(const nlohmann::json& walking);

/// Writes trajectory.csv, summary.json and report.html into `directory` (created if
/// needed). Files are written to temporaries and renamed, so nothing half-written remains.
void write_outputs(const ScenarioRun& run, const std::string& directory, bool report = true);

/// Condition number of the 3-row position Jacobian of `frame`, weighted by W^-1/2
/// (sigma_max / sigma_min), using all dofs or only the robot's joints (no virtual dofs);
/// infinity where sigma_min is not above 1e-12 sigma_max (rank below 3).
double position_condition_number(const Model& model, const Data& data, int frame, bool joints_only);

}  // namespace wbm
