// The solver's exact elimination of rows on a single free dof (joint rows,
// src/unit_row_elimination.hpp): seeded random Jacobians that mix dense rows, sparse rows
// and unit rows (scaled, on frozen dofs, two on one dof, placed anywhere), checked against
// the plain formulas of eq. (5)-(7) with Eigen, the smallest singular value against an SVD,
// and a solver that reuses the previous cycle's rows against a fresh one. Isolated unit rows
// (on a dof no other row touches) are damped by their own singular value alone.
// WBM_PROPERTY_CASES=<n> runs n cases per property instead of 10^4.
#include <limits>
#include <random>
#include <sstream>
#include <utility>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "shipped_models.hpp"
#include "test_util.hpp"
#include "wbm/paper_model.hpp"
#include "wbm/solver.hpp"

namespace {

using namespace wbm;
using Eigen::MatrixXd;
using Eigen::VectorXd;

using wbm_test::property_cases;

struct Problem {
  MatrixXd J;
  VectorXd xdot, gradient;
  Mask free;
  std::string describe() const {
    std::ostringstream out;
    out.precision(17);
    out << "J =\n" << J << "\nxdot = [" << xdot.transpose() << "]\ngradient = [" << gradient.transpose()
        << "]\nfree = [" << free.cast<int>().transpose() << "]";
    return out.str();
  }
};

/// m rows over n dofs: dense rows, rows with zeros, and unit rows (value 1 or a random
/// scale, one in twenty below the singular threshold) on random dofs, some of them frozen
/// or shared by two unit rows.
Problem random_problem(int n, int m, std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  std::uniform_int_distribution<int> dof(0, n - 1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Problem p;
  p.J = MatrixXd::Zero(m, n);
  p.free = Mask::Constant(n, true);
  for (int i = 0; i < n; ++i) p.free[i] = u(rng) > 0.15;
  for (int i = 0; i < m; ++i) {
    const double kind = u(rng);
    if (kind < 0.4) {  // unit row
      const int k = dof(rng);
      p.J(i, k) = u(rng) < 0.5 ? 1.0 : (u(rng) < 0.5 ? -1.0 : 1.0) * (0.2 + 3.0 * u(rng));
      if (u(rng) < 0.05) p.J(i, k) *= 0.005;  // r_k |J_ik| below 0.04 on every model's dofs
    } else if (kind < 0.5) {  // two entries, one of them possibly another unit row's dof
      p.J(i, dof(rng)) = normal(rng);
      p.J(i, dof(rng)) = normal(rng);
    } else {  // a task row with zeros (a chain): entries up to a random end
      const int end = 1 + dof(rng);
      for (int k = 0; k < end; ++k) p.J(i, k) = u(rng) < 0.8 ? normal(rng) : 0.0;
    }
  }
  p.xdot = VectorXd::Zero(m);
  for (int i = 0; i < m; ++i) p.xdot[i] = normal(rng);
  p.gradient = VectorXd::Zero(n);
  for (int i = 0; i < n; ++i) p.gradient[i] = normal(rng);
  return p;
}

/// The free dof of row i's only non-zero entry among the free dofs, -1 if it has more or none.
int unit_row_dof(const Problem& p, int i) {
  int count = 0, k = -1;
  for (int j = 0; j < static_cast<int>(p.J.cols()); ++j)
    if (p.free[j] && p.J(i, j) != 0.0) {
      ++count;
      k = j;
    }
  return count == 1 ? k : -1;
}

using wbm_test::raw_parameters;

/// Task and null-space parts by the plain formulas with the damping the solver reported for
/// each row: A = J W^-1 J^T + diag(lambda_i^2), q_task = W^-1 J^T A^-1 x_dot,
/// q_null = -alpha (W^-1 g - W^-1 J^T A^-1 J W^-1 g), W^-1 zero for frozen dofs.
void reference(const Model& model, const Problem& p, const VectorXd& damping, double alpha, VectorXd& task,
               VectorXd& null) {
  const int n = model.num_dofs();
  VectorXd w(n);
  for (int i = 0; i < n; ++i) w[i] = p.free[i] ? model.dof(i).work_range * model.dof(i).work_range : 0.0;
  const MatrixXd JW = p.J * w.asDiagonal();
  const MatrixXd A = JW * p.J.transpose() + MatrixXd(damping.cwiseAbs2().asDiagonal());
  const Eigen::LDLT<MatrixXd> ldlt(A);
  task = JW.transpose() * ldlt.solve(p.xdot);
  const VectorXd g = w.cwiseProduct(p.gradient);
  null = -alpha * (g - JW.transpose() * ldlt.solve(p.J * g));
}

void check_against_reference(const Model& model, unsigned seed) {
  const int n = model.num_dofs();
  const int max_rows = n + 4;
  WholeBodySolver solver(model, max_rows, raw_parameters());
  std::mt19937_64 rng(seed);
  // Mostly fewer rows than dofs; one case in ten up to more rows than dofs.
  std::uniform_int_distribution<int> rows(1, 2 * n / 3), many_rows(2 * n / 3, max_rows);
  std::bernoulli_distribution many(0.1);
  int undamped = 0, eliminated_dofs_checked = 0, isolated_damped = 0, exact_while_others_damped = 0;
  for (int c = 0; c < property_cases(); ++c) {
    const Problem p = random_problem(n, many(rng) ? many_rows(rng) : rows(rng), rng);
    solver.reset();
    // A few solves on the same problem: the smallest-eigenvalue estimate settles.
    SolverStatus st;
    for (int k = 0; k < 3; ++k) st = solver.solve(p.J, p.xdot, p.gradient, p.free, 0.001);
    ASSERT_TRUE(st.ok()) << p.describe();
    const SolverOutput& out = solver.output();
    ASSERT_TRUE(out.qdot.allFinite()) << p.describe();
    // The damping of each row: an isolated unit row's from its own singular value r_k |J_ik|,
    // the same for all rows of a block (rows linked by free dofs with entries in both).
    const int m = static_cast<int>(p.J.rows());
    const VectorXd damping = out.row_damping.head(m);
    const double eps = solver.parameters().singular_threshold, max_damping = solver.parameters().max_damping;
    std::vector<int> block(m);
    for (int i = 0; i < m; ++i) block[i] = i;
    for (bool merged = true; merged;) {  // plain relabelling until nothing changes
      merged = false;
      for (int i = 0; i < m; ++i)
        for (int j = 0; j < m; ++j)
          for (int k = 0; k < n && block[i] != block[j]; ++k)
            if (p.free[k] && p.J(i, k) != 0.0 && p.J(j, k) != 0.0) {
              const int from = std::max(block[i], block[j]), to = std::min(block[i], block[j]);
              for (int& b : block)
                if (b == from) b = to;
              merged = true;
            }
    }
    std::vector<int> isolated_dof(m, -1);
    bool others_damped = false;
    for (int i = 0; i < m; ++i) {
      const int k = unit_row_dof(p, i);
      bool alone = k >= 0;
      for (int j = 0; j < m && alone; ++j) alone = j == i || p.J(j, k) == 0.0;
      if (!alone) {
        for (int j = 0; j < i; ++j) {
          if (block[j] != block[i]) continue;
          ASSERT_EQ(damping[i], damping[j]) << "rows " << j << ", " << i << "\n" << p.describe();
        }
        others_damped = others_damped || damping[i] > 0.0;
        continue;
      }
      isolated_dof[i] = k;
      const double h = model.dof(k).work_range * p.J(i, k);
      const double expected = h * h < eps * eps ? max_damping * std::sqrt(1.0 - h * h / (eps * eps)) : 0.0;
      ASSERT_NEAR(damping[i], expected, 1e-15) << "isolated row " << i << "\n" << p.describe();
      isolated_damped += expected > 0.0;
    }
    ASSERT_EQ(out.damping, damping.maxCoeff()) << p.describe();
    VectorXd task, null;
    reference(model, p, damping, solver.parameters().nullspace_gain, task, null);
    const double scale = 1.0 + task.norm() + null.norm();
    ASSERT_LT((out.qdot_task - task).norm(), 1e-8 * scale) << "damping " << out.damping << "\n" << p.describe();
    ASSERT_LT((out.qdot_null - null).norm(), 1e-8 * scale) << "damping " << out.damping << "\n" << p.describe();
    for (int i = 0; i < n; ++i)
      if (!p.free[i]) { ASSERT_EQ(out.qdot[i], 0.0) << "frozen dof " << i << "\n" << p.describe(); }
    // An isolated row not damped itself is met exactly, also while the others are damped.
    for (int i = 0; i < m; ++i) {
      const int k = isolated_dof[i];
      if (k < 0 || damping[i] > 0.0) continue;
      ASSERT_NEAR(out.qdot_task[k], p.xdot[i] / p.J(i, k), 1e-12 * (1.0 + std::abs(p.xdot[i] / p.J(i, k))))
          << "isolated row " << i << "\n" << p.describe();
      ASSERT_EQ(out.qdot_null[k], 0.0) << "isolated row " << i << "\n" << p.describe();
      exact_while_others_damped += others_damped;
    }
    if (st.has(kDamped)) continue;
    ++undamped;
    ASSERT_LT((p.J * out.qdot_task - p.xdot).norm(), 1e-8 * (1.0 + p.xdot.norm()) * scale) << p.describe();
    // Undamped, a dof with a unit row takes exactly its commanded rate and no null-space motion.
    for (int i = 0; i < p.J.rows(); ++i) {
      const int k = unit_row_dof(p, i);
      if (k < 0) continue;
      ASSERT_NEAR(out.qdot_task[k], p.xdot[i] / p.J(i, k), 1e-12 * (1.0 + std::abs(p.xdot[i] / p.J(i, k))))
          << "row " << i << "\n" << p.describe();
      ASSERT_EQ(out.qdot_null[k], 0.0) << "row " << i << "\n" << p.describe();
      ++eliminated_dofs_checked;
    }
  }
  // Most cases must have reached the undamped checks, with unit rows in them.
  EXPECT_GT(undamped, property_cases() / 3);
  EXPECT_GT(eliminated_dofs_checked, property_cases() / 2);
  EXPECT_GT(isolated_damped, property_cases() / 100);
  EXPECT_GT(exact_while_others_damped, property_cases() / 100);
}

TEST(UnitRows, SolutionMatchesThePlainFormulasPaperModel) { check_against_reference(make_paper_model(), 1205); }

TEST(UnitRows, SolutionMatchesThePlainFormulasG1) {
  check_against_reference(wbm_test::shipped_model("g1_29dof").load(), 2005);
}

// The damping is set by sigma_min of the full J W^-1/2, unit rows included: with the same
// problem solved repeatedly the inverse iteration (through the Schur complement) converges
// to the SVD's value.
TEST(UnitRows, SmallestSingularValueIsThatOfAllRows) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  WholeBodySolver solver(model, 12, raw_parameters());
  std::mt19937_64 rng(77);
  int checked = 0;
  for (int c = 0; c < std::max(1, property_cases() / 20); ++c) {
    Problem p = random_problem(n, 12, rng);
    p.free.setConstant(true);
    VectorXd r(n);
    for (int i = 0; i < n; ++i) r[i] = model.dof(i).work_range;
    const Eigen::JacobiSVD<MatrixXd> svd(p.J * r.asDiagonal());
    const double sigma_min = svd.singularValues()[p.J.rows() - 1];
    const double gap = svd.singularValues()[p.J.rows() - 2] - sigma_min;
    if (sigma_min < 1e-6 || gap < 0.05 * sigma_min) continue;  // slow convergence: not a test of it
    solver.reset();
    for (int k = 0; k < 300; ++k) solver.solve(p.J, p.xdot, p.gradient, p.free, 0.001);
    // Rounding: the factorisation of A = J W^-1 J^T is exact to about eps sigma_max^2, which
    // moves sigma_min by about eps sigma_max^2 / (2 sigma_min): at sigma_min 3.5e-6 (one case
    // in 10^6 with WBM_PROPERTY_CASES=1000000) the estimate was 7e-5 of it off.
    const double sigma_max = svd.singularValues()[0];
    const double rounding = 4.0 * std::numeric_limits<double>::epsilon() * sigma_max * sigma_max / sigma_min;
    ASSERT_NEAR(solver.output().min_singular_value, sigma_min, 1e-6 * sigma_min + rounding) << p.describe();
    ++checked;
  }
  EXPECT_GT(checked, property_cases() / 100);
}

// Between cycles the solver tries the previous cycle's rows first. Sequences in which unit
// rows come and go (rows replaced, dofs frozen, a kept row becoming a unit row, a unit row
// gaining an entry at another unit row's dof) give bit for bit the result of a solver that
// finds them afresh.
TEST(UnitRows, ReusingThePreviousRowsChangesNothing) {
  const Model model = make_paper_model();
  const int n = model.num_dofs();
  const int m = 8;
  WholeBodySolver reused(model, m, raw_parameters());
  std::mt19937_64 rng(4242);
  std::uniform_int_distribution<int> row(0, m - 1), dof(0, n - 1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Problem p = random_problem(n, m, rng);
  int compared = 0, coupled_compared = 0;
  for (int c = 0; c < property_cases(); ++c) {
    // Small changes, as between cycles, and now and then a structural one.
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < n; ++j)
        if (p.J(i, j) != 0.0) p.J(i, j) *= 1.0 + 0.01 * (u(rng) - 0.5);
    const double change = u(rng);
    if (change < 0.05) {
      p = random_problem(n, m, rng);
    } else if (change < 0.15) {  // a row becomes a unit row, or a unit row a dense one
      const int i = row(rng);
      p.J.row(i).setZero();
      if (u(rng) < 0.5)
        p.J(i, dof(rng)) = 1.0;
      else
        p.J.row(i).head(1 + dof(rng)).setRandom();
    } else if (change < 0.2) {
      p.free[dof(rng)] = u(rng) < 0.5;
    }
    // Now and then a unit row gains an entry at another unit row's dof only: it is no unit
    // row any more, though its entries over the other dofs stay zero.
    bool coupled = false;
    if (u(rng) < 0.2) {
      std::vector<std::pair<int, int>> units;  // (row, its dof)
      for (int i = 0; i < m; ++i) {
        int nonzero = 0, at = -1;
        for (int j = 0; j < n; ++j)
          if (p.J(i, j) != 0.0) ++nonzero, at = j;
        if (nonzero == 1) units.emplace_back(i, at);
      }
      for (size_t a = 0; a + 1 < units.size() && !coupled; ++a)
        if (units[a].second != units[a + 1].second && p.free[units[a].second] && p.free[units[a + 1].second]) {
          p.J(units[a].first, units[a + 1].second) = 0.5;
          coupled = true;
        }
    }
    const SolverStatus a = reused.solve(p.J, p.xdot, p.gradient, p.free, 0.001);
    WholeBodySolver fresh(model, m, raw_parameters());
    const SolverStatus b = fresh.solve(p.J, p.xdot, p.gradient, p.free, 0.001);
    if (a.has(kDamped) || b.has(kDamped)) continue;  // the damping depends on the iteration's history
    ASSERT_EQ(reused.output().qdot_task, fresh.output().qdot_task) << "case " << c << "\n" << p.describe();
    ASSERT_EQ(reused.output().qdot_null, fresh.output().qdot_null) << "case " << c << "\n" << p.describe();
    ++compared;
    coupled_compared += coupled;
  }
  EXPECT_GT(compared, property_cases() / 4);
  EXPECT_GT(coupled_compared, property_cases() / 100) << "unit rows coupled to another's dof, compared";
}

}  // namespace
