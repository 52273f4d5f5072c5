// Whole-body solver (section IV): identities of the weighted pseudo-inverse and null-space
// projector, constraints, limits and the 2-dof axis task, as seeded property tests.
// WBM_PROPERTY_CASES=<n> runs n cases per property instead of 10^4.
#include <cmath>
#include <cstdlib>
#include <limits>
#include <memory>
#include <random>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "shipped_models.hpp"
#include "test_util.hpp"
#include "wbm/controller.hpp"
#include "wbm/errors.hpp"
#include "wbm/paper_model.hpp"
#include "wbm/solver.hpp"
#include "wbm/tasks/attitude_task.hpp"
#include "wbm/tasks/axis_task.hpp"
#include "wbm/tasks/com_task.hpp"
#include "wbm/tasks/joint_task.hpp"
#include "wbm/tasks/position_task.hpp"
#include "wbm/urdf_import.hpp"

#include "dot_kernels.hpp"  // internal (src/)

namespace {

using namespace wbm;
using Eigen::MatrixXd;
using Eigen::VectorXd;

using wbm_test::property_cases;

std::string describe(const VectorXd& q, const Mask& rows, const Mask& free) {
  std::ostringstream out;
  out.precision(17);
  out << "q = [" << q.transpose() << "]\nactive rows = [" << rows.cast<int>().transpose() << "]\nfree dofs = ["
      << free.cast<int>().transpose() << "]";
  return out.str();
}

/// The paper's task vector (eq. 4) on any model: both hands' position and grasp axis, and
/// the view axis if the model has a head frame.
void add_hand_tasks(const Model& model, TaskStack& stack, const std::string& left, const std::string& right,
                    const std::string& head) {
  stack.add(std::make_unique<PositionTask>(model, "l_hand", left));
  stack.add(std::make_unique<AxisTask>(model, "l_grasp", left));
  stack.add(std::make_unique<PositionTask>(model, "r_hand", right));
  stack.add(std::make_unique<AxisTask>(model, "r_grasp", right));
  if (!head.empty()) stack.add(std::make_unique<AxisTask>(model, "view", head));
}

void add_paper_tasks(const Model& model, TaskStack& stack) {
  add_hand_tasks(model, stack, "l_hand_ref", "r_hand_ref", "head_camera");
}

/// Random targets near the current values, so that errors are moderate.
void randomize_targets(const Model& model, const Data& data, TaskStack& stack, std::mt19937_64& rng) {
  VectorXd x(stack.num_targets());
  stack.values(model, data, x);
  std::normal_distribution<double> n(0.0, 0.1);
  for (int i = 0; i < x.size(); ++i) x[i] += n(rng);
  stack.targets() = x;
  stack.target_rates().setZero();
}

// Both versions of the solver's kernels (the one it picks for this CPU and the portable
// one), A = J W^-1 J^T and W^-1 J^T y, agree with Eigen's products on random sizes and
// entries, including odd row counts.
TEST(Solver, GramKernelsMatchEigen) {
  std::mt19937_64 rng(41);
  std::vector<std::pair<std::string, wbm::internal::GramKernel>> kernels = {
      {"portable", &wbm::internal::weighted_gram_portable}};
  std::vector<std::pair<std::string, wbm::internal::TransposeProductsKernel>> transpose_kernels = {
      {"portable", &wbm::internal::transpose_products_portable}};
  if (wbm::internal::select_weighted_gram() != &wbm::internal::weighted_gram_portable) {
    kernels.emplace_back("avx2", wbm::internal::weighted_gram_avx2());
    transpose_kernels.emplace_back("avx2", wbm::internal::transpose_products_avx2());
  } else
    std::cout << "this CPU has no AVX2/FMA: only the portable kernel is tested\n";
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  auto random_matrix = [&](Eigen::Index rows, Eigen::Index cols) {
    return Eigen::MatrixXd(Eigen::MatrixXd::NullaryExpr(rows, cols, [&] { return uniform(rng); }));
  };
  for (int c = 0; c < 2000; ++c) {
    const int m = 1 + static_cast<int>(rng() % 40), n = 4 * (1 + static_cast<int>(rng() % 25));
    const Eigen::Index ld = n + static_cast<Eigen::Index>(rng() % 3);
    Eigen::MatrixXd Jt = random_matrix(ld, m);
    const Eigen::MatrixXd w = random_matrix(n, 1).cwiseAbs();
    // Half the cases: columns ending early (zeros from a random extent on, as the solver
    // finds them), told to the kernel; the others: extent n.
    std::vector<int> extent(m, n);
    if (c % 2 == 1)
      for (int i = 0; i < m; ++i) {
        extent[i] = static_cast<int>(rng() % (n + 1));
        Jt.col(i).segment(extent[i], n - extent[i]).setZero();
      }
    Eigen::MatrixXd Jwt = Jt;
    Jwt.topRows(n) = w.asDiagonal() * Jt.topRows(n);
    const Eigen::MatrixXd expected = Jt.topRows(n).transpose() * Jwt.topRows(n);
    for (const auto& [name, kernel] : kernels) {
      Eigen::MatrixXd A = Eigen::MatrixXd::Constant(m + 1, m, std::nan(""));
      kernel(Jt.data(), Jwt.data(), ld, m, n, extent.data(), A.data(), A.outerStride());
      const Eigen::MatrixXd lower = A.topRows(m).triangularView<Eigen::Lower>();
      const Eigen::MatrixXd lower_expected = expected.triangularView<Eigen::Lower>();
      ASSERT_LE((lower - lower_expected).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + expected.cwiseAbs().maxCoeff()))
          << name << " m " << m << " n " << n << " case " << c;
      ASSERT_TRUE(A.row(m).array().isNaN().all()) << name << ": wrote outside A, case " << c;
    }
    // x1 = Jwt y1, x2 = Jwt y2 over the n rows.
    const Eigen::VectorXd y1 = random_matrix(m, 1), y2 = random_matrix(m, 1);
    const Eigen::VectorXd x1_expected = Jwt.topRows(n) * y1, x2_expected = Jwt.topRows(n) * y2;
    for (const auto& [name, kernel] : transpose_kernels) {
      Eigen::VectorXd x1 = Eigen::VectorXd::Constant(n + 1, std::nan("")), x2 = x1;
      kernel(Jwt.data(), ld, m, n, y1.data(), y2.data(), x1.data(), x2.data());
      const double scale = 1.0 + Jwt.cwiseAbs().maxCoeff() * m;
      ASSERT_LE((x1.head(n) - x1_expected).cwiseAbs().maxCoeff(), 1e-13 * scale) << name << " case " << c;
      ASSERT_LE((x2.head(n) - x2_expected).cwiseAbs().maxCoeff(), 1e-13 * scale) << name << " case " << c;
      ASSERT_TRUE(std::isnan(x1[n]) && std::isnan(x2[n])) << name << ": wrote past n, case " << c;
    }
  }
}

// The cycle's three triangular solves (L D L^T x = b for three right-hand sides at once)
// against Eigen's solve of the same A = L D L^T, for every row count the solver meets and
// unused entries of L above the diagonal set to NaN (the kernels must not read them).
TEST(Solver, ThreeSolvesKernelsMatchEigen) {
  std::mt19937_64 rng(43);
  std::vector<std::pair<std::string, wbm::internal::ThreeSolvesKernel>> kernels = {
      {"portable", &wbm::internal::three_solves_portable}};
  if (wbm::internal::select_three_solves() != &wbm::internal::three_solves_portable)
    kernels.emplace_back("avx2", wbm::internal::three_solves_avx2());
  else
    std::cout << "this CPU has no AVX2/FMA: only the portable kernel is tested\n";
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  for (int c = 0; c < 3000; ++c) {
    const int m = 1 + static_cast<int>(rng() % 41);
    const int ld = m + static_cast<int>(rng() % 3);
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    RowMajor L = RowMajor::Constant(m, ld, std::nan(""));
    Eigen::MatrixXd L_plain = Eigen::MatrixXd::Identity(m, m);
    for (int i = 0; i < m; ++i)
      for (int k = 0; k < i; ++k) L(i, k) = L_plain(i, k) = 0.5 * uniform(rng);
    Eigen::VectorXd d(m), inv_d(m);
    for (int i = 0; i < m; ++i) {
      d[i] = 0.2 + std::abs(uniform(rng));
      inv_d[i] = 1.0 / d[i];
    }
    const Eigen::MatrixXd A = L_plain * d.asDiagonal() * L_plain.transpose();
    const Eigen::MatrixXd B = Eigen::MatrixXd::NullaryExpr(m, 3, [&] { return uniform(rng); });
    const Eigen::MatrixXd expected = A.ldlt().solve(B);
    for (const auto& [name, kernel] : kernels) {
      // In place, and from separate inputs (left untouched) into outputs; each vector with a
      // NaN guard behind it; scratch of exactly 4 m entries.
      for (const bool in_place : {true, false}) {
        Eigen::MatrixXd b = Eigen::MatrixXd::Constant(m + 1, 3, std::nan(""));
        b.topRows(m) = B;
        const Eigen::MatrixXd b_before = b;
        Eigen::MatrixXd separate = Eigen::MatrixXd::Constant(m + 1, 3, std::nan(""));
        Eigen::MatrixXd& x = in_place ? b : separate;
        std::vector<double> scratch(4 * static_cast<std::size_t>(m), std::nan(""));
        kernel(L.data(), ld, inv_d.data(), m, b.col(0).data(), b.col(1).data(), b.col(2).data(), x.col(0).data(),
               x.col(1).data(), x.col(2).data(), scratch.data());
        const double error = (x.topRows(m) - expected).cwiseAbs().maxCoeff();
        ASSERT_LE(error, 1e-10 * (1.0 + expected.cwiseAbs().maxCoeff()))
            << name << " m " << m << " case " << c << (in_place ? " in place" : " separate");
        ASSERT_TRUE(x.row(m).array().isNaN().all()) << name << ": wrote past m, case " << c;
        if (!in_place) {
          ASSERT_TRUE(b.topRows(m) == b_before.topRows(m)) << name << ": changed its input, case " << c;
        }
      }
    }
  }
}

// The small two-lane kernels against plain loops, for every length from 0 to 11: the odd
// lengths run their tails (the solver calls some with even lengths only, but their contract
// is any length), and a non-finite entry at any place is found.
TEST(Solver, SmallKernelsMatchPlainLoops) {
  std::mt19937_64 rng(38);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  auto random_vector = [&](int n) { return VectorXd(VectorXd::NullaryExpr(n, [&] { return uniform(rng); })); };
  const double inf = std::numeric_limits<double>::infinity();
  for (int c = 0; c < 50; ++c) {
    for (int n = 0; n < 12; ++n) {
      const VectorXd a0 = random_vector(n), a1 = random_vector(n), b0 = random_vector(n), b1 = random_vector(n);
      double four[4], two[2];
      wbm::internal::four_dot_products(a0.data(), a1.data(), b0.data(), b1.data(), n, four);
      const double expected_four[4] = {b0.dot(a0), b0.dot(a1), b1.dot(a0), b1.dot(a1)};
      for (int k = 0; k < 4; ++k) ASSERT_NEAR(four[k], expected_four[k], 1e-14 * (1 + n)) << "n " << n << " sum " << k;
      wbm::internal::two_dot_products(a0.data(), b0.data(), b1.data(), n, two);
      ASSERT_NEAR(two[0], b0.dot(a0), 1e-14 * (1 + n)) << "n " << n;
      ASSERT_NEAR(two[1], b1.dot(a0), 1e-14 * (1 + n)) << "n " << n;

      // Two columns scaled into neighbouring entries of n rows (leading dimension 3; the
      // third entry of each row stays untouched).
      const double r0 = uniform(rng), r1 = uniform(rng);
      MatrixXd out = MatrixXd::Constant(3, std::max(n, 1), std::nan(""));
      wbm::internal::scaled_transpose_two_columns(a0.data(), a1.data(), r0, r1, n, out.data(), 3);
      for (int i = 0; i < n; ++i) {
        ASSERT_EQ(out(0, i), r0 * a0[i]) << "n " << n << " row " << i;
        ASSERT_EQ(out(1, i), r1 * a1[i]) << "n " << n << " row " << i;
        ASSERT_TRUE(std::isnan(out(2, i))) << "n " << n << " row " << i;
      }

      ASSERT_TRUE(wbm::internal::all_finite(a0.data(), n)) << "n " << n;
      for (int i = 0; i < n; ++i)
        for (const double bad : {std::nan(""), inf, -inf}) {
          VectorXd x = a0;
          x[i] = bad;
          ASSERT_FALSE(wbm::internal::all_finite(x.data(), n)) << "n " << n << " entry " << i << " " << bad;
        }
    }
    double pair[3] = {0.0, 0.0, 7.0};
    const double first = uniform(rng), second = uniform(rng);
    wbm::internal::store_pair(pair, first, second);
    ASSERT_TRUE(pair[0] == first && pair[1] == second && pair[2] == 7.0);
  }
  // The length of a 2 x 2 block's sums: where both pairs of columns still have entries,
  // rounded up to a multiple of four.
  const int extent[4] = {5, 9, 2, 0};
  EXPECT_EQ(wbm::internal::block_extent(extent, 0, 1, 2, 3), 4);  // min(9, 2) = 2 -> 4
  EXPECT_EQ(wbm::internal::block_extent(extent, 0, 1, 0, 1), 12);  // 9 -> 12
  EXPECT_EQ(wbm::internal::block_extent(extent, 2, 3, 2, 3), 4);  // 2 -> 4
  EXPECT_EQ(wbm::internal::block_extent(extent, 3, 3, 3, 3), 0);
  const int exact[2] = {8, 4};
  EXPECT_EQ(wbm::internal::block_extent(exact, 0, 0, 1, 1), 4);
}

/// The per-model properties below run on every shipped model and, through
/// scripts/check_model.sh, on the user's robot (test names end in the model's id).
class EveryModel : public testing::TestWithParam<wbm_test::ShippedModel> {};

// The cheaper position() and z_axis() of a frame agree with its full pose, in the world and
// relative to a reference frame.

TEST_P(EveryModel, RelativeFramePositionAndAxisAgreeWithThePose) {
  const wbm_test::ShippedModel& entry = GetParam();
  const Model model = entry.load();
  std::mt19937_64 rng(43);
  Data data(model);
  for (const std::string reference : {"", "heel"}) {
    const RelativeFrame frame(model, entry.left_hand, reference);
    for (int c = 0; c < 50; ++c) {
      forward_kinematics(model, data, wbm_test::random_configuration(model, rng));
      const Transform X = frame.pose(model, data);
      ASSERT_LT((frame.position(model, data) - X.p).norm(), 1e-12) << entry.id << " " << reference;
      ASSERT_LT((frame.z_axis(model, data) - X.R.col(2)).norm(), 1e-12) << entry.id << " " << reference;
    }
  }
}

/// J J# = I at full rank, J N = 0, N N = N and frozen dofs exactly still (eqs. 6, 7 and
/// IV.D) on `cases` random configurations, activations and constraints of the stack's rows
/// (a fixed base always frozen). Full rank as the damping sees it: the exact sigma_min of
/// J W^-1/2 (free dofs) at or above the singularity threshold. Then no solve may damp: the
/// solver's estimates of sigma_min^2 (the Rayleigh quotient of an inverse-iteration step and
/// the bound |b|^2 / |A^-1 b|^2 of the task solve) are both at least the exact one. Below
/// the threshold J# (solves of unit right-hand sides, pseudo_inverse()) need not be the
/// undamped one even where the test's own solve was not damped: the task bound depends on
/// the right-hand side (a random dual-arm variant, sigma_min 0.87 of the threshold: one
/// column of J# damped, the task solve not, J J# off by 0.09).
void check_pseudo_inverse_identities(const wbm_test::ShippedModel& entry, const Model& model, TaskStack& stack,
                                     unsigned seed, int cases) {
  Data data(model);
  WholeBodySolver solver(model, stack.num_rows());
  std::mt19937_64 rng(seed);
  std::bernoulli_distribution coin(0.7), freeze(0.15);
  const int n = model.num_dofs();
  int full_rank = 0;
  for (int c = 0; c < cases; ++c) {
    const VectorXd q = wbm_test::random_configuration(model, rng);
    forward_kinematics(model, data, q);
    for (int r = 0; r < stack.num_rows(); ++r) stack.activation()[r] = coin(rng);
    Mask free(n);
    for (int i = 0; i < n; ++i) free[i] = !freeze(rng);
    entry.freeze_base(model, free);
    randomize_targets(model, data, stack, rng);
    const int m = stack.assemble(model, data);
    const MatrixXd J = stack.jacobian();
    const MatrixXd Jp = solver.pseudo_inverse(J, free);
    const SolverStatus st = solver.solve(J, stack.task_velocity(), VectorXd::Zero(n), free, 0.001);
    ASSERT_TRUE(st.ok()) << describe(q, stack.activation(), free);
    // The paper's construction (IV.D): frozen columns of J zeroed, N = E - J# J (eq. 7),
    // and the diagonal elements of the frozen dofs set to zero.
    MatrixXd Jfree = J;
    for (int i = 0; i < n; ++i)
      if (!free[i]) Jfree.col(i).setZero();
    MatrixXd N = MatrixXd::Identity(n, n) - Jp * Jfree;
    for (int i = 0; i < n; ++i)
      if (!free[i]) N(i, i) = 0.0;
    for (int i = 0; i < n; ++i)
      if (!free[i]) {
        ASSERT_EQ(Jp.row(i).norm(), 0.0) << "J# row of a frozen dof\n" << describe(q, stack.activation(), free);
        ASSERT_EQ(solver.output().qdot[i], 0.0) << describe(q, stack.activation(), free);
      }
    ASSERT_TRUE(Jp.allFinite() && solver.output().qdot.allFinite()) << describe(q, stack.activation(), free);
    if (m == 0) continue;
    MatrixXd JW = Jfree;  // J W^-1/2 over the free dofs
    for (int i = 0; i < n; ++i) JW.col(i) *= model.dof(i).work_range;
    const double lambda_min =
        Eigen::SelfAdjointEigenSolver<MatrixXd>(JW * JW.transpose(), Eigen::EigenvaluesOnly).eigenvalues()[0];
    const double threshold = solver.parameters().singular_threshold;
    if (lambda_min < threshold * threshold * (1.0 + 1e-6)) continue;
    ++full_rank;
    ASSERT_FALSE(st.has(kDamped)) << "damped at sigma_min " << std::sqrt(lambda_min) << " (threshold " << threshold
                                  << ", estimate " << solver.output().min_singular_value << ")\n"
                                  << describe(q, stack.activation(), free);
    const double scale = 1.0 + J.norm() * Jp.norm();
    ASSERT_LT((J * Jp - MatrixXd::Identity(m, m)).norm(), 1e-9 * scale) << describe(q, stack.activation(), free);
    ASSERT_LT((Jfree * N).norm(), 1e-9 * scale) << describe(q, stack.activation(), free);
    ASSERT_LT((N * N - N).norm(), 1e-9 * scale * scale) << describe(q, stack.activation(), free);
  }
  std::cout << "  " << entry.id << ": identities checked on " << full_rank << " of " << cases << " cases\n";
  // The identities must have been checked on enough cases, not skipped.
  EXPECT_GE(full_rank, entry.min_full_rank_share * cases)
      << entry.id << ": the identities were checked on " << full_rank << " of " << cases
      << " cases only; the solver damped the others (rows near a singularity). If the rows are singular by the "
         "robot's build (e.g. a head frame turned by fewer than two free joints under a 2-row view axis), leave "
         "the frame out (--head).";
}

/// Cases of a property on each model when it runs on all of them (10^4 in all by default).
int cases_per_model() {
  return std::max(50, property_cases() / static_cast<int>(wbm_test::shipped_models().size()));
}

// The paper's task vector on the paper model (eq. 4), its equivalent on the others.
TEST_P(EveryModel, PseudoInverseAndNullSpaceIdentitiesWithTheHandAndViewRows) {
  const wbm_test::ShippedModel& entry = GetParam();
  const Model model = entry.load();
  TaskStack stack(model);
  add_hand_tasks(model, stack, entry.left_hand, entry.right_hand, entry.head);
  check_pseudo_inverse_identities(entry, model, stack, 20051205, property_cases());
}

TEST(Solver, NullSpaceMotionDoesNotMoveTheTask) {
  // q_dot = J# x_dot - alpha N W^-1 grad: the null-space part is invisible to J.
  const Model model = make_paper_model();
  Data data(model);
  TaskStack stack(model);
  add_paper_tasks(model, stack);
  SolverParameters p;
  p.limit_speeds = false;
  p.nullspace_rate_change_limit = 0.0;
  WholeBodySolver solver(model, stack.num_rows(), p);
  CubicJointLimitCriterion criterion(model, 0.1);
  std::mt19937_64 rng(7);
  std::bernoulli_distribution coin(0.5);
  int checked = 0;
  for (int c = 0; c < property_cases(); ++c) {
    const VectorXd q = wbm_test::random_configuration(model, rng);
    forward_kinematics(model, data, q);
    for (int r = 0; r < stack.num_rows(); ++r) stack.activation()[r] = coin(rng);
    randomize_targets(model, data, stack, rng);
    stack.assemble(model, data);
    VectorXd grad(model.num_dofs());
    criterion.gradient(q, grad);
    const Mask free = Mask::Constant(model.num_dofs(), true);
    const SolverStatus st = solver.solve(stack.jacobian(), stack.task_velocity(), grad, free, 0.001);
    if (st.has(kDamped) || stack.jacobian().rows() == 0) continue;
    const VectorXd Jn = stack.jacobian() * solver.output().qdot_null;
    ASSERT_LT(Jn.norm(), 1e-9 * (1.0 + solver.output().qdot_null.norm())) << describe(q, stack.activation(), free);
    ASSERT_LT((stack.jacobian() * solver.output().qdot_task - stack.task_velocity()).norm(),
              1e-9 * (1.0 + stack.task_velocity().norm()));
    ++checked;
  }
  EXPECT_GT(checked, property_cases() / 2);
}

/// Random controller runs: random targets (some unreachable), activation and constraint
/// switching at random cycles, NaN targets now and then. Every cycle: no NaN, positions
/// within limits, speeds within limits, frozen dofs exactly still, no rate towards a limit
/// faster than braking allows, no free dof's rate changed by more than k v_max dt. A fixed base stays
/// frozen throughout. kJitter: every cycle has another dt in [0.25, 4] ms (a loop that
/// passes the measured period). kExtreme: half the cycles a dt from 1e-12 to 10 s, targets
/// up to 1e200 m or rad away, now and then every dof frozen. kExternal: external velocities
/// (up to 1.5 v_max, either sign) on random dofs frozen in b_C, now and then none.
enum class Commands { kNormal, kJitter, kExtreme, kExternal };

void random_controller_run(const wbm_test::ShippedModel& entry, unsigned seed, int cycles,
                           const std::vector<std::string>& posture = {}, Commands commands = Commands::kNormal) {
  const Model model = entry.load();
  const std::string& l = entry.left_hand;
  const std::string& r = entry.right_hand;
  const std::string& head = entry.head;
  Controller c(model);
  c.add_task(std::make_unique<PositionTask>(model, "l_hand", l));
  c.add_task(std::make_unique<AxisTask>(model, "l_grasp", l));
  // Joint rows between the others (eliminated by the solver; their dofs also reach limits).
  if (!posture.empty()) c.add_task(std::make_unique<JointTask>(model, "posture", posture));
  c.add_task(std::make_unique<PositionTask>(model, "r_hand", r));
  c.add_task(std::make_unique<AxisTask>(model, "r_grasp", r));
  if (!head.empty()) c.add_task(std::make_unique<AxisTask>(model, "view", head));
  std::mt19937_64 rng(seed);
  c.reset(entry.start(model));
  Command cmd = c.make_command();
  entry.freeze_base(model, cmd.free_dofs);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::bernoulli_distribution rare(0.01), coin(0.5), freeze(0.1);
  std::uniform_real_distribution<double> period(0.00025, 0.004), log_period(-12.0, 1.0), log_distance(-10.0, 200.0);
  const bool extreme = commands == Commands::kExtreme;
  double dt = 0.002;
  for (int k = 0; k < cycles; ++k) {
    if (commands == Commands::kJitter) dt = period(rng);
    if (extreme) dt = coin(rng) ? 0.001 : std::pow(10.0, log_period(rng));
    if (rare(rng)) {
      const double distance = extreme ? std::pow(10.0, log_distance(rng)) : 0.6;
      for (int i = 0; i < cmd.targets.size(); ++i) cmd.targets[i] = c.values()[i] + distance * u(rng);
      for (int i = 0; i < cmd.task_active.size(); ++i) cmd.task_active[i] = coin(rng);
      for (int i = 0; i < cmd.free_dofs.size(); ++i) cmd.free_dofs[i] = !freeze(rng) && !(extreme && rare(rng));
      entry.freeze_base(model, cmd.free_dofs);
      if (coin(rng)) cmd.targets[0] = std::nan("");
      if (commands == Commands::kExternal) {
        cmd.external_velocity.setZero(coin(rng) || rare(rng) ? model.num_dofs() : 0);
        for (int i = 0; i < cmd.external_velocity.size(); ++i)
          if (!cmd.free_dofs[i] && coin(rng)) cmd.external_velocity[i] = 1.5 * model.dof(i).max_speed * u(rng);
        cmd.compensate_external = coin(rng);
      }
    }
    const VectorXd q_before = c.q(), qdot_before = c.qdot();
    const ControllerStatus st = c.update(cmd, dt);
    const VectorXd& q = c.q();
    ASSERT_TRUE(q.allFinite() && c.qdot().allFinite()) << "cycle " << k;
    for (int i = 0; i < model.num_dofs(); ++i) {
      ASSERT_GE(q[i], model.dof(i).lower) << model.dof(i).name << " cycle " << k;
      ASSERT_LE(q[i], model.dof(i).upper) << model.dof(i).name << " cycle " << k;
      // The rate reported is the realised step over dt; a step is exact to an ulp of q, which
      // over a dt of 1e-12 s is 2e-4 rad/s (the kExtreme runs).
      const double rounding = 2.0 * std::numeric_limits<double>::epsilon() * (1.0 + std::abs(q_before[i])) / dt;
      ASSERT_LE(std::abs(c.qdot()[i]), model.dof(i).max_speed * (1 + 1e-9) + rounding)
          << model.dof(i).name << " cycle " << k << " dt " << dt;
      const bool driven = cmd.external_velocity.size() != 0 && cmd.external_velocity[i] != 0.0;
      if (!cmd.free_dofs[i] && !driven) { ASSERT_EQ(q[i], q_before[i]) << "frozen " << model.dof(i).name << " cycle " << k; }
      // Towards a limit d away, no faster than stops there at k v_max / 2 (k = 20/s): the
      // dof is braked, not stopped by the clamp.
      const double v = c.qdot()[i];
      const double d = v > 0.0 ? model.dof(i).upper - q_before[i] : q_before[i] - model.dof(i).lower;
      ASSERT_LE(std::abs(v), std::sqrt(20.0 * model.dof(i).max_speed * std::max(d, 0.0)) * (1 + 1e-9) + rounding)
          << model.dof(i).name << " cycle " << k << " dt " << dt << " rate " << v << " limit " << d << " away";
      // A free dof's rate, or a frozen one's driven by an external velocity, changes by at
      // most k v_max dt per cycle (the Controller's bound), but in a cycle that failed (q_dot
      // 0 at once). Braking after the bound may cut more
      // where dt varies (the jittered runs); the extreme dts are left out.
      if ((cmd.free_dofs[i] || driven) && st.ok() && commands != Commands::kExtreme &&
          !(commands == Commands::kJitter && st.has(kDofBraked))) {
        ASSERT_LE(std::abs(v - qdot_before[i]), 20.0 * model.dof(i).max_speed * dt * (1 + 1e-9) + 4.0 * rounding)
            << model.dof(i).name << " cycle " << k << " dt " << dt << " rate " << qdot_before[i] << " -> " << v;
      }
    }
    ASSERT_FALSE(st.has(kJointLimitClamped)) << "cycle " << k << " dt " << dt;
    if (!st.ok()) { ASSERT_EQ(q, q_before); }
  }
}

TEST_P(EveryModel, RandomControllerRunsKeepLimits) {
  random_controller_run(GetParam(), 4, property_cases());
}

TEST(Controller, RandomRunsKeepLimitsWithJointRows) {
  random_controller_run(wbm_test::shipped_model("g1_29dof"), 3, property_cases(),
                        {"waist_yaw_joint", "left_shoulder_yaw_joint", "right_wrist_roll_joint"});
}

TEST(Controller, RandomRunsKeepLimitsWithAVaryingCycleTime) {
  for (const char* id : {"paper", "g1_29dof", "dual_arm"})
    random_controller_run(wbm_test::shipped_model(id), 5, property_cases(), {}, Commands::kJitter);
}

TEST(Controller, RandomRunsWithExternalVelocitiesKeepLimits) {
  for (const char* id : {"paper", "g1_29dof", "dual_arm"})
    random_controller_run(wbm_test::shipped_model(id), 7, property_cases(), {}, Commands::kExternal);
}

TEST(Controller, RandomRunsWithExtremeCycleTimesAndTargetsStayFiniteWithinLimits) {
  for (const char* id : {"paper", "g1_29dof", "dual_arm"})
    random_controller_run(wbm_test::shipped_model(id), 6, property_cases(), {}, Commands::kExtreme);
}

/// phi of eq. (15) between the frame's z-axis and a target, for finite differences.
double axis_angle(const Model& model, Data& data, const VectorXd& q, int frame, const Vector3& target) {
  forward_kinematics(model, data, q);
  const Vector3 a = frame_pose(model, data, frame).R.col(2);
  return std::atan2(a.cross(target.normalized()).norm(), a.dot(target.normalized()));
}

/// Both rows of an axis element (J, evaluated at q for the target a_t given in the reference
/// frame) are the relative angular velocity w along the sl-frame's x and y (a right-handed
/// frame, z the axis a_g): a_g moves as w x a_g, so that its change along y_sl is -row_x v
/// and along x_sl row_y v, by central differences of a_g along v.
testing::AssertionResult axis_rows_match_differences(const Model& model, Data& data, const MatrixXd& J, int frame,
                                                     int reference_frame, const VectorXd& q, const Vector3& target_R,
                                                     const VectorXd& v) {
  auto axis_relative = [&](const VectorXd& qq) {
    forward_kinematics(model, data, qq);
    const Transform X_WR = reference_frame >= 0 ? frame_pose(model, data, reference_frame) : Transform();
    return Vector3((X_WR.inverse() * frame_pose(model, data, frame)).R.col(2));
  };
  const Vector3 a_R = axis_relative(q);
  double phi = 0.0;
  const Matrix3 R_sl = AxisTask::sl_frame(a_R, target_R, Vector3::UnitY(), &phi);
  if (std::abs(R_sl.determinant() - 1.0) > 1e-12 || (R_sl.transpose() * R_sl - Matrix3::Identity()).norm() > 1e-12 ||
      (R_sl.col(2) - a_R).norm() > 1e-12)
    return testing::AssertionFailure() << "the sl-frame is no right-handed frame about the axis:\n" << R_sl;
  const double h = 1e-6;
  const Vector3 da = (axis_relative(q + h * v) - axis_relative(q - h * v)) / (2 * h);
  forward_kinematics(model, data, q);
  const double row_x = (J.row(0) * v)(0), row_y = (J.row(1) * v)(0);
  if (std::abs(da.dot(R_sl.col(1)) + row_x) > 1e-6 || std::abs(da.dot(R_sl.col(0)) - row_y) > 1e-6)
    return testing::AssertionFailure() << "rows x, y give " << row_x << ", " << row_y << "; differences "
                                       << -da.dot(R_sl.col(1)) << ", " << da.dot(R_sl.col(0));
  return testing::AssertionSuccess();
}

TEST_P(EveryModel, AxisJacobianMatchesFiniteDifferencesOfPhiAndAxis) {
  // Relative to the heel and to the other hand's frame (turned on its body in most models:
  // the reference's rotation is its body's times the frame's own).
  const wbm_test::ShippedModel& entry = GetParam();
  const Model model = entry.load();
  Data data(model);
  const int frame = model.frame_index(entry.left_hand);
  for (const std::string& reference : {std::string("heel"), entry.right_hand}) {
    if (reference == entry.left_hand) continue;  // one frame for both hands
    AxisTask task(model, "axis", entry.left_hand, reference);
    const int reference_frame = model.frame_index(reference);
    std::mt19937_64 rng(99);
    MatrixXd J(2, model.num_dofs());
    VectorXd e(2), rate(2);
    const int cases = cases_per_model();
    for (int c = 0; c < cases; ++c) {
      const VectorXd q = wbm_test::random_configuration(model, rng);
      forward_kinematics(model, data, q);
      const Transform X_WR = frame_pose(model, data, reference_frame);
      const Vector3 target_R = wbm_test::random_direction(3, rng);  // in the reference frame
      task.evaluate(model, data, target_R, Vector3::Zero(), J, e, rate);
      const Vector3 target_W = X_WR.R * target_R;
      const double phi = axis_angle(model, data, q, frame, target_W);
      if (phi < 1e-3 || phi > M_PI - 1e-3) continue;  // degenerate set: tested separately
      ASSERT_NEAR(e[1], phi, 1e-12) << entry.id << " relative to " << reference << ", case " << c;
      ASSERT_EQ(e[0], 0.0);
      const VectorXd v = wbm_test::random_direction(model.num_dofs(), rng);
      const double h = 1e-6;
      // The reference moves with q too: compare phi in the reference frame.
      auto phi_relative = [&](const VectorXd& qq) {
        forward_kinematics(model, data, qq);
        const Transform X = frame_pose(model, data, reference_frame).inverse() * frame_pose(model, data, frame);
        const Vector3 a = X.R.col(2);
        return std::atan2(a.cross(target_R.normalized()).norm(), a.dot(target_R.normalized()));
      };
      const double dphi = (phi_relative(q + h * v) - phi_relative(q - h * v)) / (2 * h);
      // Rotating about e_y moves a_g towards a_t: d(phi)/dt = -row_y q_dot.
      ASSERT_NEAR(dphi, -(J.row(1) * v)(0), 1e-6) << entry.id << " relative to " << reference << ", case " << c;
      ASSERT_TRUE(axis_rows_match_differences(model, data, J, frame, reference_frame, q, target_R, v))
          << entry.id << " relative to " << reference << ", case " << c;
    }
  }
}

// Rows of an axis on a chain with a mimic joint (a body driven by another's dof with a
// factor of -1.7 and an offset): that dof's columns count the factor in both rows.
TEST(AxisTask, RowsCountAMimicJointsFactor) {
  ModelBuilder builder("mimic_axis");
  Dof dof;
  dof.lower = -2.0;
  dof.upper = 2.0;
  dof.max_speed = 1.0;
  dof.name = "a";
  const int a = builder.add_dof(dof);
  dof.name = "b";
  const int b = builder.add_dof(dof);
  Body first;
  first.name = "first";
  first.dof = a;
  builder.add_body(first);
  Body coupled;  // turns by -1.7 a + 0.2 about y, above the first
  coupled.name = "coupled";
  coupled.parent = 0;
  coupled.X_PJ.p = {0.0, 0.0, 0.3};
  coupled.axis = Vector3::UnitY();
  coupled.dof = a;
  coupled.multiplier = -1.7;
  coupled.offset = 0.2;
  builder.add_body(coupled);
  Body last;
  last.name = "last";
  last.parent = 1;
  last.X_PJ.p = {0.1, 0.0, 0.2};
  last.axis = Vector3::UnitX();
  last.dof = b;
  builder.add_body(last);
  const Model model = builder.build();
  Data data(model);
  AxisTask task(model, "axis", "last");
  std::mt19937_64 rng(61);
  MatrixXd J(2, 2);
  VectorXd e(2), rate(2);
  for (int c = 0; c < 200; ++c) {
    const VectorXd q = wbm_test::random_configuration(model, rng);
    const Vector3 target = wbm_test::random_direction(3, rng);
    forward_kinematics(model, data, q);
    task.evaluate(model, data, target, Vector3::Zero(), J, e, rate);
    if (e[1] < 1e-3 || e[1] > M_PI - 1e-3) continue;
    ASSERT_TRUE(axis_rows_match_differences(model, data, J, model.frame_index("last"), -1, q, target,
                                            wbm_test::random_direction(2, rng)))
        << "case " << c;
  }
}

// An axis given in the frame (a camera link that looks along x) is the z-axis of that frame
// turned so that its z is the axis and its y the fallback: written as such a frame in the
// URDF, the two elements must agree in value, rows, error and rate, also where the target is
// along or against the axis (the fallback y). G1's d435_link looks along x.
TEST(AxisTask, AnAxisInTheFrameIsTheZAxisOfATurnedFrame) {
  const wbm_test::ShippedModel& g1 = wbm_test::shipped_model("g1_29dof");
  const std::string original = wbm_test::read_file(g1.path);
  for (const Vector3& axis : {Vector3(1.0, 0.0, 0.0), Vector3(1.0, 2.0, -0.5), Vector3(0.0, -3.0, 0.0)}) {
    const Vector3 z = axis.normalized();
    Vector3 y = Vector3::UnitY() - z.y() * z;
    if (y.norm() < 1e-6) y = Vector3::UnitZ() - z.z() * z;
    y.normalize();
    Matrix3 R;
    R << y.cross(z), y, z;
    const Vector3 rpy = rpy_from_rotation(R);
    std::ostringstream link;
    link.precision(17);
    link << "  <link name=\"turned_camera\"/>\n  <joint name=\"turned_camera_joint\" type=\"fixed\">\n"
         << "    <parent link=\"d435_link\"/>\n    <child link=\"turned_camera\"/>\n"
         << "    <origin xyz=\"0 0 0\" rpy=\"" << rpy.transpose() << "\"/>\n  </joint>\n</robot>";
    std::string text = original;
    text.replace(text.rfind("</robot>"), 8, link.str());
    const Model model = parse_urdf(text, g1.options, "g1_turned_camera.urdf");
    Data data(model);
    AxisTask given(model, "given", "d435_link", "heel", 2.5 * axis);  // any length
    AxisTask turned(model, "turned", "turned_camera", "heel");
    std::mt19937_64 rng(23);
    MatrixXd Jg(2, model.num_dofs()), Jt(2, model.num_dofs());
    VectorXd eg(2), et(2), rg(2), rt(2), xg(3), xt(3);
    for (int c = 0; c < 200; ++c) {
      forward_kinematics(model, data, wbm_test::random_configuration(model, rng));
      given.value(model, data, xg);
      turned.value(model, data, xt);
      ASSERT_LT((xg - xt).cwiseAbs().maxCoeff(), 1e-12) << axis.transpose();
      // Random targets, and every tenth along or against the current axis.
      Vector3 target = wbm_test::random_direction(3, rng);
      if (c % 10 == 1) target = xt;
      if (c % 10 == 2) target = -xt;
      const Vector3 rate = wbm_test::random_direction(3, rng);
      given.evaluate(model, data, target, rate, Jg, eg, rg);
      turned.evaluate(model, data, target, rate, Jt, et, rt);
      ASSERT_LT((Jg - Jt).cwiseAbs().maxCoeff(), 1e-9) << axis.transpose() << " case " << c;
      ASSERT_LT((eg - et).cwiseAbs().maxCoeff(), 1e-9) << axis.transpose() << " case " << c;
      ASSERT_LT((rg - rt).cwiseAbs().maxCoeff(), 1e-9) << axis.transpose() << " case " << c;
    }
  }
  const Model model = g1.load();
  for (const Vector3& bad : {Vector3(0.0, 0.0, 0.0), Vector3(std::nan(""), 0.0, 1.0), Vector3(INFINITY, 0.0, 0.0)}) {
    try {
      AxisTask task(model, "view", "d435_link", "", bad);
      ADD_FAILURE() << bad.transpose() << " accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("axis task 'view': the axis in frame 'd435_link' must be a finite, non-zero"),
                std::string::npos)
          << e.what();
    }
  }
}

TEST_P(EveryModel, TaskElementJacobiansMatchFiniteDifferencesOfTheirValues) {
  // Position and centre of mass relative to the heel, attitude relative to the upper body,
  // joints (the first and the last after the nine virtual dofs): J v against the central
  // difference of value() along a random direction.
  const wbm_test::ShippedModel& entry = GetParam();
  const Model model = entry.load();
  Data data(model);
  const int n = model.num_dofs();
  std::vector<std::unique_ptr<TaskElement>> elements;
  elements.push_back(std::make_unique<PositionTask>(model, "p", entry.left_hand, "heel"));
  // Relative to the frame of a body its dof drives with a factor other than 1 (a mimic
  // joint), where the model has one: the reference's own joint columns count that factor.
  for (int b = 0; b < model.num_bodies(); ++b)
    if (model.body(b).dof >= 0 && model.body(b).multiplier != 1.0 && model.find_frame(model.body(b).name) >= 0) {
      elements.push_back(std::make_unique<PositionTask>(model, "p_mimic", entry.left_hand, model.body(b).name));
      break;
    }
  if (model.total_mass() > 0.0) {  // a URDF without masses has no centre of mass
    elements.push_back(std::make_unique<CenterOfMassTask>(model, "c", "heel"));
    elements.push_back(std::make_unique<CenterOfMassTask>(model, "cw"));
  }
  elements.push_back(std::make_unique<AttitudeTask>(model, "a", entry.right_hand,
                                                    model.body(model.virtual_dofs().upper_body).name));
  std::vector<std::string> joints{model.dof(9).name};
  if (n - 1 > 9) joints.push_back(model.dof(n - 1).name);
  elements.push_back(std::make_unique<JointTask>(model, "j", joints));
  std::mt19937_64 rng(31);
  auto value_at = [&](TaskElement& e, const VectorXd& q) {
    forward_kinematics(model, data, q);
    center_of_mass(model, data);
    VectorXd x(e.target_dim());
    e.value(model, data, x);
    return x;
  };
  // The attitude's Kardan angles are singular at pitch +-90 deg (gimbal lock): their rates
  // grow as 1 / cos(pitch), and so do the higher derivatives that make the central
  // difference's error. Within 0.05 of it (2.9 deg) the attitude is not compared: Cassie's
  // all-continuous legs reach a toe 0.0009 rad from gimbal lock (difference off by 0.12,
  // its Jacobian right, as every other test of it showed). Most cases stay compared.
  int attitude_skipped = 0;
  for (int c = 0; c < 200; ++c) {
    const VectorXd q = wbm_test::random_configuration(model, rng);
    const VectorXd v = wbm_test::random_direction(model.num_dofs(), rng);
    for (auto& e : elements) {
      const VectorXd x = value_at(*e, q);
      if (dynamic_cast<AttitudeTask*>(e.get()) != nullptr && std::abs(std::cos(x[1])) < 0.05) {
        ++attitude_skipped;
        continue;
      }
      MatrixXd J(e->dim(), model.num_dofs());
      VectorXd err(e->dim()), rate(e->dim());
      e->evaluate(model, data, x, VectorXd::Zero(e->target_dim()), J, err, rate);
      const double h = 1e-6;
      VectorXd fd = (value_at(*e, q + h * v) - value_at(*e, q - h * v)) / (2 * h);
      ASSERT_LT((fd - J * v).norm(), 1e-6 * (1 + fd.norm()))
          << entry.id << " element " << e->name() << " case " << c << ", value " << x.transpose()
          << "\n  q = " << q.transpose() << "\n  v = " << v.transpose();
      ASSERT_LT(err.norm(), 1e-12) << entry.id << " " << e->name();  // zero error at its own value
      if (dynamic_cast<AttitudeTask*>(e.get()) == nullptr) {
        // Vector targets: the error is the target minus the value, the rate the target's.
        VectorXd delta(e->dim()), target_rate(e->dim());
        for (int i = 0; i < e->dim(); ++i) {
          delta[i] = 0.01 * (1 + i) * (c % 2 == 0 ? 1.0 : -1.0);
          target_rate[i] = 0.3 - 0.1 * i;
        }
        value_at(*e, q);
        e->evaluate(model, data, x + delta, target_rate, J, err, rate);
        ASSERT_LT((err - delta).norm(), 1e-12) << entry.id << " " << e->name() << " case " << c;
        ASSERT_TRUE(rate == target_rate) << entry.id << " " << e->name() << " case " << c;
      }
    }
  }
  EXPECT_LT(attitude_skipped, 20) << entry.id << ": the attitude mostly near gimbal lock";
}

// The default weights leave out the heel's walking dofs (x, y, yaw: where the robot stands,
// not a posture) and continuous dofs (no limits to keep away from); a continuous dof keeps
// no weight even where the user gives it one.
TEST_P(EveryModel, CriteriaLeaveTheHeelAndContinuousDofsAlone) {
  const wbm_test::ShippedModel& entry = GetParam();
  const Model model = entry.load();
  const int n = model.num_dofs();
  const VectorXd defaults = default_criterion_weights(model);
  for (int i = 0; i < n; ++i) {
    const Dof& d = model.dof(i);
    const bool left_out = d.continuous || d.role == DofRole::kHeelX || d.role == DofRole::kHeelY ||
                          d.role == DofRole::kHeelYaw;
    EXPECT_EQ(defaults[i], left_out ? 0.0 : 1.0) << entry.id << " dof " << d.name;
  }
  const JointCenterCriterion center(model, VectorXd::Ones(n));
  const CubicJointLimitCriterion cubic(model, 0.5, VectorXd::Ones(n));
  std::mt19937_64 rng(38);
  VectorXd g_center(n), g_cubic(n);
  for (int c = 0; c < 20; ++c) {
    VectorXd q = wbm_test::random_configuration(model, rng);
    for (int i = 0; i < n; ++i)
      if (model.dof(i).continuous) q[i] = 3.0 - 0.1 * c;  // far from 0, the continuous dofs' centre
    center.gradient(q, g_center);
    cubic.gradient(q, g_cubic);
    for (int i = 0; i < n; ++i)
      if (model.dof(i).continuous) {
        ASSERT_EQ(g_center[i], 0.0) << entry.id << " dof " << model.dof(i).name;
        ASSERT_EQ(g_cubic[i], 0.0) << entry.id << " dof " << model.dof(i).name;
      }
  }
}

// The heel's walking dofs are left out by their role, not only because the virtual base
// makes its yaw continuous: a model built by hand with a limited heel yaw keeps it out too.
TEST(Criteria, ALimitedHeelYawHasNoDefaultWeight) {
  ModelBuilder builder("limited_heel_yaw");
  Dof yaw;
  yaw.name = "heel_yaw";
  yaw.role = DofRole::kHeelYaw;
  yaw.lower = -1.0;
  yaw.upper = 1.0;
  yaw.max_speed = 1.0;
  Dof elbow = yaw;
  elbow.name = "elbow";
  elbow.role = DofRole::kJoint;
  Body heel;
  heel.name = "heel";
  heel.dof = builder.add_dof(yaw);
  const int heel_body = builder.add_body(heel);
  Body arm;
  arm.name = "arm";
  arm.parent = heel_body;
  arm.axis = Vector3::UnitY();
  arm.dof = builder.add_dof(elbow);
  builder.add_body(arm);
  const Model model = builder.build();
  ASSERT_FALSE(model.dof(0).continuous);
  EXPECT_EQ(default_criterion_weights(model), Eigen::Vector2d(0.0, 1.0));
}

TEST_P(EveryModel, CriterionGradientsMatchFiniteDifferencesOfTheirCost) {
  // dH/dq is what the null space descends (eq. 5): each criterion's gradient() against the
  // central difference of its cost() on random configurations, dof by dof (a criterion
  // weighting that dof alone, so that the difference is not lost in the rounding of the
  // other dofs' terms; the other entries of the gradient exactly zero): the cubic criterion
  // with and without its band, the squared distance from the centres. With the default
  // weights the heel and continuous dofs have none.
  const wbm_test::ShippedModel& entry = GetParam();
  const Model model = entry.load();
  const int n = model.num_dofs();
  std::mt19937_64 rng(20051206);
  std::uniform_real_distribution<double> weight(0.5, 2.0);
  VectorXd gradient(n);
  int nonzero = 0;
  for (int kind = 0; kind < 3; ++kind) {
    for (int i = 0; i < n; ++i) {
      if (model.dof(i).continuous) continue;  // no centre, no limits: weight 0 always
      const VectorXd weights = VectorXd::Unit(n, i) * weight(rng);
      std::unique_ptr<NullSpaceCriterion> criterion;
      if (kind < 2)
        criterion = std::make_unique<CubicJointLimitCriterion>(model, kind == 0 ? 0.3 : 0.0, weights);
      else
        criterion = std::make_unique<JointCenterCriterion>(model, weights);
      for (int c = 0; c < 50; ++c) {
        const VectorXd q = wbm_test::random_configuration(model, rng);
        criterion->gradient(q, gradient);
        // A step small against the dof's work range (the cost's scale: Atlas's l_arm_wry2 has 2 mrad).
        const double h = 1e-6 * std::max(1.0, std::abs(q[i])) * std::min(1.0, model.dof(i).work_range);
        VectorXd up = q, down = q;
        up[i] += h;
        down[i] -= h;
        const double fd = (criterion->cost(up) - criterion->cost(down)) / (2 * h);
        const double rounding = 8.0 * std::numeric_limits<double>::epsilon() * std::abs(criterion->cost(q)) / h;
        ASSERT_NEAR(gradient[i], fd, 1e-6 * (1.0 + std::abs(fd)) + rounding)
            << entry.id << " criterion " << kind << " case " << c << " dof " << model.dof(i).name << "\n  q = "
            << q.transpose();
        gradient[i] = 0.0;
        ASSERT_EQ(gradient.norm(), 0.0) << entry.id << " criterion " << kind << ": other dofs than " << model.dof(i).name;
        nonzero += fd != 0.0;
      }
    }
  }
  EXPECT_GT(nonzero, n * 50) << entry.id << ": the costs were mostly flat, so the check checked little";
  const VectorXd defaults = default_criterion_weights(model);
  for (int i = 0; i < n; ++i) {
    const DofRole role = model.dof(i).role;
    const bool heel = role == DofRole::kHeelX || role == DofRole::kHeelY || role == DofRole::kHeelYaw;
    EXPECT_EQ(defaults[i], heel || model.dof(i).continuous ? 0.0 : 1.0) << entry.id << " " << model.dof(i).name;
  }
}

TEST(AxisTask, DegenerateCasesAreDefinedAndContinuous) {
  const Model model = make_paper_model();
  Data data(model);
  TaskStack stack(model);
  stack.add(std::make_unique<AxisTask>(model, "grasp", "l_hand_ref"));
  WholeBodySolver solver(model, 2);
  const Mask free = Mask::Constant(model.num_dofs(), true);
  forward_kinematics(model, data, model.home());
  const Vector3 a = frame_pose(model, data, model.frame_index("l_hand_ref")).R.col(2);
  const Vector3 perp = a.unitOrthogonal();
  auto solve_for = [&](const Vector3& target) {
    stack.targets() = target;
    stack.assemble(model, data);
    EXPECT_TRUE(stack.jacobian().allFinite());
    EXPECT_TRUE(stack.task_velocity().allFinite());
    solver.reset();
    solver.solve(stack.jacobian(), stack.task_velocity(), VectorXd::Zero(model.num_dofs()), free, 0.001);
    return VectorXd(solver.output().qdot);
  };
  // Coinciding axes: zero error, zero motion, and continuous: a tiny offset gives a tiny q_dot.
  const VectorXd at = solve_for(a);
  EXPECT_EQ(at.norm(), 0.0);
  for (double eps : {1e-6, 1e-9, 1e-12}) {
    const Vector3 near = Eigen::AngleAxisd(eps, perp) * a;
    EXPECT_LT((solve_for(near) - at).norm(), 1e3 * eps + 1e-12) << "eps " << eps;
  }
  // Opposite axes: phi = pi, a finite, deterministic rotation.
  double phi = 0.0;
  const Matrix3 sl = AxisTask::sl_frame(a, -a, perp, &phi);
  EXPECT_NEAR(phi, M_PI, 1e-12);
  EXPECT_TRUE(sl.allFinite());
  EXPECT_NEAR((sl.transpose() * sl - Matrix3::Identity()).norm(), 0.0, 1e-12);
  const VectorXd opposite = solve_for(-a);
  EXPECT_TRUE(opposite.allFinite());
  EXPECT_GT(opposite.norm(), 0.0);
  EXPECT_EQ(solve_for(-a), opposite);
}

// Attitude error with all rows active: the rotation to the target on Kardan rates, the same
// for the two angle triples of one rotation ((a, b, c) and (a + pi, pi - b, c + pi), also
// with |b| > 90 degrees), and the differences of the angles to first order; with one row
// active (through a TaskStack), that angle's wrapped difference to the target written with
// its pitch within 90 degrees (canonical_angles: the same rotation) exactly.
TEST(AttitudeTask, ErrorIsTheRotationToTheTargetWithAllRowsAndTheAngleWithOne) {
  const Model model = make_paper_model();
  Data data(model);
  AttitudeTask task(model, "a", "r_hand_ref");
  TaskStack stack(model);
  stack.add(std::make_unique<AttitudeTask>(model, "a", "r_hand_ref"));
  std::mt19937_64 rng(47);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  const int n = model.num_dofs();
  MatrixXd J(3, n), J_twin(3, n);
  Eigen::VectorXd e(3), e_twin(3), r(3), r_twin(3);
  for (int c = 0; c < property_cases(); ++c) {
    const VectorXd q = wbm_test::random_configuration(model, rng);
    forward_kinematics(model, data, q);
    Vector3 angles;
    task.value(model, data, angles);
    const Vector3 t(angle(rng), angle(rng), angle(rng));  // pitch up to 180 degrees
    const Vector3 twin(t.x() + M_PI, M_PI - t.y(), t.z() + M_PI);
    const Vector3 rate(angle(rng), angle(rng), angle(rng));
    const Vector3 twin_rate(rate.x(), -rate.y(), rate.z());
    ASSERT_LT((AttitudeTask::kardan_rotation(t) - AttitudeTask::kardan_rotation(twin)).norm(), 1e-12);
    const Vector3 canonical = AttitudeTask::canonical_angles(t);
    ASSERT_LT((AttitudeTask::kardan_rotation(canonical) - AttitudeTask::kardan_rotation(t)).norm(), 1e-12);
    ASSERT_LE(std::abs(std::remainder(canonical.y(), 2 * M_PI)), M_PI / 2);
    task.evaluate(model, data, t, rate, J, e, r);
    task.evaluate(model, data, twin, twin_rate, J_twin, e_twin, r_twin);
    ASSERT_LT((e - e_twin).norm(), 1e-9 * (1 + e.norm())) << "case " << c << " target " << t.transpose();
    ASSERT_LT((r - r_twin).norm(), 1e-9 * (1 + r.norm())) << "case " << c;
    // A small offset delta of the angles (away from gimbal lock): e = delta + O(delta^2).
    if (std::abs(std::cos(angles.y())) > 0.3) {
      const Vector3 delta = 1e-5 * Vector3(angle(rng), angle(rng), angle(rng));
      task.evaluate(model, data, angles + delta, Vector3::Zero(), J, e, r);
      ASSERT_LT((e - delta).norm(), 1e-8) << "case " << c << " e " << e.transpose() << " delta " << delta.transpose();
    }
    // One row active: exactly the wrapped difference of that angle.
    for (int row = 0; row < 3; ++row) {
      stack.activation().setConstant(false);
      stack.activation()[row] = true;
      stack.targets() = t;
      stack.target_rates().setZero();
      ASSERT_EQ(stack.assemble(model, data), 1);
      ASSERT_NEAR(stack.errors()[row], std::remainder(canonical[row] - angles[row], 2 * M_PI), 1e-12) << "row " << row;
    }
  }
}

// E(angles) maps the rates of the Kardan angles to the world angular velocity of
// R = Rx(a) Ry(b) Rz(c): w = vee(dR/dt R^T), by central differences on random angles and rates.
TEST(AttitudeTask, TheKardanRateMatrixMapsAngleRatesToTheAngularVelocity) {
  std::mt19937_64 rng(53);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  for (int c = 0; c < 2000; ++c) {
    const Vector3 angles(angle(rng), angle(rng), angle(rng)), rates(angle(rng), angle(rng), angle(rng));
    const double h = 1e-6;
    const Matrix3 dR = (AttitudeTask::kardan_rotation(angles + h * rates) - AttitudeTask::kardan_rotation(angles - h * rates)) / (2 * h);
    const Matrix3 W = dR * AttitudeTask::kardan_rotation(angles).transpose();
    const Vector3 w(W(2, 1), W(0, 2), W(1, 0));
    ASSERT_LT((AttitudeTask::kardan_rate_matrix(angles) * rates - w).norm(), 1e-8 * (1.0 + w.norm()))
        << "case " << c << ", angles " << angles.transpose() << ", rates " << rates.transpose();
  }
}

// At pitch +-90 degrees the Kardan angles cannot follow a turn about the axis that E lacks
// there (gimbal lock): the rows E^-1 J_R grow as 1 / cos(pitch). With |cos(pitch)| floored
// at 1e-3 they stay below about 1e3 (a joint about world z, above joints about x, y and z
// that are the angles themselves, turns about that axis), finite at the exact lock too.
TEST(AttitudeTask, RowsStayBoundedAtGimbalLock) {
  ModelBuilder builder("gimbal");
  const Vector3 axes[4] = {Vector3::UnitZ(), Vector3::UnitX(), Vector3::UnitY(), Vector3::UnitZ()};
  const char* joints[4] = {"j0", "j1", "j2", "j3"};
  const char* links[4] = {"link0", "link1", "link2", "link3"};
  for (int k = 0; k < 4; ++k) {
    Dof dof;
    dof.name = joints[k];
    dof.lower = -4.0;
    dof.upper = 4.0;
    dof.max_speed = 1.0;
    Body body;
    body.name = links[k];
    body.parent = k - 1;
    body.axis = axes[k];
    body.dof = builder.add_dof(dof);
    builder.add_body(body);
  }
  const Model model = builder.build();
  Data data(model);
  AttitudeTask task(model, "a", "link3");
  MatrixXd J(3, 4);
  VectorXd e(3), r(3), angles(3);
  for (const double off : {1e-6, -1e-6, 1e-9, 0.0, 0.1}) {
    const Eigen::Vector4d q(0.0, 0.3, M_PI / 2 - off, -0.4);
    forward_kinematics(model, data, q);
    task.value(model, data, angles);
    task.evaluate(model, data, angles, Vector3::Zero(), J, e, r);
    ASSERT_TRUE(J.allFinite()) << off;
    const double largest = J.cwiseAbs().maxCoeff();
    if (off == 0.1) {
      EXPECT_LT(largest, 20.0);
    } else {
      EXPECT_LE(largest, 1.001e3) << "pitch pi/2 - " << off;
      EXPECT_GE(largest, 0.9e3) << "pitch pi/2 - " << off;
    }
  }
}

// Inverse iteration continues from the last cycle's vector, one step per cycle away from
// the threshold. Where the rows turn (here at once) so that A's weak direction is the old
// vector's orthogonal, that step overestimates sigma_min: A was solved undamped, and a
// command along the weak direction gave |q_dot| = 60 here (H1 hands crossed out of reach:
// a shoulder at its 20 rad/s speed limit for a cycle). The task solve itself bounds
// sigma_min (solver.cpp) and damps it.
TEST(Solver, AnEstimateThatMissedTheWeakDirectionIsCaughtByTheTaskSolve) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  const int d[3] = {model.dof_index("l_shoulder_pitch"), model.dof_index("l_shoulder_roll"),
                    model.dof_index("l_shoulder_yaw")};
  SolverParameters p;
  p.limit_speeds = false;
  p.nullspace_rate_change_limit = 0.0;
  WholeBodySolver solver(model, 2, p);
  const Mask free = Mask::Constant(n, true);
  // Rows over three dofs in range-normalised units (J W^-1/2 = rows below).
  auto jacobian = [&](const Eigen::Matrix<double, 2, 3>& rows) {
    MatrixXd J = MatrixXd::Zero(2, n);
    for (int r = 0; r < 2; ++r)
      for (int k = 0; k < 3; ++k) J(r, d[k]) = rows(r, k) / model.dof(d[k]).work_range;
    return J;
  };
  Eigen::Matrix<double, 2, 3> well, weak;
  well << 1, 1, 0, -1, 0, 1;    // A = [2 -1; -1 2]: smallest eigenvalue 1 along (1, 1)
  weak << 1, 1, 0, 1, 1, 0.01;  // A = [2 2; 2 2.0001]: 5e-5 along about (1, -1)
  const VectorXd zero = VectorXd::Zero(n);
  for (int k = 0; k < 20; ++k) ASSERT_FALSE(solver.solve(jacobian(well), Eigen::Vector2d(0.1, 0.1), zero, free, 0.001).has(kDamped));
  const Eigen::Vector2d xdot(0.1, -0.1);
  const SolverStatus st = solver.solve(jacobian(weak), xdot, zero, free, 0.001);
  EXPECT_TRUE(st.has(kDamped)) << "sigma_min estimate " << solver.output().min_singular_value;
  double max_range = 0.0;
  for (int i = 0; i < n; ++i) max_range = std::max(max_range, model.dof(i).work_range);
  EXPECT_LT(solver.output().qdot.norm(), xdot.norm() * max_range / (2 * p.max_damping));
}

TEST(Solver, BoundedAndContinuousThroughASingularity) {
  // Stretch the left arm through elbow = 0 (its upper limit, the singular configuration)
  // with the hand commanded 0.3 m beyond reach: q_dot stays bounded and changes
  // continuously with the configuration.
  const Model model = make_paper_model();
  Data data(model);
  TaskStack stack(model);
  stack.add(std::make_unique<PositionTask>(model, "l_hand", "l_hand_ref"));
  Mask free = Mask::Constant(model.num_dofs(), false);
  for (const char* d : {"l_shoulder_pitch", "l_shoulder_roll", "l_shoulder_yaw", "l_elbow", "l_hand_rot"})
    free[model.dof_index(d)] = true;
  SolverParameters p;
  p.limit_speeds = false;
  p.nullspace_rate_change_limit = 0.0;
  WholeBodySolver solver(model, 3, p);
  VectorXd q = model.home();
  const int elbow = model.dof_index("l_elbow");
  const int steps = 2000;
  std::vector<VectorXd> qdots;
  double max_xdot = 0.0, max_range = 0.0;
  int damped = 0;
  for (int i = 0; i < model.num_dofs(); ++i) max_range = std::max(max_range, model.dof(i).work_range);
  for (int k = 0; k <= steps; ++k) {
    q[elbow] = -0.3 + 0.3 * k / steps;  // to the straight arm
    forward_kinematics(model, data, q);
    const Vector3 p_hand = frame_pose(model, data, model.frame_index("l_hand_ref")).p;
    const Vector3 p_shoulder = data.X_WB[model.frame(model.frame_index("l_shoulder_1")).body].p;
    stack.targets() = p_hand + 0.3 * (p_hand - p_shoulder).normalized();
    stack.assemble(model, data);
    max_xdot = std::max(max_xdot, stack.task_velocity().norm());
    const SolverStatus st = solver.solve(stack.jacobian(), stack.task_velocity(), VectorXd::Zero(model.num_dofs()), free, 0.001);
    damped += st.has(kDamped) ? 1 : 0;
    ASSERT_TRUE(solver.output().qdot.allFinite());
    qdots.push_back(solver.output().qdot);
  }
  // Bounded: the damped inverse amplifies at most 1 / (2 lambda_max) in range-normalised units.
  double max_qdot = 0.0, max_step = 0.0;
  for (size_t k = 0; k < qdots.size(); ++k) {
    max_qdot = std::max(max_qdot, qdots[k].norm());
    if (k > 0) max_step = std::max(max_step, (qdots[k] - qdots[k - 1]).norm());
  }
  EXPECT_LT(max_qdot, max_xdot * max_range / (2 * p.max_damping));
  // Continuous: a 0.15 mrad change of the elbow changes q_dot by a small fraction of it.
  EXPECT_LT(max_step, 0.02 * max_qdot);
  EXPECT_GT(damped, 0);  // the singular region was reached and reported
}

// The estimate of sigma_min^2 that sets the damping (the Rayleigh quotient of one warm
// inverse-iteration step per cycle, another step near the threshold while the iterate still
// turns) stays within 5 10^-5 eps^2 of the eigenvalue in every cycle of a sweep into the
// stretched arm and back, with a shoulder dof frozen and released every 50 cycles, with and
// without an eliminated joint row and beside a block of rows of its own (the other hand's),
// and never falls below it (an upper bound). Here the
// Rayleigh quotient without the extra step misses by 9 10^-4 eps^2 where the dof is first
// frozen, and 1 / |A^-1 v| after two steps near the threshold (the scheme before) by 8 10^-5 eps^2.
TEST(Solver, SigmaMinEstimateFollowsTheEigenvalueNearTheThreshold) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  Data data(model);
  // Variants: the left hand alone, with a joint row on its arm, and beside the right hand on
  // the other arm (two blocks of rows that share no free dof, each with its own iterate:
  // resolve_blocks()).
  for (const char* name : {"alone", "with the joint row", "beside the other hand"}) {
    const std::string variant = name;
    const bool joint_row = variant == "with the joint row", two_blocks = variant == "beside the other hand";
    TaskStack stack(model);
    stack.add(std::make_unique<PositionTask>(model, "l_hand", "l_hand_ref"));
    if (joint_row) stack.add(std::make_unique<JointTask>(model, "yaw", std::vector<std::string>{"l_shoulder_yaw"}));
    if (two_blocks) stack.add(std::make_unique<PositionTask>(model, "r_hand", "r_hand_ref"));
    Mask free = Mask::Constant(n, false);
    for (const char* d : {"l_shoulder_pitch", "l_shoulder_roll", "l_shoulder_yaw", "l_elbow", "l_hand_rot"})
      free[model.dof_index(d)] = true;
    if (two_blocks)
      for (const char* d : {"r_shoulder_pitch", "r_shoulder_roll", "r_shoulder_yaw", "r_elbow", "r_hand_rot"})
        free[model.dof_index(d)] = true;
    SolverParameters p;
    p.limit_speeds = false;
    p.nullspace_rate_change_limit = 0.0;
    const double eps2 = p.singular_threshold * p.singular_threshold;
    WholeBodySolver solver(model, 6, p);
    VectorXd q = model.home();
    q[model.dof_index("r_elbow")] = -1.2;  // the other arm well away from its singularity
    VectorXd w(n);
    for (int i = 0; i < n; ++i) w[i] = free[i] ? model.dof(i).work_range * model.dof(i).work_range : 0.0;
    const int elbow = model.dof_index("l_elbow"), yaw = model.dof_index("l_shoulder_yaw");
    const int roll = model.dof_index("l_shoulder_roll");
    const int steps = 600;
    int near = 0;
    for (int k = 0; k <= steps; ++k) {
      // Towards the straight arm and back, turning the upper arm on the way.
      const double t = static_cast<double>(k) / steps;
      q[elbow] = -0.25 * std::abs(1.0 - 2.0 * t) - 0.002;
      q[yaw] = 0.4 * std::sin(3.0 * t);
      free[roll] = (k / 50) % 2 == 0;  // frozen and released (as at a limit)
      w[roll] = free[roll] ? model.dof(roll).work_range * model.dof(roll).work_range : 0.0;
      forward_kinematics(model, data, q);
      stack.targets().setZero();
      stack.assemble(model, data);
      solver.solve(stack.jacobian(), stack.task_velocity(), VectorXd::Zero(n), free, 0.001);
      const MatrixXd A = stack.jacobian() * w.asDiagonal() * stack.jacobian().transpose();
      const double exact = Eigen::SelfAdjointEigenSolver<MatrixXd>(A).eigenvalues()[0];
      const double estimate = solver.output().min_singular_value * solver.output().min_singular_value;
      if (k < 3 || exact > 4.0 * eps2) continue;  // three steps from the start; far from the threshold
      ++near;
      ASSERT_GE(estimate, exact - 1e-9 * eps2) << "cycle " << k << ", " << variant;
      ASSERT_LT(std::abs(estimate - exact), 5e-5 * eps2)
          << "cycle " << k << ", " << variant << ": estimate " << estimate << ", eigenvalue " << exact;
    }
    EXPECT_GT(near, steps / 4) << "the sweep must run near the threshold";
  }
}

// Rows scaled to the edges of the double range: A's entries ~1e-300 (the inverse iteration's
// step overflows: its estimate was NaN, and the damping decision was made on it), ~1e-200,
// ~1e150 and beyond the range (A overflows). The cycle gives finite rates and a defined
// estimate of sigma_min; the tiny rows are damped.
TEST(Solver, RowsNearTheEdgeOfTheDoubleRangeGiveFiniteRates) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  Data data(model);
  TaskStack stack(model);
  add_paper_tasks(model, stack);
  forward_kinematics(model, data, model.home());
  stack.assemble(model, data);
  for (const double scale : {1e-150, 1e-100, 1e75, 1e160}) {
    WholeBodySolver solver(model, stack.num_rows());
    const MatrixXd J = scale * stack.jacobian();
    const VectorXd xdot = VectorXd::Constant(stack.num_rows(), 0.01);
    for (int k = 0; k < 3; ++k) {
      const SolverStatus st = solver.solve(J, xdot, VectorXd::Zero(n), Mask::Constant(n, true), 0.001);
      ASSERT_TRUE(solver.output().qdot.allFinite()) << "scale " << scale << ", cycle " << k;
      ASSERT_FALSE(std::isnan(solver.output().min_singular_value)) << "scale " << scale << ", cycle " << k;
      if (scale < 1.0) {
        EXPECT_TRUE(st.has(kDamped)) << "scale " << scale;
      }
    }
  }
}

TEST(Solver, MoreActiveRowsThanFreeDofs) {
  const Model model = make_paper_model();
  Data data(model);
  TaskStack stack(model);
  add_paper_tasks(model, stack);
  WholeBodySolver solver(model, stack.num_rows());
  Mask free = Mask::Constant(model.num_dofs(), false);
  for (int i = 9; i < 14; ++i) free[i] = true;  // only the left arm: 5 dofs for 12 rows
  forward_kinematics(model, data, model.home());
  std::mt19937_64 rng(3);
  randomize_targets(model, data, stack, rng);
  stack.assemble(model, data);
  const SolverStatus st = solver.solve(stack.jacobian(), stack.task_velocity(), VectorXd::Zero(model.num_dofs()), free, 0.001);
  EXPECT_TRUE(st.has(kOverdetermined));
  EXPECT_TRUE(st.has(kDamped));
  EXPECT_TRUE(solver.output().qdot.allFinite());
  for (int i = 0; i < model.num_dofs(); ++i)
    if (!free[i]) { EXPECT_EQ(solver.output().qdot[i], 0.0); }
}

TEST(Solver, InvalidInputsGiveZeroVelocityAndAStatus) {
  const Model model = make_paper_model();
  WholeBodySolver solver(model, 3);
  const int n = model.num_dofs();
  const MatrixXd J = MatrixXd::Ones(3, n);
  const VectorXd xdot = VectorXd::Ones(3);
  const Mask free = Mask::Constant(n, true);
  VectorXd nan_x = xdot;
  nan_x[1] = std::nan("");
  EXPECT_TRUE(solver.solve(J, nan_x, VectorXd::Zero(n), free, 0.001).has(kInvalidInput));
  EXPECT_EQ(solver.output().qdot.norm(), 0.0);
  EXPECT_TRUE(solver.solve(J, xdot, VectorXd::Zero(n), free, std::nan("")).has(kInvalidInput));
  EXPECT_TRUE(solver.solve(J, xdot, VectorXd::Zero(n), free, -1.0).has(kInvalidInput));
  EXPECT_TRUE(solver.solve(J, xdot, VectorXd::Zero(n), Mask::Constant(n - 1, true), 0.001).has(kInvalidInput));
  EXPECT_TRUE(solver.solve(MatrixXd::Ones(4, n), VectorXd::Ones(4), VectorXd::Zero(n), free, 0.001).has(kInvalidInput));
  EXPECT_TRUE(solver.solve(J, xdot, VectorXd::Zero(n), Mask::Constant(n, false), 0.001).has(kAllDofsFrozen));
  EXPECT_EQ(solver.output().qdot.norm(), 0.0);
  const SolverStatus none = solver.solve(MatrixXd::Zero(0, n), VectorXd::Zero(0), VectorXd::Ones(n), free, 0.001);
  EXPECT_TRUE(none.has(kNoActiveRows));
  EXPECT_TRUE(solver.output().qdot.allFinite());
}

TEST(Solver, SpeedScalingAndJerkLimit) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  SolverParameters p;
  p.nullspace_rate_change_limit = 10.0;
  WholeBodySolver solver(model, 1, p);
  const Mask free = Mask::Constant(n, true);
  // A huge task velocity: the task part is scaled to the speed limits.
  MatrixXd J = MatrixXd::Zero(1, n);
  J(0, model.dof_index("l_elbow")) = 1.0;
  SolverStatus st = solver.solve(J, VectorXd::Constant(1, 100.0), VectorXd::Zero(n), free, 0.001);
  EXPECT_TRUE(st.has(kTaskSpeedLimited));
  EXPECT_NEAR(solver.output().qdot[model.dof_index("l_elbow")], model.dof(model.dof_index("l_elbow")).max_speed, 1e-12);
  // A large gradient from rest: the null-space velocity ramps up at the jerk limit.
  solver.reset();
  const VectorXd grad = VectorXd::Constant(n, 50.0);
  const MatrixXd none = MatrixXd::Zero(0, n);
  VectorXd previous = VectorXd::Zero(n);
  for (int k = 0; k < 50; ++k) {
    st = solver.solve(none, VectorXd::Zero(0), grad, free, 0.001);
    const VectorXd& v = solver.output().qdot;
    for (int i = 0; i < n; ++i) {
      ASSERT_LE(std::abs(v[i] - previous[i]), 10.0 * model.dof(i).max_speed * 0.001 * (1 + 1e-9)) << k;
      ASSERT_LE(std::abs(v[i]), model.dof(i).max_speed * (1 + 1e-12));
    }
    previous = v;
  }
  EXPECT_TRUE(st.has(kNullSpaceSpeedScaled) || st.has(kNullSpaceJerkLimited));
}

// Every row a joint row on a dof of its own (all eliminated and isolated, none kept in A):
// each is a block of its own for the speed scaling, so a row driven past its dof's speed
// limit is scaled alone and the others keep their rates. With as many rows as the solver
// holds, the block count is one more than the rows (the kept rows' empty block): the scales
// were written one past the end of a buffer of m entries, which the sanitizer build (CTest
// clang_build_and_unit_tests) reports as a heap overflow.
TEST(Solver, EveryRowIsolatedIsSpeedScaledAlone) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  const char* names[] = {"l_elbow", "r_elbow", "head_pan", "r_hand_rot"};
  constexpr int m = 4;
  WholeBodySolver solver(model, m);
  const Mask free = Mask::Constant(n, true);
  MatrixXd J = MatrixXd::Zero(m, n);
  VectorXd xdot(m);
  for (int i = 0; i < m; ++i) {
    J(i, model.dof_index(names[i])) = 1.0;
    const double vmax = model.dof(model.dof_index(names[i])).max_speed;
    xdot[i] = i % 2 == 0 ? 3.0 * vmax : 0.5 * vmax;  // rows 0 and 2 beyond their limits
  }
  const SolverStatus st = solver.solve(J, xdot, VectorXd::Zero(n), free, 0.001);
  EXPECT_TRUE(st.ok());
  EXPECT_TRUE(st.has(kTaskSpeedLimited));
  for (int i = 0; i < m; ++i) {
    const int d = model.dof_index(names[i]);
    EXPECT_NEAR(solver.output().qdot_task[d], std::min(xdot[i], model.dof(d).max_speed), 1e-12) << names[i];
  }
  EXPECT_NEAR(solver.output().task_scale, 1.0 / 3.0, 1e-12);
}

// Where the task part alone crosses a speed limit it is scaled to it, and the null-space
// part is scaled to fit beside it as anywhere else: q_dot is continuous in the task
// velocity across that point. (Dropping the null space there made q_dot jump by the whole
// null-space motion, and a target out of reach crossed the point again and again: a
// limit cycle at 15-20 Hz, Scenarios.TargetsOutOfReachSettleWithoutChattering.)
TEST(Solver, QdotIsContinuousWhereTheTaskPartReachesASpeedLimit) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  SolverParameters p;
  p.nullspace_rate_change_limit = 0.0;  // the speed rule alone
  WholeBodySolver solver(model, 1, p);
  const Mask free = Mask::Constant(n, true);
  MatrixXd J = MatrixXd::Zero(1, n);
  J(0, model.dof_index("l_elbow")) = 1.0;
  J(0, model.dof_index("l_shoulder_pitch")) = 0.5;
  VectorXd gradient = VectorXd::Zero(n);
  // The null space moves the elbow against the task part (as out of reach, where the
  // joint-limit criterion bends the arm the task stretches) and the shoulder yaw.
  gradient[model.dof_index("l_elbow")] = -2.0;
  gradient[model.dof_index("l_shoulder_yaw")] = -1.0;
  // The task rate at which the task part alone reaches a speed limit.
  solver.solve(J, VectorXd::Constant(1, 1.0), gradient, free, 0.001);
  const VectorXd per_unit = solver.output().qdot_task;
  double crossing = std::numeric_limits<double>::infinity();
  for (int i = 0; i < n; ++i)
    if (per_unit[i] != 0.0) crossing = std::min(crossing, model.max_speeds()[i] / std::abs(per_unit[i]));
  const double null_size = solver.output().qdot_null.cwiseAbs().maxCoeff();
  ASSERT_GT(null_size, 0.1);  // a null-space motion whose loss would show
  const int steps = 400;
  const double step = 0.4 * crossing / steps;  // 0.8 to 1.2 times the crossing
  // Continuous: the change per step stays of the order of the task part's (the null-space
  // scale moves with it where a limit binds), far below the null-space motion a jump drops.
  const double max_change = 10.0 * step * per_unit.cwiseAbs().maxCoeff();
  ASSERT_LT(max_change, 0.1 * null_size);
  VectorXd previous;
  int limited = 0;
  for (int k = 0; k <= steps; ++k) {
    const double xdot = 0.8 * crossing + k * step;
    const SolverStatus st = solver.solve(J, VectorXd::Constant(1, xdot), gradient, free, 0.001);
    const VectorXd& v = solver.output().qdot;
    for (int i = 0; i < n; ++i) ASSERT_LE(std::abs(v[i]), model.max_speeds()[i] * (1 + 1e-12)) << k;
    if (st.has(kTaskSpeedLimited)) {
      ++limited;
      EXPECT_GT(solver.output().qdot_null.cwiseAbs().maxCoeff(), 0.5 * null_size) << "null space dropped, k " << k;
    }
    if (k > 0) {
      ASSERT_LE((v - previous).cwiseAbs().maxCoeff(), max_change)
          << "q_dot jumps at task rate " << xdot << " (the task part reaches a limit at " << crossing << ")";
    }
    previous = v;
  }
  EXPECT_GT(limited, steps / 3);
  EXPECT_LT(limited, 2 * steps / 3);
}

// A dof at its limit is frozen while the solution would drive it further out and released
// where its free rate turns inwards; q_dot is continuous there (the rate crosses zero), also
// with the jerk limit on. Before, the jerk limit compared the new split of q_dot into task
// and null-space parts (the dof's null-space rate appears at once) with the last cycle's,
// scaled the whole null space down and drove the dof back into the clamp: out of reach with
// crossed arms that repeated every 20 ms (G1 23-dof, 4,000 rad/s^2).
TEST(Solver, QdotIsContinuousWhereADofIsReleasedFromItsLimit) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  const double dt = 0.001;
  WholeBodySolver solver(model, 1);
  ASSERT_GT(solver.parameters().nullspace_rate_change_limit, 0.0);  // the jerk limit is on
  const Mask free = Mask::Constant(n, true);
  const int elbow = model.dof_index("l_elbow");
  VectorXd q = model.home();
  q[elbow] = model.lower_limits()[elbow];
  MatrixXd J = MatrixXd::Zero(1, n);
  J(0, elbow) = 1.0;
  J(0, model.dof_index("l_shoulder_pitch")) = 0.5;
  // The null space pushes the elbow off its lower limit and also moves the shoulder yaw;
  // a negative task rate drives the elbow into the limit.
  VectorXd gradient = VectorXd::Zero(n);
  gradient[elbow] = -0.5;
  gradient[model.dof_index("l_shoulder_yaw")] = 0.25;
  // The parts per unit task rate, with the elbow free and frozen (a solver without the jerk
  // and speed limits: the first solve's null space is not yet ramped up).
  SolverParameters unlimited;
  unlimited.nullspace_rate_change_limit = 0.0;
  unlimited.limit_speeds = false;
  WholeBodySolver probe(model, 1, unlimited);
  probe.solve(J, VectorXd::Constant(1, 1.0), gradient, free, dt);  // no q: nothing frozen
  const VectorXd per_unit = probe.output().qdot_task;
  const double null_elbow = probe.output().qdot_null[elbow];
  ASSERT_GT(null_elbow, 0.05);
  ASSERT_GT(per_unit[elbow], 0.0);
  const double crossing = -null_elbow / per_unit[elbow];  // the task rate where the free elbow rate is 0
  Mask elbow_frozen = free;
  elbow_frozen[elbow] = false;
  probe.solve(J, VectorXd::Constant(1, 1.0), gradient, elbow_frozen, dt);
  const double sensitivity = std::max(per_unit.cwiseAbs().maxCoeff(), probe.output().qdot_task.cwiseAbs().maxCoeff());
  const int steps = 400;
  const double step = 0.4 * std::abs(crossing) / steps;  // 1.2 to 0.8 times the crossing
  const double max_change = 10.0 * step * sensitivity;
  ASSERT_LT(max_change, 0.1 * null_elbow);
  for (int k = 0; k < 200; ++k) solver.solve(J, VectorXd::Constant(1, 1.2 * crossing), gradient, free, dt, &q);
  VectorXd previous = solver.output().qdot;
  int frozen = 0;
  for (int k = 1; k <= steps; ++k) {
    const double xdot = 1.2 * crossing - k * (0.4 * crossing / steps);
    const SolverStatus st = solver.solve(J, VectorXd::Constant(1, xdot), gradient, free, dt, &q);
    ASSERT_FALSE(st.has(kTaskSpeedLimited) || st.has(kNullSpaceSpeedScaled)) << k;  // the jerk limit alone
    const VectorXd& v = solver.output().qdot;
    if (st.has(kDofAtLimitFrozen)) {
      ++frozen;
      EXPECT_EQ(v[elbow], 0.0) << k;
    } else {
      EXPECT_GE(v[elbow], 0.0) << "released into the limit at task rate " << xdot << ", k " << k;
    }
    ASSERT_LE((v - previous).cwiseAbs().maxCoeff(), max_change)
        << "q_dot jumps at task rate " << xdot << " (the elbow is released at " << crossing << "), k " << k
        << (st.has(kNullSpaceJerkLimited) ? ", jerk-limited" : "");
    previous = v;
  }
  EXPECT_GT(frozen, steps / 3);  // frozen first, released later
  EXPECT_LT(frozen, 2 * steps / 3);
}

// Near a singularity the damping is raised (x4 per overshoot, kDampingRaised) where q_dot
// turns back between two solves under an unchanged command, in proportion to the command's
// speed against that at the raise, and returns to that of sigma_min after an undamped solve. A command that turns, or a new row count, raises
// nothing. One row through the elbow with a coefficient +-s below the threshold stands in
// for a configuration that crosses the singularity every cycle.
TEST(Solver, DampingIsRaisedWhereQdotTurnsBackUnderTheSameCommand) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  const int elbow = model.dof_index("l_elbow");
  const double range = model.dof(elbow).work_range;
  WholeBodySolver solver(model, 2);
  const Mask free = Mask::Constant(n, true);
  const VectorXd gradient = VectorXd::Zero(n);
  const double s = 0.25 * solver.parameters().singular_threshold / range;  // sigma_min = eps / 4
  auto row = [&](double coefficient) {
    MatrixXd J = MatrixXd::Zero(1, n);
    J(0, elbow) = coefficient;
    return J;
  };
  const VectorXd xdot = VectorXd::Constant(1, 1.0);
  const double max2 = solver.parameters().max_damping * solver.parameters().max_damping;
  const double base = max2 * (1.0 - 1.0 / 16.0);  // lambda^2 of sigma_min alone
  SolverStatus st = solver.solve(row(s), xdot, gradient, free, 0.001);
  ASSERT_TRUE(st.has(kDamped));
  EXPECT_FALSE(st.has(kDampingRaised));
  EXPECT_NEAR(solver.output().damping, std::sqrt(base), 1e-9);
  // The same command, the configuration across the singularity: q_dot turns back.
  st = solver.solve(row(-s), xdot, gradient, free, 0.001);
  EXPECT_FALSE(st.has(kDampingRaised));  // raised from the next solve on
  st = solver.solve(row(s), xdot, gradient, free, 0.001);
  EXPECT_TRUE(st.has(kDampingRaised));
  EXPECT_NEAR(solver.output().damping, std::sqrt(4.0 * base), 1e-9);
  // Raised again at each further turn of a comparable size (after a raise q_dot shrinks,
  // so every other turn), up to the bound.
  for (int k = 0; k < 40; ++k) solver.solve(row(k % 2 ? s : -s), xdot, gradient, free, 0.001);
  EXPECT_NEAR(solver.output().damping, std::sqrt(WholeBodySolver::kMaxDampingFactor * base), 1e-9);
  EXPECT_TRUE(std::isfinite(solver.output().qdot[elbow]));
  // A slower command needs less (the overshoot grows with |x_dot|): a quarter of the rate,
  // a quarter of the raise; at 1/512 of it, none.
  st = solver.solve(row(s), VectorXd(0.25 * xdot), gradient, free, 0.001);
  EXPECT_TRUE(st.has(kDampingRaised));
  EXPECT_NEAR(solver.output().damping, std::sqrt(WholeBodySolver::kMaxDampingFactor / 4.0 * base), 1e-9);
  st = solver.solve(row(s), VectorXd(xdot / 512.0), gradient, free, 0.001);
  EXPECT_FALSE(st.has(kDampingRaised));
  EXPECT_NEAR(solver.output().damping, std::sqrt(base), 1e-9);
  st = solver.solve(row(s), xdot, gradient, free, 0.001);  // as fast again: the whole raise
  EXPECT_NEAR(solver.output().damping, std::sqrt(WholeBodySolver::kMaxDampingFactor * base), 1e-9);
  // An undamped solve resets it.
  st = solver.solve(row(1.0), xdot, gradient, free, 0.001);
  EXPECT_FALSE(st.has(kDamped) || st.has(kDampingRaised));
  st = solver.solve(row(s), xdot, gradient, free, 0.001);
  EXPECT_FALSE(st.has(kDampingRaised));
  EXPECT_NEAR(solver.output().damping, std::sqrt(base), 1e-9);
  // q_dot turns back because the command did: nothing raised.
  for (int k = 1; k <= 4; ++k) {
    st = solver.solve(row(s), k % 2 ? VectorXd(-xdot) : xdot, gradient, free, 0.001);
    EXPECT_FALSE(st.has(kDampingRaised)) << k;
  }
  // Nor across a change of the row count (a task switched on or off).
  MatrixXd two = MatrixXd::Zero(2, n);
  two(0, elbow) = -s;
  two(1, model.dof_index("head_pan")) = 1.0;
  solver.solve(two, Eigen::Vector2d(1.0, 0.0), gradient, free, 0.001);
  st = solver.solve(row(s), xdot, gradient, free, 0.001);
  EXPECT_FALSE(st.has(kDampingRaised));
  // reset() forgets a raised damping.
  for (int k = 0; k < 4; ++k) solver.solve(row(k % 2 ? s : -s), xdot, gradient, free, 0.001);
  ASSERT_GT(solver.output().damping, std::sqrt(base) * 1.5);
  solver.reset();
  st = solver.solve(row(s), xdot, gradient, free, 0.001);
  EXPECT_FALSE(st.has(kDampingRaised));
  EXPECT_NEAR(solver.output().damping, std::sqrt(base), 1e-9);
}

// Error clamping: an element's feedback term gain * e, over its active rows, is scaled to
// feedback_limit() where its norm exceeds it (direction kept); the errors themselves, and
// the feed-forward rate, are untouched. A controller sets the limit to the filter's speed.
// What the stack starts an element with and how it switches one: a direction element's
// target is the unit z (a zero direction is no target), others zero; switching an element
// switches all its rows; the rows of an element switched off have zero error, not the last
// one it had.
TEST(TaskStack, ElementsStartWithValidTargetsAndSwitchAllTheirRows) {
  const Model model = make_paper_model();
  Data data(model);
  forward_kinematics(model, data, model.home());
  TaskStack stack(model);
  add_paper_tasks(model, stack);  // l_hand, l_grasp, r_hand, r_grasp, view
  const int l_hand = stack.element_index("l_hand"), l_grasp = stack.element_index("l_grasp");
  const int view = stack.element_index("view");
  EXPECT_EQ(Vector3(stack.targets().segment<3>(stack.target_offset(l_hand))), Vector3::Zero());
  EXPECT_EQ(Vector3(stack.targets().segment<3>(stack.target_offset(l_grasp))), Vector3::UnitZ());
  EXPECT_EQ(Vector3(stack.targets().segment<3>(stack.target_offset(view))), Vector3::UnitZ());
  EXPECT_TRUE(stack.activation().all());
  stack.set_element_active(l_hand, false);
  for (int r = 0; r < 3; ++r) EXPECT_FALSE(stack.activation()[stack.row_offset(l_hand) + r]) << r;
  EXPECT_FALSE(stack.element_active(l_hand));
  EXPECT_EQ(stack.activation().count(), stack.num_rows() - 3);
  stack.set_element_active(l_hand, true);
  EXPECT_TRUE(stack.activation().all());
  // Errors: the hand 0.1 m from its target, then switched off.
  VectorXd x(stack.num_targets());
  stack.values(model, data, x);
  stack.targets() = x;
  stack.targets()[stack.target_offset(l_hand)] += 0.1;
  stack.assemble(model, data);
  EXPECT_NEAR(stack.errors()[stack.row_offset(l_hand)], 0.1, 1e-12);
  stack.set_element_active(l_hand, false);
  stack.assemble(model, data);
  EXPECT_EQ(Vector3(stack.errors().segment<3>(stack.row_offset(l_hand))), Vector3::Zero());
}

TEST(TaskStack, FeedbackTermIsBoundedByTheElementsLimit) {
  const Model model = make_paper_model();
  Data data(model);
  forward_kinematics(model, data, model.home());
  TaskStack stack(model);
  add_paper_tasks(model, stack);  // l_hand, l_grasp, r_hand, r_grasp, view
  EXPECT_EQ(stack.feedback_limit(0), std::numeric_limits<double>::infinity());
  VectorXd x(stack.num_targets());
  stack.values(model, data, x);
  const int l_hand = stack.element_index("l_hand"), r_hand = stack.element_index("r_hand");
  stack.targets() = x;
  stack.targets().segment<3>(stack.target_offset(l_hand)) += Vector3(0.3, 0.0, 0.4);  // 0.5 m away
  stack.targets().segment<3>(stack.target_offset(r_hand)) += Vector3(0.0, 0.002, 0.0);  // 2 mm away
  stack.target_rates().setZero();
  stack.target_rates()[stack.target_offset(l_hand)] = 0.1;  // feed-forward, not bounded
  stack.element(l_hand).set_gain(10.0);
  stack.set_feedback_limit(l_hand, 0.4);
  stack.set_feedback_limit(r_hand, 0.4);
  ASSERT_EQ(stack.assemble(model, data), stack.num_rows());
  const Eigen::Vector3d l_rows = stack.task_velocity().segment<3>(stack.row_offset(l_hand));
  const Eigen::Vector3d l_error = stack.errors().segment<3>(stack.row_offset(l_hand));
  EXPECT_NEAR(l_error.norm(), 0.5, 1e-12);  // the error is reported unclamped
  EXPECT_LT((l_rows - Vector3(0.1, 0.0, 0.0) - 0.4 * l_error.normalized()).norm(), 1e-12) << l_rows.transpose();
  const Eigen::Vector3d r_rows = stack.task_velocity().segment<3>(stack.row_offset(r_hand));
  EXPECT_LT((r_rows - 10.0 * Vector3(0.0, 0.002, 0.0)).norm(), 1e-12);  // below the limit: gain * e
  // Only the active rows count: z alone (0.4 m) gives 0.4 m/s in z.
  stack.activation().segment(stack.row_offset(l_hand), 2).setConstant(false);
  const int m = stack.assemble(model, data);
  EXPECT_NEAR(stack.task_velocity()[0], 0.4, 1e-12);
  EXPECT_EQ(m, stack.num_rows() - 2);
  // Without a limit, gain * e as before.
  stack.set_feedback_limit(l_hand, std::numeric_limits<double>::infinity());
  stack.assemble(model, data);
  EXPECT_NEAR(stack.task_velocity()[0], 10.0 * 0.4, 1e-12);
  for (const double bad : {0.0, -1.0, std::nan("")}) EXPECT_THROW(stack.set_feedback_limit(l_hand, bad), ConfigError);
  EXPECT_THROW(stack.set_feedback_limit(99, 1.0), std::out_of_range);
  // A controller bounds each element's feedback by its filter's speed.
  Controller controller(model);
  FilterParameters filter;
  filter.max_speed = 0.25;
  const int hand = controller.add_task(std::make_unique<PositionTask>(model, "hand", "l_hand_ref"), filter);
  EXPECT_EQ(controller.tasks().feedback_limit(hand), 0.25);
  controller.tasks().set_feedback_limit(hand, std::numeric_limits<double>::infinity());  // no bound
  EXPECT_EQ(controller.tasks().feedback_limit(hand), std::numeric_limits<double>::infinity());
}

TEST(Controller, ConfigurationErrorsThrow) {
  const Model model = make_paper_model();
  EXPECT_THROW(PositionTask(model, "x", "no_such_frame"), ModelError);
  EXPECT_THROW(AxisTask(model, "x", "l_hand_ref", "no_such_reference"), ModelError);
  EXPECT_THROW(JointTask(model, "x", {"no_such_dof"}), ModelError);
  EXPECT_THROW(JointTask(model, "x", {}), ConfigError);
  EXPECT_THROW(JointTask(model, "x", {"l_elbow", "head_pan", "l_elbow"}), ConfigError);  // two equal rows
  PositionTask task(model, "x", "l_hand_ref");
  EXPECT_THROW(task.set_gain(-1.0), ConfigError);
  EXPECT_THROW(task.set_gain(std::nan("")), ConfigError);
  // A target period (angles) must be finite and >= 0; attitude targets have 2 pi.
  struct Periodic : TaskElement {
    explicit Periodic(double period) : TaskElement("p", 1, 1, TargetKind::kVector, period) {}
    void value(const Model&, const Data&, Eigen::Ref<Eigen::VectorXd>) override {}
    void evaluate(const Model&, const Data&, const Eigen::Ref<const Eigen::VectorXd>&,
                  const Eigen::Ref<const Eigen::VectorXd>&, Eigen::Ref<Eigen::MatrixXd>, Eigen::Ref<Eigen::VectorXd>,
                  Eigen::Ref<Eigen::VectorXd>) override {}
  };
  EXPECT_THROW(Periodic{-1.0}, ConfigError);
  EXPECT_THROW(Periodic{std::numeric_limits<double>::infinity()}, ConfigError);  // braces: not a declaration
  EXPECT_EQ(Periodic(0.5).target_period(), 0.5);
  EXPECT_EQ(task.target_period(), 0.0);
  EXPECT_EQ(AttitudeTask(model, "a", "l_hand_ref").target_period(), 2 * M_PI);
  SolverParameters bad;
  bad.max_damping = -1.0;
  EXPECT_THROW(Controller(model, bad), ConfigError);
  EXPECT_THROW(CubicJointLimitCriterion(model, 1.0), ConfigError);
  EXPECT_THROW(JointCenterCriterion(model, VectorXd::Ones(3)), ConfigError);
  for (const double bad_weight : {-1e-9, std::nan("")}) {
    VectorXd weights = VectorXd::Ones(model.num_dofs());
    weights[12] = bad_weight;
    EXPECT_THROW(JointCenterCriterion(model, weights), ConfigError) << bad_weight;
    EXPECT_THROW(CubicJointLimitCriterion(model, 0.5, weights), ConfigError) << bad_weight;
  }
  // A row unit is set for a row of the element only.
  struct TwoRows : TaskElement {
    explicit TwoRows(int row) : TaskElement("two", 2, 2, TargetKind::kVector) { set_row_unit(row, RowUnit::kAngle); }
    void value(const Model&, const Data&, Eigen::Ref<Eigen::VectorXd>) override {}
    void evaluate(const Model&, const Data&, const Eigen::Ref<const Eigen::VectorXd>&,
                  const Eigen::Ref<const Eigen::VectorXd>&, Eigen::Ref<Eigen::MatrixXd>, Eigen::Ref<Eigen::VectorXd>,
                  Eigen::Ref<Eigen::VectorXd>) override {}
  };
  EXPECT_THROW(TwoRows{2}, ConfigError);
  EXPECT_THROW(TwoRows{-1}, ConfigError);
  EXPECT_EQ(TwoRows{1}.row_unit(1), RowUnit::kAngle);
  // A centre-of-mass task needs mass.
  ModelBuilder massless("massless");
  Dof dof;
  dof.name = "j";
  dof.lower = -1.0;
  dof.upper = 1.0;
  dof.max_speed = 1.0;
  Body link;
  link.name = "link";
  link.dof = massless.add_dof(dof);
  massless.add_body(link);
  const Model no_mass = massless.build();
  try {
    CenterOfMassTask(no_mass, "com");
    ADD_FAILURE() << "a centre-of-mass task on a model without mass";
  } catch (const ModelError& e) {
    EXPECT_NE(std::string(e.what()).find("centre-of-mass task 'com': the model has no mass"), std::string::npos)
        << e.what();
  }
  Controller c(model);
  c.add_task(std::make_unique<PositionTask>(model, "a", "l_hand_ref"));
  EXPECT_THROW(c.add_task(std::make_unique<PositionTask>(model, "a", "r_hand_ref")), ConfigError);
  FilterParameters f;
  f.max_speed = 0.0;
  EXPECT_THROW(c.add_task(std::make_unique<PositionTask>(model, "b", "r_hand_ref"), f), ConfigError);
  VectorXd q = model.home();
  q[3] = 10.0;
  EXPECT_THROW(c.reset(q), ModelError);
}

TEST(Controller, BadCommandsHaveDefinedResults) {
  const Model model = make_paper_model();
  Controller c(model);
  c.add_task(std::make_unique<PositionTask>(model, "l_hand", "l_hand_ref"));
  c.add_task(std::make_unique<AxisTask>(model, "view", "head_camera"));
  c.reset(model.home());
  Command cmd = c.make_command();
  // NaN target of an active element: flagged, the element keeps its previous target.
  cmd.targets[0] = std::nan("");
  ControllerStatus st = c.update(cmd, 0.001);
  EXPECT_TRUE(st.has(kInvalidTarget));
  EXPECT_TRUE(c.q().allFinite());
  // Infinite and zero-direction targets likewise.
  cmd.targets[0] = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(c.update(cmd, 0.001).has(kInvalidTarget));
  cmd.targets = c.values();
  cmd.targets.segment<3>(3).setZero();
  EXPECT_TRUE(c.update(cmd, 0.001).has(kInvalidTarget));
  // A NaN at any entry (the last one of a 3-vector too) is found.
  for (int i = 0; i < cmd.targets.size(); ++i) {
    cmd.targets = c.values();
    cmd.targets[i] = std::nan("");
    EXPECT_TRUE(c.update(cmd, 0.001).has(kInvalidTarget)) << "entry " << i;
    EXPECT_TRUE(c.q().allFinite()) << "entry " << i;
  }
  cmd.targets = c.values();
  // Bad dt: nothing moves.
  const VectorXd q1 = c.q();
  for (double dt : {0.0, -0.001, std::nan(""), std::numeric_limits<double>::infinity()}) {
    st = c.update(cmd, dt);
    EXPECT_TRUE(st.has(kInvalidCommand)) << dt;
    EXPECT_EQ(c.q(), q1);
  }
  // Activation vector of the wrong length.
  Command wrong = cmd;
  wrong.task_active = Mask::Constant(4, true);
  EXPECT_TRUE(c.update(wrong, 0.001).has(kInvalidCommand));
  EXPECT_EQ(c.q(), q1);
  // An element added past the controller (tasks().add()) would have no trajectory filter
  // (the next cycle indexed past the filters): refused at setup, before or after reset(),
  // and the controller still runs with what it has.
  Controller grown(model);
  grown.add_task(std::make_unique<PositionTask>(model, "r_hand", "r_hand_ref"));
  for (int after_reset = 0; after_reset < 2; ++after_reset) {
    if (after_reset) grown.reset(model.home());
    try {
      grown.tasks().add(std::make_unique<PositionTask>(model, "l_hand", "l_hand_ref"));
      ADD_FAILURE() << "tasks().add() accepted an element without a filter";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("element 'l_hand' added to a controller's stack with tasks().add()"),
                std::string::npos)
          << e.what();
    }
  }
  EXPECT_EQ(grown.tasks().num_elements(), 1);
  EXPECT_TRUE(grown.update(grown.make_command(), 0.001).ok());
  // All dofs frozen: nothing moves, and the status says so.
  Command frozen = cmd;
  frozen.free_dofs.setConstant(false);
  frozen.targets[2] += 0.1;
  EXPECT_TRUE(c.update(frozen, 0.001).has(kAllDofsFrozen));
  EXPECT_EQ(c.q(), q1);
  // No active rows: only null-space motion, flagged.
  Command idle = cmd;
  idle.task_active.setConstant(false);
  EXPECT_TRUE(c.update(idle, 0.001).has(kNoActiveRows));
  // Unreachable target (20 m up): bounded, within limits, no NaN.
  Command far = cmd;
  far.targets[2] = 20.0;
  for (int k = 0; k < 2000; ++k) {
    st = c.update(far, 0.001);
    ASSERT_TRUE(c.q().allFinite());
  }
  EXPECT_TRUE(st.ok());
  for (int i = 0; i < model.num_dofs(); ++i) {
    EXPECT_GE(c.q()[i], model.dof(i).lower);
    EXPECT_LE(c.q()[i], model.dof(i).upper);
  }
}

INSTANTIATE_TEST_SUITE_P(Models, EveryModel, testing::ValuesIn(wbm_test::shipped_models()), wbm_test::ModelIdName());

}  // namespace
