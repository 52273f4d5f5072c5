#pragma once
/// @file
/// Scaling study of bench_wbm: controller cycle time on generated trees against the number
/// of dofs and against the number of active task rows.

#include <string>
#include <vector>

#include <benchmark/benchmark.h>

namespace wbm_bench {

struct ScalingCase {
  std::string name;  ///< Benchmark name, e.g. "scaling/dofs/49".
  int joints = 0;    ///< Revolute joints in the branches (the model adds 9 virtual dofs).
  int branches = 0;  ///< Serial branches on the torso.
  int rows = 0;      ///< Active task rows (position elements on branch tips).
};

/// dofs sweep: 10..100 joints in 4 branches, 12 rows ("scaling/dofs/<n>"); rows sweeps:
/// 3..40 rows on trees of 60 and 100 joints with 14 branches ("scaling/rows_n<n>/<m>").
std::vector<ScalingCase> scaling_cases();

/// What is timed: the whole Controller::update(), or one stage on states recorded from the
/// moving run (TaskStack::assemble after forward kinematics; WholeBodySolver::solve).
enum class ScalingStage { kCycle, kAssemble, kSolve };
/// "" for the cycle ("scaling/<sweep>/<x>"), else the suffix ("scaling/<sweep>/<x>/solve").
const char* stage_name(ScalingStage stage);
void bm_scaling(benchmark::State& state, const ScalingCase* c, ScalingStage stage);

}  // namespace wbm_bench
