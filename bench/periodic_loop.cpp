#include "periodic_loop.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <vector>

namespace wbm_bench {
namespace {

constexpr std::int64_t kNsPerSecond = 1000000000;

std::int64_t now_ns() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<std::int64_t>(t.tv_sec) * kNsPerSecond + t.tv_nsec;
}

void wait_until(std::int64_t ns, bool spin) {
  if (spin) {
    while (now_ns() < ns) {
    }
    return;
  }
  timespec t{};
  t.tv_sec = static_cast<time_t>(ns / kNsPerSecond);
  t.tv_nsec = static_cast<long>(ns % kNsPerSecond);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr) == EINTR) {
  }
}

/// The p-quantile (0 <= p <= 1) of v; reorders v.
double quantile(std::vector<float>& v, double p) {
  if (v.empty()) return 0.0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

/// SCHED_FIFO and locked memory for the calling thread while it exists; the previous
/// policy restored and the memory unlocked afterwards.
class RealtimeScheduling {
 public:
  explicit RealtimeScheduling(int priority) {
    if (priority <= 0) {
      description_ = "as started (no SCHED_FIFO asked for)";
      return;
    }
    pthread_getschedparam(pthread_self(), &old_policy_, &old_param_);
    sched_param param{};
    param.sched_priority = std::clamp(priority, sched_get_priority_min(SCHED_FIFO), sched_get_priority_max(SCHED_FIFO));
    const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
    fifo_ = rc == 0;
    description_ = fifo_ ? "SCHED_FIFO " + std::to_string(param.sched_priority)
                         : "SCHED_OTHER (SCHED_FIFO refused: " + std::string(std::strerror(rc)) + ")";
    locked_ = mlockall(MCL_CURRENT | MCL_FUTURE) == 0;
    description_ += locked_ ? ", memory locked" : ", memory not locked (mlockall: " + std::string(std::strerror(errno)) + ")";
  }
  ~RealtimeScheduling() {
    if (fifo_) pthread_setschedparam(pthread_self(), old_policy_, &old_param_);
    if (locked_) munlockall();
  }
  RealtimeScheduling(const RealtimeScheduling&) = delete;
  RealtimeScheduling& operator=(const RealtimeScheduling&) = delete;
  const std::string& description() const { return description_; }

 private:
  int old_policy_ = SCHED_OTHER;
  sched_param old_param_{};
  bool fifo_ = false, locked_ = false;
  std::string description_;
};

}  // namespace

PeriodicLoopResult run_periodic_loop(const PeriodicLoopOptions& options, const std::function<void(double)>& before,
                                     const std::function<std::uint32_t(double)>& cycle, const LoopProgress& progress) {
  if (!(std::isfinite(options.seconds) && options.seconds > 0.0))
    throw std::invalid_argument("loop length must be a positive number of seconds");
  if (!(std::isfinite(options.rate_hz) && options.rate_hz > 0.0 && options.rate_hz <= 1e6))
    throw std::invalid_argument("loop rate must be a positive number of Hz, at most 1e6");
  if (options.seconds * options.rate_hz > 1e8) throw std::invalid_argument("loop too long: more than 1e8 periods");
  if (options.spin && options.fifo_priority > 0)
    throw std::invalid_argument("a busy-waiting loop with SCHED_FIFO: the kernel throttles it (priority 0 expected)");
  const std::int64_t period = std::max<std::int64_t>(1, std::llround(1e9 / options.rate_hz));
  const double dt = static_cast<double>(period) * 1e-9;
  const long recorded = std::max(1L, std::lround(options.seconds * options.rate_hz));
  const long warmup = std::max(0L, std::lround(std::max(0.0, options.warmup_seconds) * options.rate_hz));
  const long per_second = std::max(1L, std::lround(options.rate_hz));

  PeriodicLoopResult r;
  r.period_us = 1e-3 * static_cast<double>(period);
  r.cycle_us.reserve(static_cast<std::size_t>(recorded));  // before the loop: no allocation inside it
  r.wake_us.reserve(static_cast<std::size_t>(recorded));
  const RealtimeScheduling scheduling(options.fifo_priority);
  r.scheduling = scheduling.description() + (options.spin ? ", busy-waiting" : ", sleeping between periods");

  // The loop covers `warmup` periods and then `recorded` ones of wall time: where starts are
  // skipped, fewer cycles are recorded (never more, so the reserved samples suffice).
  std::int64_t start = now_ns() + period;
  const std::int64_t record_from = start + warmup * period;
  const std::int64_t end = record_from + recorded * period;
  long reported = 0;  // whole seconds of the recorded part passed on to `progress`
  while (start < end) {
    wait_until(start, options.spin);
    const std::int64_t woke = now_ns();
    before(dt);
    const std::int64_t t0 = now_ns();
    r.flags |= cycle(dt);
    const std::int64_t t1 = now_ns();
    const bool recording = start >= record_from;
    std::int64_t next = start + period;
    if (recording) {
      // The maxima of the stored (float) samples, so that they bound the percentiles exactly.
      const float c = static_cast<float>(1e-3 * static_cast<double>(t1 - t0));
      const float w = static_cast<float>(1e-3 * static_cast<double>(woke - start));
      r.cycle_us.push_back(c);
      r.wake_us.push_back(w);
      r.cycle_max = std::max(r.cycle_max, static_cast<double>(c));
      r.wake_max = std::max(r.wake_max, static_cast<double>(w));
      r.busy_max = std::max(r.busy_max, 1e-3 * static_cast<double>(t1 - start));
      r.overruns += t1 > next;
      ++r.periods;
    }
    // Periods whose start has passed by a whole period are not run late: the loop goes on
    // with the next one still ahead (as a robot's loop that keeps its phase).
    if (t1 > next + period) {
      const std::int64_t behind = (t1 - next) / period;
      // Skipped starts next + k period, 0 <= k < behind, that lie in [record_from, end): all
      // starts are on one grid, so the divisions are exact.
      const std::int64_t first_k = std::clamp<std::int64_t>((record_from - next) / period, 0, behind);
      const std::int64_t last_k = std::clamp<std::int64_t>((end - next) / period, 0, behind);
      r.skipped += std::max<std::int64_t>(0, last_k - first_k);
      next += behind * period;
    }
    start = next;
    const long seconds_done = recording ? static_cast<long>((start - record_from) / (per_second * period)) : 0;
    if (progress && seconds_done > reported && start < end) {
      reported = seconds_done;
      progress(static_cast<double>(seconds_done), r);
    }
  }
  std::vector<float> sorted = r.cycle_us;  // the samples stay in period order
  r.cycle_p50 = quantile(sorted, 0.5);
  r.cycle_p99 = quantile(sorted, 0.99);
  r.cycle_p999 = quantile(sorted, 0.999);
  sorted = r.wake_us;
  r.wake_p50 = quantile(sorted, 0.5);
  r.wake_p99 = quantile(sorted, 0.99);
  return r;
}

}  // namespace wbm_bench
