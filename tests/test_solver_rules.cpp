// Rules of the solver and the controller that a broken version of each passed unnoticed
// (tests/mutation_check.py): parameter ranges, the sigma_min estimate after a row count
// change, the no-row and all-frozen paths, the status flags, the raised damping's triggers,
// the integration's clamp, and cycles that compute nothing. Each test names what it pins.
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <Eigen/QR>
#include <gtest/gtest.h>

#include "test_util.hpp"
#include "wbm/controller.hpp"
#include "wbm/errors.hpp"
#include "wbm/kinematics.hpp"
#include "wbm/nullspace_criterion.hpp"
#include "wbm/paper_model.hpp"
#include "wbm/solver.hpp"
#include "wbm/task_element.hpp"
#include "wbm/tasks/com_task.hpp"
#include "wbm/tasks/position_task.hpp"
#include "wbm/task_stack.hpp"

namespace {

using namespace wbm;
using Eigen::MatrixXd;
using Eigen::VectorXd;

using wbm_test::raw_parameters;
using wbm_test::throws_with;

/// A random orthogonal matrix of R^m (seeded), for eigenvectors that no start vector favours.
MatrixXd random_rotation(int m, std::mt19937_64& rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  MatrixXd G(m, m);
  for (int i = 0; i < G.size(); ++i) G.data()[i] = normal(rng);
  return Eigen::HouseholderQR<MatrixXd>(G).householderQ();
}

/// J (m x n) whose weighted Gram matrix J W^-1 J^T is B B^T, W^-1 = diag(work_range^2):
/// J = B Q^T diag(1 / work_range) with Q (n x m) orthonormal columns on every dof.
MatrixXd jacobian_with_gram(const Model& model, const MatrixXd& B, std::mt19937_64& rng) {
  const int n = model.num_dofs(), m = static_cast<int>(B.rows());
  MatrixXd J = B * random_rotation(n, rng).leftCols(m).transpose();
  for (int i = 0; i < n; ++i) J.col(i) /= model.dof(i).work_range;
  return J;
}

/// One row (1 x n) on the left elbow with `coefficient` and, if given, on the dof before it
/// (the shoulder's yaw) with `shoulder`.
MatrixXd elbow_row(const Model& model, double coefficient, double shoulder = 0.0) {
  MatrixXd J = MatrixXd::Zero(1, model.num_dofs());
  const int elbow = model.dof_index("l_elbow");
  J(0, elbow) = coefficient;
  J(0, elbow - 1) = shoulder;
  return J;
}

TEST(Solver, ParametersOutsideTheirRangesThrow) {
  const Model model = make_paper_model();
  const double nan = std::nan(""), inf = std::numeric_limits<double>::infinity();
  struct Bad {
    std::string field;
    double value;
  };
  const std::vector<Bad> bad = {{"nullspace_gain", -1e-9},        {"nullspace_gain", nan},
                                {"nullspace_gain", inf},          {"singular_threshold", 0.0},
                                {"singular_threshold", nan},      {"singular_threshold", inf},
                                {"max_damping", 0.0},             {"max_damping", nan},
                                {"nullspace_rate_change_limit", -1e-9}, {"nullspace_rate_change_limit", nan},
                                {"nullspace_rate_change_limit", inf}};
  for (const Bad& b : bad) {
    SolverParameters p;
    if (b.field == "nullspace_gain") p.nullspace_gain = b.value;
    if (b.field == "singular_threshold") p.singular_threshold = b.value;
    if (b.field == "max_damping") p.max_damping = b.value;
    if (b.field == "nullspace_rate_change_limit") p.nullspace_rate_change_limit = b.value;
    const std::string what = b.field + " = " + std::to_string(b.value);
    EXPECT_TRUE(throws_with<ConfigError>([&] { WholeBodySolver(model, 3, p); }, "solver: " + b.field)) << what;
    WholeBodySolver solver(model, 3);
    EXPECT_THROW(solver.set_parameters(p), ConfigError) << what;
    Controller controller(model);
    EXPECT_THROW(controller.set_solver_parameters(p), ConfigError) << what << " (before reset())";
  }
  // The edges of the ranges: no null-space motion, no rate change limit.
  SolverParameters edge;
  edge.nullspace_gain = 0.0;
  edge.nullspace_rate_change_limit = 0.0;
  EXPECT_NO_THROW(WholeBodySolver(model, 3, edge));
  EXPECT_THROW(WholeBodySolver(model, -1), ConfigError);
  EXPECT_NO_THROW(WholeBodySolver(model, 0));
}

// sigma_min is estimated by inverse iteration warm-started from the last cycle: one step per
// cycle, three from a fresh start after the row count changed. A has eigenvalues 1, 10, 100
// (then 1, 10, 100, 1000) in random directions, the command along the largest (so that the
// task solve's bound, |b| / |A^-1 b| = sqrt(largest), does not help). Every estimate bounds
// sigma_min = 1 from above; three steps put nearly all within 1 % (a start vector almost
// orthogonal to the weak direction needs more), one step left most beyond.
TEST(Solver, TheFirstEstimateAfterARowCountChangeTakesThreeSteps) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  std::mt19937_64 rng(5);
  int estimates = 0, close = 0;
  for (int trial = 0; trial < 40; ++trial) {
    WholeBodySolver solver(model, 4, raw_parameters());
    for (const int m : {3, 4, 3}) {
      const MatrixXd R = random_rotation(m, rng);
      VectorXd roots(m);
      for (int i = 0; i < m; ++i) roots[i] = std::pow(10.0, 0.5 * i);
      const MatrixXd J = jacobian_with_gram(model, R * roots.asDiagonal(), rng);
      solver.solve(J, R.col(m - 1), VectorXd::Zero(n), Mask::Constant(n, true), 0.001);
      const double sigma = solver.output().min_singular_value;
      EXPECT_GE(sigma, 1.0 - 1e-9) << "trial " << trial << ", m " << m << ": an upper bound";
      ++estimates;
      close += sigma < 1.01;
    }
  }
  EXPECT_GE(close, estimates * 9 / 10) << close << " of " << estimates << " first estimates within 1 %";
}

// Two independent blocks of rows (the hands, with only the arms free), scaled to the edges
// of the double range: where the estimate of a block's sigma_min overflows (no number), that
// block is damped as singular; the rates stay finite and the solve valid.
TEST(Solver, BlocksOfRowsNearTheEdgeOfTheDoubleRangeGiveFiniteRates) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  Data data(model);
  TaskStack stack(model);
  stack.add(std::make_unique<PositionTask>(model, "l_hand", "l_hand_ref"));
  stack.add(std::make_unique<PositionTask>(model, "r_hand", "r_hand_ref"));
  forward_kinematics(model, data, model.home());
  stack.assemble(model, data);
  Mask arms = Mask::Constant(n, false);
  for (int i = model.dof_index("l_shoulder_pitch"); i <= model.dof_index("r_hand_rot"); ++i) arms[i] = true;
  for (const double scale : {1e-150, 1e-100, 1e75, 1e160}) {
    WholeBodySolver solver(model, stack.num_rows());
    const MatrixXd J = scale * stack.jacobian();
    const VectorXd xdot = VectorXd::Constant(stack.num_rows(), 0.01);
    for (int k = 0; k < 3; ++k) {
      const SolverStatus st = solver.solve(J, xdot, VectorXd::Zero(n), arms, 0.001);
      ASSERT_FALSE(st.has(kInvalidInput)) << "scale " << scale << ", cycle " << k;
      ASSERT_TRUE(solver.output().qdot.allFinite()) << "scale " << scale << ", cycle " << k;
      if (scale < 1e100) {  // (beyond, A overflows and its inverse is zero: q_dot 1e-162 rounds to 0)
        ASSERT_GT(solver.output().qdot.norm(), 0.0) << "scale " << scale << ", cycle " << k;
      }
      ASSERT_FALSE(std::isnan(solver.output().min_singular_value)) << "scale " << scale << ", cycle " << k;
      if (scale < 1.0) {
        EXPECT_TRUE(st.has(kDamped)) << "scale " << scale;
      }
    }
  }
}

// One row more than the free dofs is overdetermined; as many rows as free dofs is not.
TEST(Solver, OverdeterminedMeansMoreRowsThanFreeDofs) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  std::mt19937_64 rng(8);
  std::normal_distribution<double> normal(0.0, 1.0);
  Mask free = Mask::Constant(n, false);
  for (int i = 9; i < 12; ++i) free[i] = true;  // three dofs of the left arm
  WholeBodySolver solver(model, 4);
  for (const int m : {2, 3, 4}) {
    MatrixXd J(m, n);
    for (int i = 0; i < J.size(); ++i) J.data()[i] = normal(rng);
    const SolverStatus st = solver.solve(J, VectorXd::Constant(m, 0.01), VectorXd::Zero(n), free, 0.001);
    EXPECT_EQ(st.has(kOverdetermined), m > 3) << m << " rows on 3 free dofs";
  }
}

// Without active rows the solver moves the free dofs down the gradient, q_dot = -k W^-1 dH/dq
// (eq. 7's null-space term with N = I), frozen dofs not at all; sigma_min is infinite (no
// row to be singular). With a gradient too large for the speed limits the null-space part
// is scaled to them, flagged, one dof exactly at its limit.
TEST(Solver, WithoutRowsTheNullSpaceMotionIsTheWeightedGradient) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  WholeBodySolver solver(model, 2, raw_parameters());
  Mask free = Mask::Constant(n, true);
  free[10] = free[15] = false;
  VectorXd gradient(n);
  for (int i = 0; i < n; ++i) gradient[i] = uniform(rng);
  const MatrixXd none = MatrixXd::Zero(0, n);
  SolverStatus st = solver.solve(none, VectorXd::Zero(0), gradient, free, 0.001);
  EXPECT_TRUE(st.has(kNoActiveRows));
  EXPECT_EQ(solver.output().min_singular_value, std::numeric_limits<double>::infinity());
  const double k = solver.parameters().nullspace_gain;
  for (int i = 0; i < n; ++i) {
    const double r = model.dof(i).work_range;
    const double expected = free[i] ? -k * r * r * gradient[i] : 0.0;
    EXPECT_NEAR(solver.output().qdot[i], expected, 1e-12 * (1.0 + std::abs(expected))) << model.dof(i).name;
    EXPECT_EQ(solver.output().qdot_task[i], 0.0);
  }
  // Speed-limited (no jerk limit): scaled, flagged, the most limited dof at its limit.
  SolverParameters scaled = raw_parameters();
  scaled.limit_speeds = true;
  solver.set_parameters(scaled);
  st = solver.solve(none, VectorXd::Zero(0), 1e3 * gradient, free, 0.001);
  EXPECT_TRUE(st.has(kNullSpaceSpeedScaled));
  EXPECT_FALSE(st.has(kNullSpaceJerkLimited));
  EXPECT_LT(solver.output().nullspace_scale, 1.0);
  double largest = 0.0;
  for (int i = 0; i < n; ++i) largest = std::max(largest, std::abs(solver.output().qdot[i]) / model.dof(i).max_speed);
  EXPECT_NEAR(largest, 1.0, 1e-12);
}

TEST(Solver, AConfigurationOfTheWrongSizeIsInvalid) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  WholeBodySolver solver(model, 1);
  const MatrixXd J = elbow_row(model, 1.0);
  const VectorXd short_q = VectorXd::Zero(n - 1);
  const SolverStatus st = solver.solve(J, VectorXd::Ones(1), VectorXd::Zero(n), Mask::Constant(n, true), 0.001, &short_q);
  EXPECT_TRUE(st.has(kInvalidInput));
  EXPECT_EQ(solver.output().qdot.norm(), 0.0);
}

// The one free dof stands at its upper limit and the row drives it further: frozen, no dof
// is left, and every part of the output is zero (not the first solve's before the freeze).
TEST(Solver, FreezingTheLastFreeDofAtItsLimitZeroesEveryPart) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  const int elbow = model.dof_index("l_elbow");
  WholeBodySolver solver(model, 1);
  Mask free = Mask::Constant(n, false);
  free[elbow] = true;
  const MatrixXd J = elbow_row(model, 1.0);
  VectorXd q = model.home();
  q[elbow] = model.dof(elbow).upper;
  VectorXd gradient = VectorXd::Zero(n);
  gradient[elbow] = -1.0;  // the null space would drive it out too
  const SolverStatus st = solver.solve(J, VectorXd::Constant(1, 0.5), gradient, free, 0.001, &q);
  EXPECT_TRUE(st.has(kAllDofsFrozen));
  EXPECT_TRUE(st.has(kDofAtLimitFrozen));
  EXPECT_EQ(solver.output().qdot.norm(), 0.0);
  EXPECT_EQ(solver.output().qdot_task.norm(), 0.0);
  EXPECT_EQ(solver.output().qdot_null.norm(), 0.0);
}

// The elbow stands at its upper limit and the row drives it out: frozen at its limit, every
// cycle. A dof the user freezes or frees meanwhile (b_C) is a switched constraint, not a
// change of the set frozen at limits: the jerk limit still smooths that switch.
TEST(Solver, ADofTheUserFreezesIsNotFrozenAtItsLimit) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  const int elbow = model.dof_index("l_elbow");
  WholeBodySolver solver(model, 1);
  const MatrixXd J = elbow_row(model, 1.0, 0.5);
  VectorXd q = model.home();
  q[elbow] = model.dof(elbow).upper;
  Mask free = Mask::Constant(n, true);
  const VectorXd gradient = VectorXd::Zero(n);
  const VectorXd xdot = VectorXd::Constant(1, 0.2);
  SolverStatus st = solver.solve(J, xdot, gradient, free, 0.001, &q);
  ASSERT_TRUE(st.has(kDofAtLimitFrozen));
  EXPECT_TRUE(solver.output().frozen_set_changed);
  st = solver.solve(J, xdot, gradient, free, 0.001, &q);
  EXPECT_FALSE(solver.output().frozen_set_changed);
  for (const bool head_free : {false, true, false}) {
    free[model.dof_index("head_pan")] = head_free;
    st = solver.solve(J, xdot, gradient, free, 0.001, &q);
    ASSERT_TRUE(st.has(kDofAtLimitFrozen));
    EXPECT_FALSE(solver.output().frozen_set_changed) << "head_pan free " << head_free;
  }
}

// A dof braked before its limit keeps q_dot = q_dot_task + q_dot_null: both parts are
// scaled with it.
TEST(Solver, ABrakedDofsPartsAddUpToItsRate) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  const int elbow = model.dof_index("l_elbow");
  WholeBodySolver solver(model, 1);
  const MatrixXd J = elbow_row(model, 1.0, 0.3);
  VectorXd q = model.home();
  q[elbow] = model.dof(elbow).upper - 1e-4;
  VectorXd gradient = VectorXd::Zero(n);
  gradient[elbow] = -0.5;
  gradient[elbow - 1] = 0.5;
  const Mask free = Mask::Constant(n, true);
  const SolverStatus st = solver.solve(J, VectorXd::Constant(1, 2.0), gradient, free, 0.001, &q);
  ASSERT_TRUE(st.has(kDofBraked));
  const auto& out = solver.output();
  EXPECT_LE(q[elbow] + out.qdot[elbow] * 0.001, model.dof(elbow).upper + 1e-15);
  for (int i = 0; i < n; ++i)
    EXPECT_NEAR(out.qdot[i], out.qdot_task[i] + out.qdot_null[i], 1e-12 * (1.0 + std::abs(out.qdot[i])))
        << model.dof(i).name;
}

// One damped row on the elbow (sigma_min = eps / 4), no speed scaling or jerk limit, so that
// q_dot is the command times a constant. The damping is raised (for the solve after) where
// the change of q_dot turned back and grew in kAlternations solves in a row under the same
// command, also while q_dot itself never turns back (a period-2 oscillation on a drift);
// an alternation that dies down raises nothing.
TEST(Solver, AGrowingAlternationRaisesTheDampingAndADyingOneDoesNot) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  const int elbow = model.dof_index("l_elbow");
  WholeBodySolver solver(model, 1, raw_parameters());
  const MatrixXd J = elbow_row(model, 0.25 * solver.parameters().singular_threshold / model.dof(elbow).work_range);
  const Mask free = Mask::Constant(n, true);
  const VectorXd gradient = VectorXd::Zero(n);
  // q_dot changes +0.1, -0.15, +0.25, -0.3, +0.4 (times a constant): the fourth turn in a
  // row after the sixth solve, raised from the seventh.
  const double growing[] = {1.0, 1.1, 0.95, 1.2, 0.9, 1.3, 1.3};
  for (int k = 0; k < 7; ++k) {
    const SolverStatus st = solver.solve(J, VectorXd::Constant(1, growing[k]), gradient, free, 0.001);
    ASSERT_TRUE(st.has(kDamped));
    EXPECT_EQ(st.has(kDampingRaised), k == 6) << "solve " << k + 1;
  }
  solver.reset();
  // +0.4, -0.7, +0.6, -0.5, +0.4, -0.3, +0.2, -0.1: it grew once, then shrinks.
  const double dying[] = {1.0, 1.4, 0.7, 1.3, 0.8, 1.2, 0.9, 1.1, 1.0, 1.0};
  for (int k = 0; k < 10; ++k) {
    const SolverStatus st = solver.solve(J, VectorXd::Constant(1, dying[k]), gradient, free, 0.001);
    EXPECT_FALSE(st.has(kDampingRaised)) << "solve " << k + 1;
  }
}

// q_dot turning back under the same command raises the damping when some dof's rate changed
// by more than 1 % of its speed limit, not below (rounding-sized flips are no overshoot).
TEST(Solver, ATurnBackRaisesTheDampingFromOnePercentOfTheSpeedLimit) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  const int elbow = model.dof_index("l_elbow");
  const double vmax = model.dof(elbow).max_speed;
  WholeBodySolver solver(model, 1, raw_parameters());
  const double s = 0.25 * solver.parameters().singular_threshold / model.dof(elbow).work_range;
  auto row = [&](double coefficient) { return elbow_row(model, coefficient); };
  const Mask free = Mask::Constant(n, true);
  const VectorXd gradient = VectorXd::Zero(n);
  solver.solve(row(s), VectorXd::Ones(1), gradient, free, 0.001);
  const double per_command = solver.output().qdot[elbow];  // q_dot per unit command
  ASSERT_GT(per_command, 0.0);
  // |q_dot| = 2.5 % of v_max: the turn changes it by 5 %; at 0.25 %, by 0.5 %.
  for (const double share : {0.025, 0.0025}) {
    solver.reset();
    const VectorXd xdot = VectorXd::Constant(1, share * vmax / per_command);
    solver.solve(row(s), xdot, gradient, free, 0.001);
    solver.solve(row(-s), xdot, gradient, free, 0.001);
    const SolverStatus st = solver.solve(row(s), xdot, gradient, free, 0.001);
    EXPECT_EQ(st.has(kDampingRaised), share > 0.005) << "|q_dot| " << share << " of v_max";
  }
}

// integrate() clamps at the limits and says so, except where a step lands on a limit and
// rounding puts it there an ulp or two past (a braked dof): put back without the flag.
TEST(Solver, IntegrationClampsAndFlagsOnlyRealOvershoots) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  const int elbow = model.dof_index("l_elbow");
  const double upper = model.dof(elbow).upper, lower = model.dof(elbow).lower;
  VectorXd q = model.home(), qdot = VectorXd::Zero(n), next(n);
  const double dt = 0.001;
  // An ulp past.
  q[elbow] = upper;
  qdot[elbow] = (std::nextafter(upper, 10.0) - upper) / dt;  // a step of about one ulp
  std::uint32_t flags = integrate(model, q, qdot, dt, next);
  EXPECT_EQ(next[elbow], upper);
  EXPECT_FALSE(flags & kJointLimitClamped);
  // Landing from afar with rounding: at most a few ulps past, never flagged.
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> distance(1e-6, 0.3);
  for (int c = 0; c < 10000; ++c) {
    const double d = distance(rng);
    q[elbow] = lower + d;
    qdot[elbow] = -d / dt;
    flags = integrate(model, q, qdot, dt, next);
    ASSERT_GE(next[elbow], lower);
    ASSERT_FALSE(flags & kJointLimitClamped) << "distance " << d;
  }
  // 1e-11 past (ten thousand times the rounding tolerance 4 eps (1 + |limit|) at this limit
  // of 0) is a clamp.
  q[elbow] = upper - 1e-3;
  qdot[elbow] = (1e-3 + 1e-11) / dt;
  flags = integrate(model, q, qdot, dt, next);
  EXPECT_EQ(next[elbow], upper);
  EXPECT_TRUE(flags & kJointLimitClamped);
}

// The centre of mass is updated every cycle when any element needs it, also when an element
// that does not need it was added after one that does.
TEST(Controller, TheCentreOfMassIsUpdatedWhenAnyElementNeedsIt) {
  const Model model = make_paper_model();
  Controller c(model);
  c.add_task(std::make_unique<CenterOfMassTask>(model, "com"));
  c.add_task(std::make_unique<PositionTask>(model, "l_hand", "l_hand_ref"));
  c.reset(model.home());
  Command cmd = c.make_command();
  cmd.targets[3] += 0.2;  // the left hand forward; the com's own target held
  Data fresh(model);
  for (int k = 0; k < 300; ++k) {
    ASSERT_TRUE(c.update(cmd, 0.002).ok());
    forward_kinematics(model, fresh, c.q());
    center_of_mass(model, fresh);
    ASSERT_LT((c.values().head<3>() - center_of_mass_position(model, fresh)).norm(), 1e-12) << "cycle " << k;
  }
  EXPECT_GT((c.q() - model.home()).norm(), 0.05);
}

// The null-space criterion's gradient reaches the solver: with no active row the null-space
// part is -k W^-1 dH/dq of the state the cycle started from.
TEST(Controller, TheCriterionsGradientDrivesTheNullSpace) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  Controller c(model, raw_parameters());
  c.add_task(std::make_unique<PositionTask>(model, "l_hand", "l_hand_ref"));
  VectorXd weights = VectorXd::Zero(n);
  for (int i = 9; i < n; ++i) weights[i] = 1.0;
  c.set_criterion(std::make_unique<JointCenterCriterion>(model, weights));
  const JointCenterCriterion criterion(model, weights);
  std::mt19937_64 rng(12);
  VectorXd q = model.home();
  for (int i = 9; i < n; ++i)
    q[i] = model.dof(i).lower + std::uniform_real_distribution<double>(0.1, 0.9)(rng) * model.dof(i).work_range;
  c.reset(q);
  Command idle = c.make_command();
  idle.task_active.setConstant(false);
  VectorXd gradient(n);
  criterion.gradient(q, gradient);
  ASSERT_GT(gradient.norm(), 0.1);
  ASSERT_TRUE(c.update(idle, 0.001).ok());
  const double k = c.solver().parameters().nullspace_gain;
  for (int i = 0; i < n; ++i) {
    const double r = model.dof(i).work_range;
    const double expected = -k * r * r * gradient[i];
    EXPECT_NEAR(c.solver().output().qdot_null[i], expected, 1e-12 * (1.0 + std::abs(expected))) << model.dof(i).name;
  }
}

/// A user's element that goes wrong on request: a row on the head's pan whose rate is NaN.
struct FaultyElement : TaskElement {
  FaultyElement(const Model& model, const bool& fault)
      : TaskElement("faulty", 1, 1, TargetKind::kVector), dof_(model.dof_index("head_pan")), fault_(fault) {}
  void value(const Model&, const Data& data, Eigen::Ref<VectorXd> x) override { x[0] = data.q[dof_]; }
  void evaluate(const Model&, const Data&, const Eigen::Ref<const VectorXd>&, const Eigen::Ref<const VectorXd>&,
                Eigen::Ref<MatrixXd> J, Eigen::Ref<VectorXd> error, Eigen::Ref<VectorXd> rate) override {
    J.setZero();
    J(0, dof_) = 1.0;
    error[0] = 0.0;
    rate[0] = fault_ ? std::nan("") : 0.0;
  }
  int dof_;
  const bool& fault_;
};

// A cycle that computes nothing (a bad command, every dof frozen, an element whose rate is
// NaN: the solver's input invalid) leaves the robot where it is and at rest: q unchanged
// and q_dot zero, not the last cycle's rate.
TEST(Controller, ACycleThatComputesNothingLeavesTheRobotAtRest) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  Controller c(model);
  c.add_task(std::make_unique<PositionTask>(model, "l_hand", "l_hand_ref"));
  bool fault = false;
  c.add_task(std::make_unique<FaultyElement>(model, fault));
  c.reset(model.home());
  Command moving = c.make_command();
  moving.targets[0] += 0.2;  // the left hand forward
  std::vector<std::pair<std::string, Command>> bad;
  Command short_external = moving;
  short_external.external_velocity = VectorXd::Zero(n - 1);
  bad.emplace_back("external velocity of n - 1 entries", short_external);
  Command nan_external = moving;
  nan_external.external_velocity = VectorXd::Zero(n);
  nan_external.external_velocity[12] = std::nan("");
  bad.emplace_back("NaN external velocity", nan_external);
  Command inf_external = nan_external;
  inf_external.external_velocity[12] = std::numeric_limits<double>::infinity();
  bad.emplace_back("infinite external velocity", inf_external);
  Command wrong_free = moving;
  wrong_free.free_dofs = Mask::Constant(n + 1, true);
  bad.emplace_back("free dofs of n + 1 entries", wrong_free);
  Command frozen = moving;
  frozen.free_dofs.setConstant(false);
  bad.emplace_back("every dof frozen", frozen);
  bad.emplace_back("an element's NaN rate", moving);
  for (const auto& [what, command] : bad) {
    c.reset(model.home());
    fault = false;
    for (int k = 0; k < 50; ++k) ASSERT_TRUE(c.update(moving, 0.002).ok());
    ASSERT_GT(c.qdot().norm(), 0.01) << what;
    const VectorXd q = c.q();
    fault = what == "an element's NaN rate";
    const ControllerStatus st = c.update(command, 0.002);
    EXPECT_TRUE(what == "every dof frozen" ? st.has(kAllDofsFrozen)
                : fault                    ? st.has(kInvalidInput) && !st.ok()
                                           : st.has(kInvalidCommand))
        << what;
    EXPECT_EQ(c.q(), q) << what;
    EXPECT_EQ(c.qdot().norm(), 0.0) << what;
  }
}

}  // namespace
