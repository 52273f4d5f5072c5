#pragma once
/// @file
/// The robot models shipped with wbm, with the import options they need: the built-in
/// paper model, every URDF under models/third_party/ and wbm's own dual-arm robot
/// (models/dual_arm/); and a user's robot named in the environment (scripts/check_model.sh).
/// Shared by tests and benchmarks.

#include <optional>
#include <ostream>
#include <set>
#include <string>
#include <vector>

#include "wbm/model.hpp"
#include "wbm/task_stack.hpp"
#include "wbm/urdf_import.hpp"

#ifndef WBM_SOURCE_DIR
#error "WBM_SOURCE_DIR must be defined (the wbm source tree, set in tests/CMakeLists.txt)"
#endif

namespace wbm_test {

struct ShippedModel {
  /// Identifier usable in test names (letters, digits, underscores).
  std::string id;
  /// Absolute path of the URDF file; empty for the built-in paper model.
  std::string path;
  /// Import options (root, legs, default limits) this file needs.
  wbm::UrdfImportOptions options;
  /// Natural hand frames (a palm/gripper point where the file has one, else the last arm
  /// link) and the head/gaze frame (camera or gaze frame; empty if none).
  std::string left_hand, right_hand, head;
  /// Joints driven through <mimic> (the model covers mimic coupling); unknown for the
  /// user's robot (a <mimic> element may sit on a fixed joint or in a locked leg).
  std::optional<bool> has_mimic = false;
  /// The base never moves (a robot bolted to the world): tests that run the controller
  /// start from the upright base and keep the nine virtual dofs frozen.
  bool fixed_base = false;
  /// Share of random configurations, activations and frozen dofs in which the hand and head
  /// rows are far from singular (the solver does not damp), i.e. in which the pseudo-inverse
  /// identities are checked; the test fails below it, so that it cannot pass by skipping.
  /// The shipped models have 92-100 %; the user's robot may have less for a reason of its
  /// own: Baxter's head turns by one joint, so on its fixed base a 2-row view axis on it is
  /// singular whenever both rows are active (37 % checked).
  double min_full_rank_share = 0.5;

  bool is_urdf() const { return !path.empty(); }
  /// Builds the model (make_paper_model() or load_urdf(path, options)).
  wbm::Model load() const;
  /// Where a controller starts: home, with the base upright if it is fixed.
  Eigen::VectorXd start(const wbm::Model& model) const;
  /// Clears the virtual dofs in a free-dof mask if the base is fixed.
  void freeze_base(const wbm::Model& model, wbm::Mask& free_dofs) const;
};

/// gtest prints parameters with this (instead of a byte dump).
inline void PrintTo(const ShippedModel& m, std::ostream* os) { *os << m.id; }
/// Names the cases of a gtest suite over ShippedModel by the model's id (the last argument
/// of INSTANTIATE_TEST_SUITE_P); "user" for the user's robot, which check_model.sh filters on.
struct ModelIdName {
  template <class ParamInfo>
  std::string operator()(const ParamInfo& info) const { return info.param.id; }
};

/// All shipped models: the paper model first, then the URDFs; and last, if the environment
/// names one (WBM_TEST_URDF, scripts/check_model.sh), the user's robot with id "user".
const std::vector<ShippedModel>& shipped_models();
/// Only the URDF entries.
std::vector<ShippedModel> shipped_urdf_models();
/// URDF import options the shipped list does not use, on shipped files: G1 re-rooted at its
/// torso (its waist joints reversed), G1 with its legs dropped, and a synthetic robot with
/// prismatic and mimic joints (multipliers, offsets) rooted at three of its links.
std::vector<ShippedModel> import_variants();
/// The import variant with this id; throws std::out_of_range if there is none.
ShippedModel import_variant(const std::string& id);
/// The entry with this id; throws std::out_of_range if there is none.
const ShippedModel& shipped_model(const std::string& id);

/// The robot's joints (dofs of role kJoint) that move frame `frame`; empty for a frame welded
/// to the root link or in a locked leg. @throws wbm::ModelError for an unknown frame.
std::set<int> joints_moving(const wbm::Model& model, const std::string& frame);
/// True where every joint that moves one of the two frames also moves the other: two frames
/// of one arm (or body), a singular choice of hands for the tests and benchmarks.
bool on_one_arm(const wbm::Model& model, const std::string& a, const std::string& b);

/// Absolute path of a file in the source tree, e.g. source_path("tests/data/x.urdf").
inline std::string source_path(const std::string& relative) { return std::string(WBM_SOURCE_DIR) + "/" + relative; }

}  // namespace wbm_test
