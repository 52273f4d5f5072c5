#pragma once
/// @file
/// Benchmark fixtures of bench_wbm: one robot model with a task set, in wbm and in Orocos
/// KDL, built on first use and checked (the controller converges and moves, KDL agrees on
/// the kinematics and its solvers converge) before anything is timed.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "wbm/urdf_import.hpp"

namespace wbm_bench {

/// A model and the task elements a fixture controls.
struct FixtureSpec {
  std::string id;           ///< Benchmark name prefix, e.g. "paper_r12".
  std::string description;  ///< One line for the notes.
  /// URDF file; empty: the built-in paper model (its "URDF tree" for KDL is then
  /// wbm::export_urdf of it, from the upper body down).
  std::string urdf;
  wbm::UrdfImportOptions options;
  std::string left_hand, right_hand, head;  ///< Frames (also KDL segments).
  bool left_position = false, right_position = false;  ///< PositionTask, 3 rows each.
  bool left_axis = false, right_axis = false;          ///< AxisTask (grasp axis), 2 rows each.
  bool head_axis = false;                              ///< AxisTask (view axis), 2 rows.
  bool com = false;                                    ///< CenterOfMassTask relative to "heel", 3 rows.
  std::vector<std::string> joint_task;                 ///< JointTask (posture) dofs, 1 row each.
  /// Freeze all nine virtual dofs (heel and upper body), not only the heel: a robot on a
  /// fixed base, e.g. a dual-arm robot on a pedestal (its base never moves).
  bool fixed_base = false;
  /// Dof values [rad, or m for prismatic dofs] that replace the home pose's where every
  /// controller and solver starts (--start DOF=VALUE,...): arms stretched at the home pose
  /// (the centre of every joint range) keep a robot's hands from moving.
  std::vector<std::pair<std::string, double>> start_values;
  /// A robot given on the command line (--wbm_urdf), whatever its id: its tracking is
  /// reported, not held to the shipped fixtures' limits (see Fixture::check_wbm).
  bool user_robot = false;

  int rows() const;
};

/// paper_r3, paper_r6, paper_r12, g1_r20, romeo_r12 (see bench/README.md).
std::vector<FixtureSpec> standard_fixtures();

/// A fixture on any URDF: both hands position + grasp axis, and the head's view axis if
/// `head` is set (12 or 10 rows). `root`/`legs`/... as for wbm::load_urdf.
FixtureSpec custom_fixture(const std::string& id, const std::string& urdf, const wbm::UrdfImportOptions& options,
                           const std::string& left_hand, const std::string& right_hand, const std::string& head);

/// Builds and checks the fixture (as its benchmarks do on first use) and keeps it for them.
/// @return an empty string, or what failed (also recorded as a failure in the notes).
std::string prepare_fixture(const FixtureSpec& spec);

/// The fixture's control cycle as a robot's loop runs it (for the periodic loop):
/// `next_targets(dt)` moves the targets on by dt [s] as the cycle benchmarks do, `update(dt)`
/// runs one cycle and returns status flags (wbm's; for KDL kInvalidInput if its joint
/// values are no longer finite). Both work on the fixture's state, which the cycle
/// benchmarks use too.
struct ControlCycle {
  std::function<void(double)> next_targets;
  std::function<std::uint32_t(double)> update;
  int rows = 0, dofs = 0;
};
/// Which cycle: wbm::Controller::update, or KDL's TreeIkSolverVel_wdls cycle on the same
/// tree (as <id>/kdl_wdls/cycle).
enum class LoopSolver { kWbm, kKdlWdls };
/// @pre prepare_fixture(spec) returned no error. @throws std::logic_error otherwise.
ControlCycle control_cycle(const FixtureSpec& spec, LoopSolver solver);

/// Benchmark bodies; each builds (and checks) the fixture on first use.
/// (a) forward kinematics + the active rows' Jacobians.
void bm_wbm_kinematics(benchmark::State& state, const FixtureSpec* spec);
void bm_kdl_kinematics(benchmark::State& state, const FixtureSpec* spec);
/// (b) one wbm::Controller::update() with moving targets.
void bm_wbm_cycle(benchmark::State& state, const FixtureSpec* spec);
/// (b'') the same with cold caches: before each timed cycle (untimed) 2 MiB of other data
/// are read and written and 64 KiB of other code run, as a robot's other work between two
/// control cycles would (L1 and L2 evicted; the shared L3 not).
void bm_wbm_cycle_cold(benchmark::State& state, const FixtureSpec* spec);
/// (b') the same with the hand targets 1 m beyond the hands, after 3 s of reaching for them:
/// arms stretched (the damped path), dofs at their limits (frozen and re-solved).
void bm_wbm_cycle_out_of_reach(benchmark::State& state, const FixtureSpec* spec);
/// (c) KDL closed-loop cycle: endpoint FK, twists, TreeIkSolverVel_wdls, integration, on the
/// same tree as wbm (wbm::export_urdf with the virtual dofs: the same dofs, joint weights as
/// wbm's W, heel frozen) and on the URDF's own tree (no virtual dofs, legs included);
/// and ChainIkSolverVel_pinv_nso on the right arm chain (plain pinv for arms with fewer
/// than 6 joints, which pinv_nso does not support).
void bm_kdl_wdls_cycle(benchmark::State& state, const FixtureSpec* spec);
void bm_kdl_wdls_urdf_cycle(benchmark::State& state, const FixtureSpec* spec);
/// KDL's wdls cycle on wbm's whole tree with cold caches, as bm_wbm_cycle_cold.
void bm_kdl_wdls_cycle_cold(benchmark::State& state, const FixtureSpec* spec);
void bm_kdl_arm_cycle(benchmark::State& state, const FixtureSpec* spec);
/// (b) against (c) paired: rounds of 24 wbm cycles and 2 KDL wdls cycles (same tree),
/// alternating, each cycle timed on its own and the first of each block untimed (it runs
/// after the other solver's code and data). A slow spell of the machine (seconds) then hits
/// both alike, so the ratio of the two medians (counter `ratio`; `p50_us`/`p99_us` are wbm's,
/// `kdl_p50_us` KDL's) moves less from run to run than that of the separate benchmarks.
void bm_wbm_vs_kdl_wdls_paired(benchmark::State& state, const FixtureSpec* spec);

/// Stages of one controller cycle, timed alone with the library's public functions on
/// states recorded from the fixture's moving-target run (where the cycle's time goes).
enum class Part { kFilters, kForwardKinematics, kCenterOfMass, kValues, kAssemble, kGradient, kSolve, kIntegrate };
const char* part_name(Part part);
std::vector<Part> all_parts();
void bm_wbm_part(benchmark::State& state, const FixtureSpec* spec, Part part);
/// The solve stage with 64 KiB of other code run (untimed) before each call: the solver's
/// code no longer decoded in the op cache nor in the L1 instruction cache, its data still in
/// L1. Against the solve stage alone, what decoding the solver's code again costs; inside the
/// cycle the other stages' code does the same (bench/README.md, "Inside the cycle").
void bm_wbm_solve_after_other_code(benchmark::State& state, const FixtureSpec* spec);

}  // namespace wbm_bench
