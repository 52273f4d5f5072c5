#include "walking_loop.hpp"

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "bench_common.hpp"
#include "wbm/balance.hpp"
#include "wbm/controller.hpp"
#include "wbm/paper_model.hpp"
#include "wbm/tasks/axis_task.hpp"
#include "wbm/tasks/position_task.hpp"
#include "wbm/walking.hpp"

namespace wbm_bench {
namespace {

constexpr double kWalkDt = 1e-3;     // [s]
constexpr int kCyclesPerWalk = 14000;  // 14 s: the walk of scenarios/walk_object_ahead.yaml ends after about 9

/// The controller, the modules and the command of one walk, built once per benchmark.
class WalkLoop {
 public:
  WalkLoop()
      : model_(wbm::make_paper_model()),
        controller_(model_),
        balance_(model_, std::make_unique<wbm::CenterOfMassCentering>(5.0, 0.0), feet_),
        walking_(model_, feet_, wbm::scaled_walking_parameters(model_, feet_)) {
    controller_.add_task(std::make_unique<wbm::PositionTask>(model_, "l_hand", "l_hand_ref"), {3.0, 0.4, 2});
    controller_.add_task(std::make_unique<wbm::AxisTask>(model_, "l_grasp", "l_hand_ref"), {3.0, 0.8, 2});
    restart();
  }

  /// Back to the home pose, standing, the object commanded (untimed: it allocates).
  void restart() {
    controller_.reset(model_.home());
    command_ = controller_.make_command();
    command_.external_velocity = Eigen::VectorXd::Zero(model_.num_dofs());
    command_.task_active.setConstant(true);
    command_.targets << 1.5, 0.5, 0.75, 0.0, 0.0, 1.0;
    walking_ = wbm::WalkingModule(model_, feet_, wbm::scaled_walking_parameters(model_, feet_));
    balance_.disable(command_);
    last_ = {};
    cycle_ = 0;
  }

  /// Walking and balance for the next cycle: the command's b_C and external velocities.
  /// Returns the walking module's flags.
  std::uint32_t modules() {
    const std::uint32_t flags = walking_.update(controller_, last_, cycle_ * kWalkDt, kWalkDt, command_);
    if ((flags & wbm::kWalkFinished) != 0) {
      ++walks_;
      footsteps_in_walks_ = footsteps_ + walking_.num_footsteps();  // up to the end of this walk
    }
    in_walk_ += walking_.walking() ? 1 : 0;
    balance_.update(controller_.data(), walking_.balance_support(controller_.q()), kWalkDt, command_);
    return flags;
  }
  void control() { last_ = controller_.update(command_, kWalkDt); }
  /// After a timed cycle (untimed): count it, restart at the end of a walk's time.
  void next() {
    failed_ = failed_ || !last_.ok() || !controller_.q().allFinite();
    ++cycles_;
    if (++cycle_ == kCyclesPerWalk) {
      footsteps_ += walking_.num_footsteps();
      restart();
    }
  }

  /// One whole walk, untimed, as the fixtures are checked before they are timed: it must
  /// walk, end, and bring the hand to the object. Sets `ok`; returns what it saw.
  std::string check(bool& ok) {
    std::uint32_t seen = 0;
    bool finite = true;
    for (cycle_ = 0; cycle_ < kCyclesPerWalk && finite; ++cycle_) {
      seen |= modules();
      control();
      finite = last_.ok() && controller_.q().allFinite();
    }
    const double error = (controller_.values().head<3>() - Eigen::Vector3d(1.5, 0.5, 0.75)).norm();
    char line[200];
    std::snprintf(line, sizeof line, "%d footsteps, %s after %.0f s, the hand %.2g mm from the object",
                  walking_.num_footsteps(), walking_.walking() ? "still walking" : "standing", kCyclesPerWalk * kWalkDt,
                  1e3 * error);
    ok = finite && (seen & wbm::kWalkFinished) != 0 && !walking_.walking() && walking_.num_footsteps() >= 3 &&
         error < 1e-3;
    restart();
    walks_ = in_walk_ = footsteps_in_walks_ = 0;  // the counters are the timed run's
    return line;
  }

  bool failed() const { return failed_; }
  long walks() const { return walks_; }
  /// Footsteps of the walks that ended (not of one still going at the end of the run).
  long footsteps_in_walks() const { return footsteps_in_walks_; }
  double walking_share() const { return cycles_ > 0 ? static_cast<double>(in_walk_) / static_cast<double>(cycles_) : 0.0; }

 private:
  wbm::FootGeometry feet_;
  wbm::Model model_;
  wbm::Controller controller_;
  wbm::BalanceModule balance_;
  wbm::WalkingModule walking_;
  wbm::Command command_;
  wbm::ControllerStatus last_;
  int cycle_ = 0;
  long cycles_ = 0, walks_ = 0, footsteps_ = 0, footsteps_in_walks_ = 0, in_walk_ = 0;
  bool failed_ = false;
};

}  // namespace

void bm_walk(benchmark::State& state, WalkPart part) {
  WalkLoop loop;
  static bool checked = false, passed = false;  // once per process, before the first timing
  if (!checked) {
    checked = true;
    const std::string seen = loop.check(passed);
    if (passed) note("paper_walk: one walk checked before timing: " + seen);
    else fail("paper_walk: the walk did not end at the object: " + seen);
  }
  if (!passed) {
    state.SkipWithError("the walk failed its check (see the notes)");
    return;
  }
  bool first = true;
  // Before each timed call (untimed): the bookkeeping of the cycle before, and, where only
  // the modules are timed, the controller's cycle they need the state of.
  auto prepare = [&] {
    if (!first) {
      if (part == WalkPart::kModules) loop.control();
      loop.next();
    }
    first = false;
  };
  if (part == WalkPart::kCycle)
    timed_loop(state, prepare, [&] {
      loop.modules();
      loop.control();
    });
  else
    timed_loop(state, prepare, [&] { loop.modules(); });
  if (loop.failed()) state.SkipWithError("the walking loop failed (an invalid command, or q not finite)");
  state.counters["walks"] = static_cast<double>(loop.walks());
  state.counters["footsteps_per_walk"] =
      loop.walks() > 0 ? static_cast<double>(loop.footsteps_in_walks()) / static_cast<double>(loop.walks()) : 0.0;
  state.counters["walking_pct"] = 100.0 * loop.walking_share();
}

}  // namespace wbm_bench
