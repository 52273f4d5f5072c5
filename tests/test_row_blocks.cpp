// Independent blocks of task rows (no free dof in common, e.g. the two arms of a robot on a
// fixed base): each block is damped by its own smallest singular value and scaled to the
// speed limits on its own (docs/solver.md, "Independent blocks of rows"). Seeded random
// problems whose rows fall into two to four blocks over disjoint sets of dofs, in shuffled
// row order, some blocks near-singular or overdetermined, some with isolated joint rows.
// WBM_PROPERTY_CASES=<n> runs n cases per property instead of 10^4.
#include <algorithm>
#include <numeric>
#include <random>
#include <sstream>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "alloc_counter.hpp"
#include "test_util.hpp"
#include "wbm/paper_model.hpp"
#include "wbm/solver.hpp"

#include "row_blocks.hpp"  // internal (src/)
#include "unit_row_elimination.hpp"

namespace {

using namespace wbm;
using Eigen::MatrixXd;
using Eigen::VectorXd;

using wbm_test::property_cases;

struct BlockProblem {
  MatrixXd J;
  VectorXd xdot, gradient;
  Mask free;
  std::vector<int> block;  // per row
  int blocks = 0;
  std::string describe() const {
    std::ostringstream out;
    out.precision(17);
    out << "J =\n" << J << "\nxdot = [" << xdot.transpose() << "]\nblocks = [";
    for (int b : block) out << " " << b;
    out << " ]";
    return out.str();
  }
};

/// Two to four blocks of rows over disjoint random sets of dofs (some dofs in none). A block
/// is dense over its dofs; one in three near-singular (a row repeated with a small change)
/// and one in six has more rows than dofs. Rows shuffled.
BlockProblem random_blocks(int n, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> normal;
  BlockProblem p;
  p.blocks = 2 + static_cast<int>(u(rng) * 3.0);
  std::vector<int> dofs(n);
  std::iota(dofs.begin(), dofs.end(), 0);
  std::shuffle(dofs.begin(), dofs.end(), rng);
  std::vector<std::vector<double>> rows;
  int next = 0;
  for (int b = 0; b < p.blocks; ++b) {
    const int size = 1 + static_cast<int>(u(rng) * std::min(6, (n - next) / (p.blocks - b)));
    const std::vector<int> mine(dofs.begin() + next, dofs.begin() + next + size);
    next += size;
    int count = 1 + static_cast<int>(u(rng) * size);
    const double kind = u(rng);
    if (kind < 1.0 / 6.0) count = size + 1;  // overdetermined
    std::vector<double> first;
    for (int r = 0; r < count; ++r) {
      std::vector<double> row(n, 0.0);
      for (int d : mine) row[d] = normal(rng);
      if (r == 1 && kind > 2.0 / 3.0)  // near-singular: the first row again, slightly changed
        for (int d : mine) row[d] = first[d] + 1e-3 * normal(rng);
      if (r == 0) first = row;
      rows.push_back(row);
      p.block.push_back(b);
    }
  }
  std::vector<int> order(rows.size());
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  p.J = MatrixXd::Zero(static_cast<int>(rows.size()), n);
  std::vector<int> block(rows.size());
  for (size_t i = 0; i < order.size(); ++i) {
    for (int d = 0; d < n; ++d) p.J(static_cast<int>(i), d) = rows[order[i]][d];
    block[i] = p.block[order[i]];
  }
  p.block = block;
  p.xdot = VectorXd::Zero(p.J.rows());
  for (int i = 0; i < p.J.rows(); ++i) p.xdot[i] = normal(rng);
  p.gradient = VectorXd::Zero(n);
  for (int i = 0; i < n; ++i) p.gradient[i] = normal(rng);
  p.free = Mask::Constant(n, true);
  return p;
}

using wbm_test::raw_parameters;

// The blocks found from A directly, and whether they are the previous call's: the solver
// restarts its per-block iteration when they are not (same count, labels and row count).
TEST(RowBlocks, TheBlocksAndWhetherTheyChangedSinceTheLastCall) {
  const internal::UnitRowElimination none(6, 8);  // no eliminated rows
  internal::RowBlocks blocks(8);
  // Lower triangles, column-major: `coupled` couples every row, `pairs` rows 0-2 and 1-3,
  // `other_pairs` rows 0-3 and 1-2.
  const MatrixXd coupled = MatrixXd::Constant(4, 4, 0.5);
  MatrixXd pairs = MatrixXd::Identity(4, 4), other_pairs = pairs;
  pairs(2, 0) = pairs(3, 1) = 0.5;
  other_pairs(3, 0) = other_pairs(2, 1) = 0.5;
  auto find = [&](const MatrixXd& A, int rows) { return blocks.find(A.data(), A.outerStride(), rows, none); };
  EXPECT_EQ(find(coupled, 3), 1);
  EXPECT_FALSE(blocks.unchanged());  // the first call
  EXPECT_EQ(find(coupled, 3), 1);
  EXPECT_TRUE(blocks.unchanged());
  EXPECT_EQ(find(coupled, 4), 1);
  EXPECT_FALSE(blocks.unchanged()) << "one block, but of four rows, not three";
  EXPECT_EQ(find(pairs, 4), 2);
  EXPECT_FALSE(blocks.unchanged());
  EXPECT_EQ(blocks.block(0), 0);
  EXPECT_EQ(blocks.block(1), 1);
  EXPECT_EQ(blocks.block(2), 0);
  EXPECT_EQ(blocks.block(3), 1);
  EXPECT_EQ(find(pairs, 4), 2);
  EXPECT_TRUE(blocks.unchanged());
  EXPECT_EQ(find(other_pairs, 4), 2);
  EXPECT_FALSE(blocks.unchanged()) << "two blocks, but other rows in them";
  EXPECT_EQ(blocks.block(2), 1);
  EXPECT_EQ(blocks.block(3), 0);
  EXPECT_EQ(find(coupled, 4), 1);
  EXPECT_FALSE(blocks.unchanged()) << "one block after two";
  EXPECT_EQ(find(coupled, 4), 1);
  EXPECT_TRUE(blocks.unchanged());
}

// Each block is damped by its own sigma_min: rows of one block share one lambda, which is
// the rule's for that block's smallest singular value (an SVD of the block alone); the
// solution is the plain formula's with each row's lambda; an undamped block is met exactly
// while another is damped.
TEST(RowBlocks, EachBlockIsDampedByItsOwnSmallestSingularValue) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  WholeBodySolver solver(model, 40, raw_parameters());
  const double eps = solver.parameters().singular_threshold, max_damping = solver.parameters().max_damping;
  std::mt19937_64 rng(20261202);
  int exact_beside_damped = 0, compared_with_svd = 0;
  for (int c = 0; c < property_cases(); ++c) {
    const BlockProblem p = random_blocks(n, rng);
    const int m = static_cast<int>(p.J.rows());
    solver.reset();
    SolverStatus st = solver.solve(p.J, p.xdot, p.gradient, p.free, 0.001);
    const wbm_test::AllocationCounter counter;  // the block path allocates nothing either
    for (int k = 1; k < 30; ++k) st = solver.solve(p.J, p.xdot, p.gradient, p.free, 0.001);
    ASSERT_EQ(counter.count(), 0) << p.describe();
    ASSERT_TRUE(st.ok()) << p.describe();
    const SolverOutput& out = solver.output();
    VectorXd range(n);
    for (int i = 0; i < n; ++i) range[i] = model.dof(i).work_range;
    std::vector<bool> damped(p.blocks, false);
    for (int b = 0; b < p.blocks; ++b) {
      std::vector<int> rows;
      for (int i = 0; i < m; ++i)
        if (p.block[i] == b) rows.push_back(i);
      for (int i : rows) ASSERT_EQ(out.row_damping[i], out.row_damping[rows[0]]) << "block " << b << "\n" << p.describe();
      const double lambda = out.row_damping[rows[0]];
      damped[b] = lambda > 0.0;
      // The block alone: its smallest singular value (zero if it has more rows than dofs).
      MatrixXd Jb(rows.size(), n);
      for (size_t k = 0; k < rows.size(); ++k) Jb.row(k) = p.J.row(rows[k]);
      const Eigen::JacobiSVD<MatrixXd> svd(Jb * range.asDiagonal());
      const VectorXd sv = svd.singularValues();
      const double sigma = static_cast<int>(rows.size()) > static_cast<int>((Jb.array() != 0.0).colwise().any().count())
                               ? 0.0
                               : sv[sv.size() - 1];
      const double gap = sv.size() > 1 ? sv[sv.size() - 2] - sigma : 1.0;
      if (sigma > 1e-3 && gap < 0.05 * sigma) continue;  // slow convergence of the iteration
      const double expected = sigma < eps ? max_damping * std::sqrt(1.0 - sigma * sigma / (eps * eps)) : 0.0;
      ASSERT_NEAR(lambda, expected, 1e-6 * max_damping) << "block " << b << ", sigma_min " << sigma << "\n" << p.describe();
      ++compared_with_svd;
    }
    // The plain formulas with each row's lambda.
    VectorXd w(n);
    for (int i = 0; i < n; ++i) w[i] = range[i] * range[i];
    const MatrixXd JW = p.J * w.asDiagonal();
    const MatrixXd A = JW * p.J.transpose() + MatrixXd(out.row_damping.head(m).cwiseAbs2().asDiagonal());
    const Eigen::LDLT<MatrixXd> ldlt(A);
    const VectorXd task = JW.transpose() * ldlt.solve(p.xdot);
    const double scale = 1.0 + task.norm();
    ASSERT_LT((out.qdot_task - task).norm(), 1e-8 * scale) << p.describe();
    // Undamped blocks exact, also beside damped ones.
    const VectorXd achieved = p.J * out.qdot_task;
    for (int i = 0; i < m; ++i)
      if (!damped[p.block[i]]) {
        ASSERT_NEAR(achieved[i], p.xdot[i], 1e-9 * scale) << "row " << i << "\n" << p.describe();
      }
    if (std::count(damped.begin(), damped.end(), true) > 0 && std::count(damped.begin(), damped.end(), false) > 0)
      ++exact_beside_damped;
  }
  EXPECT_GT(exact_beside_damped, property_cases() / 10);
  EXPECT_GT(compared_with_svd, property_cases());
}

// Each block's task part is scaled to the speed limits on its own: a block within the
// limits keeps its unscaled rates while another is slowed to them.
TEST(RowBlocks, EachBlockIsScaledToTheSpeedLimitsOnItsOwn) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  SolverParameters limited = raw_parameters();
  limited.limit_speeds = true;
  WholeBodySolver solver(model, 40, limited), raw(model, 40, raw_parameters());
  std::mt19937_64 rng(1202);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int unscaled_beside_scaled = 0;
  for (int c = 0; c < property_cases(); ++c) {
    BlockProblem p = random_blocks(n, rng);
    const int m = static_cast<int>(p.J.rows());
    for (int i = 0; i < m; ++i) p.xdot[i] *= 0.1 + 20.0 * u(rng) * u(rng);  // some blocks beyond the limits
    solver.reset();
    raw.reset();
    for (int k = 0; k < 3; ++k) {
      solver.solve(p.J, p.xdot, p.gradient, p.free, 0.001);
      raw.solve(p.J, p.xdot, p.gradient, p.free, 0.001);
    }
    const VectorXd& unscaled = raw.output().qdot_task;
    const VectorXd& scaled = solver.output().qdot_task;
    // Per block: the factor its dofs were scaled by, the same for all of them, and 1 unless
    // one of them would exceed its limit.
    std::vector<int> dof_block(n, -1);
    for (int i = 0; i < m; ++i)
      for (int d = 0; d < n; ++d)
        if (p.J(i, d) != 0.0) dof_block[d] = p.block[i];
    int scaled_blocks = 0, unscaled_blocks = 0;
    for (int b = 0; b < p.blocks; ++b) {
      double factor = 1.0;
      for (int d = 0; d < n; ++d)
        if (dof_block[d] == b && std::abs(unscaled[d]) > model.max_speeds()[d])
          factor = std::min(factor, model.max_speeds()[d] / std::abs(unscaled[d]));
      for (int d = 0; d < n; ++d)
        if (dof_block[d] == b) {
          ASSERT_NEAR(scaled[d], factor * unscaled[d], 1e-12 * (1.0 + std::abs(unscaled[d])))
              << "dof " << d << " of block " << b << "\n" << p.describe();
        }
      (factor < 1.0 ? scaled_blocks : unscaled_blocks) += 1;
    }
    unscaled_beside_scaled += scaled_blocks > 0 && unscaled_blocks > 0;
  }
  EXPECT_GT(unscaled_beside_scaled, property_cases() / 10);
}

}  // namespace
