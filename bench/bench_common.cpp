#include "bench_common.hpp"

#include <algorithm>
#include <cstdio>

namespace wbm_bench {
namespace {

double g_overhead_ns = 0.0;
std::vector<std::string> g_notes;
bool g_failed = false;
constexpr std::size_t kMaxSamples = std::size_t{1} << 22;  // 4M single-call samples (16 MB)

double percentile(std::vector<float>& v, double p) {
  if (v.empty()) return 0.0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace

void calibrate_timer() {
  using Clock = std::chrono::steady_clock;
  std::vector<float> d(200000);
  for (float& x : d) {
    const Clock::time_point t0 = Clock::now();
    const Clock::time_point t1 = Clock::now();
    x = static_cast<float>(std::chrono::duration<double, std::nano>(t1 - t0).count());
  }
  g_overhead_ns = percentile(d, 0.5);
}

double timer_overhead_ns() { return g_overhead_ns; }

void note(const std::string& line) { g_notes.push_back(line); }
const std::vector<std::string>& notes() { return g_notes; }
void fail(const std::string& line) {
  g_failed = true;
  g_notes.push_back("FAILED: " + line);
  std::fprintf(stderr, "bench_wbm: FAILED: %s\n", line.c_str());
}
bool any_failure() { return g_failed; }

std::vector<float>& sample_buffer() {
  static std::vector<float> buffer = [] {
    std::vector<float> b;
    b.reserve(kMaxSamples);
    return b;
  }();
  return buffer;
}

double sample_percentile(std::vector<float>& samples, double p) { return percentile(samples, p); }

void set_percentile_counters(benchmark::State& state, std::vector<float>& samples_ns) {
  const double p50 = percentile(samples_ns, 0.50);
  const double p99 = percentile(samples_ns, 0.99);
  state.counters["p50_us"] = benchmark::Counter(p50 * 1e-3);
  state.counters["p99_us"] = benchmark::Counter(p99 * 1e-3);
}

}  // namespace wbm_bench
