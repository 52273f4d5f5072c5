#include "scaling.hpp"

#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <stdexcept>

#include "bench_common.hpp"
#include "recorded_solves.hpp"
#include "wbm/controller.hpp"
#include "wbm/tasks/position_task.hpp"

namespace wbm_bench {
namespace {

using Eigen::VectorXd;
using wbm::Vector3;

constexpr double kDt = 1e-3;
constexpr double kOmega = 2.0 * M_PI * 0.25;
constexpr double kAmplitude = 0.03;  // [m]

/// A torso on the paper's virtual base with `branches` serial chains of random revolute
/// joints (random unit axes, 10 cm links, 0.5 kg each); frame "tip_k" at the end of
/// branch k. Home: random joint values in [-1, 1] rad (bent, away from singularities).
wbm::Model make_tree(int joints, int branches, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  auto random_unit = [&] {
    Vector3 a;
    do a = Vector3{unit(rng), unit(rng), unit(rng)};  // braces: drawn in this order with every compiler
    while (a.norm() < 0.1 || a.norm() > 1.0);
    return Vector3(a.normalized());
  };
  wbm::ModelBuilder b("tree_" + std::to_string(joints) + "j_" + std::to_string(branches) + "b");
  wbm::Inertial heel, torso;
  torso.mass = 10.0;
  torso.com = Vector3(0.0, 0.0, 0.15);
  torso.inertia = 0.1 * wbm::Matrix3::Identity();
  const int torso_body = wbm::add_virtual_base(b, 1.0, "torso", heel, torso);
  std::vector<double> home;
  for (const wbm::Dof& d : wbm::default_virtual_dofs(1.0)) home.push_back(d.continuous ? 0.0 : d.center());
  for (int k = 0; k < branches; ++k) {
    const int length = joints / branches + (k < joints % branches ? 1 : 0);
    const double angle = 2.0 * M_PI * k / branches;
    const Vector3 direction = Vector3(std::cos(angle), std::sin(angle), k % 2 == 0 ? 0.5 : -0.5).normalized();
    int parent = torso_body;
    for (int j = 0; j < length; ++j) {
      wbm::Dof dof;
      char name[32];
      std::snprintf(name, sizeof name, "b%d_j%d", k, j);  // (operator+ on literals trips GCC 12's -Wrestrict)
      dof.name = name;
      dof.lower = -2.0;
      dof.upper = 2.0;
      dof.max_speed = 3.0;
      wbm::Body body;
      body.name = dof.name + "_link";
      body.parent = parent;
      body.X_PJ.p = (j == 0 ? 0.15 : 0.10) * (direction + 0.3 * random_unit()).normalized();
      body.axis = random_unit();
      body.dof = b.add_dof(dof);
      body.inertial.mass = 0.5;
      body.inertial.com = 0.05 * direction;
      body.inertial.inertia = 1e-3 * wbm::Matrix3::Identity();
      parent = b.add_body(body);
      home.push_back(unit(rng));
    }
    wbm::Frame tip;
    tip.name = "tip_" + std::to_string(k);
    tip.body = parent;
    tip.X_BF.p = 0.08 * direction;
    b.add_frame(tip);
  }
  b.set_home(Eigen::Map<const VectorXd>(home.data(), static_cast<Eigen::Index>(home.size())));
  return b.build();
}

class ScalingFixture {
 public:
  /// Draws the case's tree and checks that the controller follows the moving tips (within
  /// 1 cm) over one period of their motion without the damped path in most cycles. A tree
  /// that does not (the smallest ones can: branches of two joints whose tips lean on the
  /// torso's small virtual ranges) is redrawn with the next seed, up to kMaxDraws times, so
  /// that the dofs sweep times the normal cycle; many rows (35, 40) damp in a third to a half.
  explicit ScalingFixture(const ScalingCase& sc) : model(make_tree(sc.joints, sc.branches, 1234u + sc.joints)) {
    constexpr int kMaxDraws = 8;
    std::string rejected;
    for (int draw = 0;; ++draw) {
      const unsigned seed = 1234u + sc.joints + 1000u * draw;
      if (draw > 0) model = make_tree(sc.joints, sc.branches, seed);
      char line[320];
      const bool tracks = run_sanity_check(sc, line, sizeof line);
      if (tracks || draw + 1 == kMaxDraws) {
        note(std::string(line) + (rejected.empty() ? "" : " (tree seed " + std::to_string(seed) + "; redrawn:" + rejected + ")"));
        if (!tracks) throw std::runtime_error(sc.name + ": controller does not track the tips or damps in most cycles");
        break;
      }
      rejected += " seed " + std::to_string(seed);
    }
  }

  /// Builds the controller on `model`, moves the tips for 0.5 s and one period (4 s) and
  /// records the states of the stage benchmarks; writes the summary into `line`. True if the
  /// tips are followed within 1 cm and fewer than half the cycles are damped.
  bool run_sanity_check(const ScalingCase& sc, char* line, std::size_t size) {
    t = 0.0;
    states.clear();
    controller = std::make_unique<wbm::Controller>(model);
    controller->set_criterion(std::make_unique<wbm::CubicJointLimitCriterion>(model, 0.0));  // as in fixtures.cpp
    const int elements = (sc.rows + 2) / 3;
    if (elements > sc.branches) throw std::runtime_error(sc.name + ": more position elements than branch tips");
    for (int k = 0; k < elements; ++k)
      controller->add_task(std::make_unique<wbm::PositionTask>(model, "tip_" + std::to_string(k), "tip_" + std::to_string(k)));
    controller->reset(model.home());
    command = controller->make_command();
    for (int r = sc.rows; r < command.task_active.size(); ++r) command.task_active[r] = false;
    const wbm::VirtualDofs& v = model.virtual_dofs();
    for (int heel : {v.heel_x, v.heel_y, v.heel_yaw}) command.free_dofs[heel] = false;
    base = controller->values();

    int damped = 0, frozen = 0;
    double tracking = 0.0;
    const int cycles = 500 + static_cast<int>(std::lround(2.0 * M_PI / kOmega / kDt));
    solves.clear();
    for (int k = 0; k < cycles; ++k) {
      next_targets();
      // 32 consecutive cycles for the stage benchmarks (their J stay in cache): the
      // configuration each starts from and the solver's inputs as the controller built them.
      const bool record = k >= 1000 && k < 1032;
      if (record) states.push_back(controller->q());
      const wbm::ControllerStatus status = controller->update(command, kDt);
      if (!status.ok()) throw std::runtime_error(sc.name + ": controller cycle failed");
      if (record) solves.record(*controller, status);
      damped += status.has(wbm::kDamped);
      frozen += status.has(wbm::kDofAtLimitFrozen);
      if (k >= 500)
        for (int r = 0; r < sc.rows; ++r)  // position elements: row r <-> target entry r
          tracking = std::max(tracking, std::abs(controller->values()[r] - controller->filtered_targets()[r]));
    }
    record_stages(elements);
    std::snprintf(line, size,
                  "%s: %d dofs (%d joints, %d branches), %d rows: max tracking error %.2g m, damped %.0f %%, "
                  "limit-frozen %.0f %%",
                  sc.name.c_str(), model.num_dofs(), sc.joints, sc.branches, sc.rows, tracking, 100.0 * damped / cycles,
                  100.0 * frozen / cycles);
    return tracking < 1e-2 && 2 * damped < cycles;
  }

  /// Inputs of the assemble and solve stages at the recorded states (as in fixtures.cpp:
  /// J and the task velocities were recorded from the controller; the stack here serves the
  /// assemble stage). Throws if the solve stage does not give the controller's J# x_dot.
  void record_stages(int elements) {
    gradient.clear();
    data = std::make_unique<wbm::Data>(model);
    stack = std::make_unique<wbm::TaskStack>(model);
    for (int k = 0; k < elements; ++k)
      stack->add(std::make_unique<wbm::PositionTask>(model, "tip_" + std::to_string(k), "tip_" + std::to_string(k)));
    stack->activation() = command.task_active;
    stack->targets() = controller->filtered_targets();
    const wbm::CubicJointLimitCriterion criterion(model, 0.0);
    for (const VectorXd& q : states) {
      VectorXd g(model.num_dofs());
      criterion.gradient(q, g);
      gradient.push_back(g);
    }
    solver = std::make_unique<wbm::WholeBodySolver>(model, stack->num_rows());
    for (std::size_t k = 0; k < states.size(); ++k) {
      solver->solve(solves.J[k], solves.xdot[k], gradient[k], command.free_dofs, kDt);
      solves.check(k, *solver, "scaling");
    }
  }

  void next_targets() {
    t += kDt;
    for (int e = 0; e < controller->tasks().num_elements(); ++e) {
      const double phase = kOmega * t + 0.7 * e;
      command.targets.segment<3>(3 * e) =
          base.segment<3>(3 * e) + kAmplitude * Vector3(std::sin(phase), 1.0 - std::cos(phase), 0.5 * std::sin(2.0 * phase));
    }
  }

  wbm::Model model;
  std::unique_ptr<wbm::Controller> controller;
  wbm::Command command;
  VectorXd base;
  double t = 0.0;
  // Stage benchmarks.
  std::vector<VectorXd> states;
  std::unique_ptr<wbm::Data> data;
  std::unique_ptr<wbm::TaskStack> stack;
  RecordedSolves solves;  ///< the solver's inputs of the recorded cycles
  std::vector<VectorXd> gradient;
  std::unique_ptr<wbm::WholeBodySolver> solver;
};

}  // namespace

std::vector<ScalingCase> scaling_cases() {
  std::vector<ScalingCase> cases;
  for (int joints = 10; joints <= 100; joints += 10)
    cases.push_back({"scaling/dofs/" + std::to_string(joints + 9), joints, 4, 12});
  // Rows at two tree sizes, so that a fit can tell n m^2 (forming J W^-1 J^T) from m^3.
  for (int joints : {60, 100})
    for (int rows : {3, 6, 9, 12, 15, 20, 25, 30, 35, 40})
      cases.push_back({"scaling/rows_n" + std::to_string(joints + 9) + "/" + std::to_string(rows), joints, 14, rows});
  return cases;
}

void bm_scaling(benchmark::State& state, const ScalingCase* c, ScalingStage stage) {
  static std::map<std::string, std::unique_ptr<ScalingFixture>> built;
  ScalingFixture* f = nullptr;
  auto it = built.find(c->name);
  if (it != built.end()) {
    f = it->second.get();
  } else {
    try {
      f = built.emplace(c->name, std::make_unique<ScalingFixture>(*c)).first->second.get();
    } catch (const std::exception& e) {
      fail(e.what());
      built.emplace(c->name, nullptr);
    }
  }
  if (f == nullptr) {
    state.SkipWithError("scaling fixture failed its sanity check (see the notes)");
    return;
  }
  const std::size_t n = f->states.size();
  std::size_t k = 0;
  switch (stage) {
    case ScalingStage::kCycle: {
      std::uint32_t last = 0;
      std::int64_t damped = 0, frozen = 0, cycles = 0;
      timed_loop(
          state,
          [&] {
            damped += (last & wbm::kDamped) != 0;
            frozen += (last & wbm::kDofAtLimitFrozen) != 0;
            f->next_targets();
          },
          [&] {
            last = f->controller->update(f->command, kDt).flags;
            ++cycles;
          });
      if (cycles > 0) {
        state.counters["damped_pct"] = 100.0 * static_cast<double>(damped) / static_cast<double>(cycles);
        state.counters["refrozen_pct"] = 100.0 * static_cast<double>(frozen) / static_cast<double>(cycles);
      }
      break;
    }
    case ScalingStage::kAssemble:
      timed_loop(
          state,
          [&] {
            k = (k + 1) % n;
            wbm::forward_kinematics(f->model, *f->data, f->states[k]);
          },
          [&] { benchmark::DoNotOptimize(f->stack->assemble(f->model, *f->data)); });
      break;
    case ScalingStage::kSolve:
      timed_loop(
          state, [&] { k = (k + 1) % n; },
          [&] {
            benchmark::DoNotOptimize(f->solver->solve(f->solves.J[k], f->solves.xdot[k], f->gradient[k], f->command.free_dofs, kDt));
          });
      break;
  }
  state.counters["dofs"] = f->model.num_dofs();
  state.counters["rows"] = c->rows;
  state.counters["joints"] = c->joints;
}

const char* stage_name(ScalingStage stage) {
  switch (stage) {
    case ScalingStage::kCycle: return "";
    case ScalingStage::kAssemble: return "assemble";
    case ScalingStage::kSolve: return "solve";
  }
  return "?";
}

}  // namespace wbm_bench
