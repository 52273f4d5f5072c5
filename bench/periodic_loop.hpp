#pragma once
/// @file
/// The controller in a periodic real-time loop, as a robot runs it: wake at absolute
/// times t0 + k T (clock_nanosleep on CLOCK_MONOTONIC), run one cycle, sleep again.
/// Where the benchmarks time calls back to back, this shows what a 1 kHz loop sees: the
/// worst case over many periods, how late the thread wakes, and periods overrun.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace wbm_bench {

/// @pre seconds > 0, rate_hz > 0.
struct PeriodicLoopOptions {
  double seconds = 10.0;   ///< Length of the timed run [s] (after `warmup_seconds`).
  double rate_hz = 1000.0; ///< Loop rate [Hz]; the period T = 1 / rate_hz is also the cycle's dt.
  double warmup_seconds = 0.1;  ///< Periods run first and not recorded [s].
  /// SCHED_FIFO priority asked for (1-99), with all memory locked (mlockall); 0: neither.
  /// If the system refuses, the loop runs as it is and the result says why.
  int fifo_priority = 80;
  /// Busy-wait for each period's start instead of sleeping (as a loop on an isolated core
  /// may): the core never idles, so caches and predictors stay warmer. Not with SCHED_FIFO,
  /// which the kernel throttles (sched_rt_runtime_us: 50 ms of every second by default).
  /// @pre !spin || fifo_priority == 0.
  bool spin = false;
};

/// Times [us]; percentiles over the recorded periods.
struct PeriodicLoopResult {
  long periods = 0;            ///< Periods recorded (seconds x rate, less the skipped ones).
  long overruns = 0;           ///< Cycles that ended after the next period's start.
  long skipped = 0;            ///< Periods whose start had passed when the loop woke (not run).
  double cycle_p50 = 0, cycle_p99 = 0, cycle_p999 = 0, cycle_max = 0;  ///< The cycle alone.
  double wake_p50 = 0, wake_p99 = 0, wake_max = 0;  ///< From a period's start to the thread running.
  double busy_max = 0;         ///< Largest wake-up latency + cycle: the part of a period used.
  std::uint32_t flags = 0;     ///< Status flags of all cycles, or-ed.
  std::string scheduling;      ///< E.g. "SCHED_FIFO 80, memory locked" or why not.
  std::vector<float> cycle_us, wake_us;  ///< Per recorded period, in order [us].
  double period_us = 0;        ///< The period used (1e6 / rate, rounded to whole ns) [us].
};

/// Called about once per second of the run (outside the timed part of a period).
using LoopProgress = std::function<void(double seconds_done, const PeriodicLoopResult& so_far)>;

/// Runs `cycle(dt)` once per period; `before(dt)` runs untimed just before it (the next
/// targets). Returns the statistics; restores the thread's scheduling and unlocks memory.
/// @throws std::invalid_argument for a non-positive or non-finite length or rate, or spin
/// with a SCHED_FIFO priority.
PeriodicLoopResult run_periodic_loop(const PeriodicLoopOptions& options, const std::function<void(double)>& before,
                                     const std::function<std::uint32_t(double)>& cycle,
                                     const LoopProgress& progress = {});

}  // namespace wbm_bench
