#pragma once
/// @file
/// Scenario files (YAML): robot, task elements, timing and a timeline of commands.
/// The format is documented in docs/scenarios.md.

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "wbm/controller.hpp"
#include "wbm/urdf_import.hpp"
#include "wbm/walking.hpp"

namespace wbm {

/// Most cycles one scenario may run (1000 s at 1 kHz): the run keeps every cycle in memory.
constexpr int kMaxScenarioCycles = 1000000;

/// Cycles a scenario of `duration` at `dt` runs (the nearest whole number); 0 if that is
/// not 1 to kMaxScenarioCycles (or dt is not > 0). Cycle k (from 1) starts at (k - 1) dt.
int scenario_cycles(double duration, double dt);

struct ScenarioTask {
  std::string name;
  std::string type;  ///< position | axis | attitude | com | joints
  std::string frame;
  std::string reference;  ///< "" = world
  Vector3 axis = Vector3::UnitZ();  ///< axis tasks: the axis in the frame
  std::vector<std::string> dofs;  ///< joints tasks
  double gain = 10.0;
  FilterParameters filter;
  bool active = false;
  int line = 0;  ///< of the entry in the file, for messages about names the model lacks
};

/// A row selection "element" (all rows) or "element.component" (x/y/z, roll/pitch/yaw,
/// a row index, or a dof name for joint tasks).
struct RowSelection {
  std::string text;
  int line = 0;
  std::string field;  ///< where it was given, e.g. "timeline[2].deactivate"
};

struct ScenarioEvent {
  double time = 0.0;
  int line = 0;
  std::vector<std::pair<std::string, Eigen::VectorXd>> targets;           ///< absolute
  std::vector<std::pair<std::string, Eigen::VectorXd>> relative_targets;  ///< added to the value at that time
  std::string field;  ///< "timeline[i]", for errors found when the elements are known
  std::vector<int> target_lines, relative_target_lines;  ///< the line of each entry (if read from a file)
  std::vector<RowSelection> activate, deactivate;
  std::vector<std::string> freeze, release;
  int balance = -1;  ///< -1 unchanged, 0 off, 1 on
};

struct BalanceSettings {
  bool configured = false;  ///< the scenario has a balance section (record the com margin)
  bool enabled = false;
  bool compensate = true;  ///< feed x_bal into the solver (eq. 21)
  double gain = 5.0;       ///< [1/s]
  double margin = 0.0;     ///< [m]
};

/// Feet for the support polygon: size from the user (default: ASIMO-like), spacing from
/// the user or measured between two foot frames of the model at the home pose.
struct FeetSettings {
  FootGeometry geometry;
  std::string left_frame, right_frame;  ///< e.g. the URDF's ankle or sole links
  int line = 0;
};

struct WalkingSettings {
  bool enabled = false;
  WalkingParameters parameters;
  /// Which of the scaled fields the file gives; the others the runner takes from
  /// scaled_walking_parameters (the defaults scaled to the robot's feet and height).
  bool min_width_given = false, max_width_given = false, length_given = false, duration_given = false;
  bool tolerance_given = false;  ///< position_tolerance (scaled to the robot when not given)
  int line = 0;
};

struct Scenario {
  std::string name;             ///< also the output directory's name when several run
  int name_line = 0;
  std::string description;
  std::string source;           ///< the file, for messages
  std::string urdf;             ///< empty: built-in paper model
  UrdfImportOptions urdf_options;
  /// robot.fixed_base: the nine virtual dofs start upright (upright_base_configuration)
  /// and stay frozen; balance, walking and releasing one of them are errors.
  bool fixed_base = false;
  int robot_line = 0;           ///< for messages of the URDF import
  double dt = 0.001;
  double duration = 1.0;
  int record_every = 10;
  SolverParameters solver;
  std::string criterion = "cubic";
  double criterion_band = 0.3;
  std::vector<std::pair<std::string, double>> initial;  ///< dof values replacing the home pose
  std::vector<std::string> frozen;                      ///< initially frozen dofs
  int initial_line = 0, frozen_line = 0;                ///< for messages about unknown dofs
  std::vector<ScenarioTask> tasks;
  std::vector<ScenarioEvent> events;                    ///< in the order of their times (the file's; an event before the previous one is an error)
  BalanceSettings balance;
  WalkingSettings walking;
  FeetSettings feet;
};

/// The longest file name Linux file systems take (NAME_MAX) [bytes]: a scenario's name and
/// each new directory of --out are checked against it before anything runs, since creating
/// the directory fails only after the simulation.
inline constexpr std::size_t kMaxFileNameBytes = 255;

/// @throws ConfigError "FILE:LINE: field: what was expected" for any bad entry.
Scenario load_scenario(const std::string& path);
Scenario parse_scenario(const std::string& yaml, const std::string& source, const std::string& base_dir);

}  // namespace wbm
