#pragma once
/// @file
/// Timing harness shared by the benchmarks of bench_wbm: every benchmark iteration is one
/// call, timed on its own with std::chrono::steady_clock (Google Benchmark's manual time),
/// so that the median and the 99th percentile of single calls can be reported next to
/// the mean.

#include <chrono>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

namespace wbm_bench {

/// Measures the median cost of one pair of steady_clock::now() calls; call once at start.
void calibrate_timer();
/// The calibrated overhead [ns]; it is subtracted from every sample.
double timer_overhead_ns();

/// Lines printed after the run (sanity checks, model sizes), in the order added.
void note(const std::string& line);
const std::vector<std::string>& notes();
/// Marks the run as failed (a sanity check did not pass); main() returns 1.
void fail(const std::string& line);
bool any_failure();

/// Per-run sample buffer (reserved once, reused).
std::vector<float>& sample_buffer();
/// Sets the counters p50_us and p99_us (median and 99th percentile of single calls).
void set_percentile_counters(benchmark::State& state, std::vector<float>& samples_ns);
/// The p-quantile (0 <= p <= 1) of the samples (reordered in place); 0 for none.
double sample_percentile(std::vector<float>& samples, double p);

/// Runs `body` once per benchmark iteration after `prepare` (untimed: e.g. the next
/// target of a moving trajectory), times each call of `body` with steady_clock, reports
/// the sum as manual time and sets the percentile counters.
template <class Prepare, class Body>
void timed_loop(benchmark::State& state, Prepare&& prepare, Body&& body) {
  using Clock = std::chrono::steady_clock;
  std::vector<float>& samples = sample_buffer();
  samples.clear();
  const double overhead = timer_overhead_ns();
  for (auto _ : state) {
    prepare();
    const Clock::time_point t0 = Clock::now();
    body();
    const Clock::time_point t1 = Clock::now();
    double ns = std::chrono::duration<double, std::nano>(t1 - t0).count() - overhead;
    if (ns < 0.0) ns = 0.0;
    state.SetIterationTime(ns * 1e-9);
    if (samples.size() < samples.capacity()) samples.push_back(static_cast<float>(ns));
  }
  set_percentile_counters(state, samples);
}

}  // namespace wbm_bench
