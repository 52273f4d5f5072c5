#pragma once
/// @file
/// The loop of a walking robot as a benchmark (bench_wbm's paper_walk/...): the paper's
/// section VI walk (an object 1.5 m ahead, 0.5 m to the left, left hand position and grasp
/// axis) with balance, in wbm run's order: WalkingModule::update, the support polygon (the
/// feet, or the support planned beside the floating heel during a walk),
/// BalanceModule::update, Controller::update. The walk restarts from the home pose when it
/// has ended (untimed), so that the samples cover standing, triggering, stepping and
/// finishing in their proportions.

#include <benchmark/benchmark.h>

namespace wbm_bench {

/// What is timed of each cycle.
enum class WalkPart {
  kCycle,    ///< the whole loop: the two modules and the controller cycle
  kModules,  ///< the walking and balance modules and the support polygon, without the controller
};

/// @pre calibrate_timer() was called. Counters: walks (ended during the run), footsteps
/// (per walk), walking_pct (share of cycles in a walk), and those of timed_loop.
void bm_walk(benchmark::State& state, WalkPart part);

}  // namespace wbm_bench
