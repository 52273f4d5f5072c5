#include "wbm/solver.hpp"

#include <algorithm>
#include <cmath>

#include "wbm/errors.hpp"

#include "braking.hpp"
#include "dot_kernels.hpp"
#include "rate_checks.hpp"
#include "row_blocks.hpp"
#include "unit_row_elimination.hpp"

namespace wbm {
namespace {

void check(const SolverParameters& p) {
  auto positive = [](double v) { return std::isfinite(v) && v >= 0.0; };
  if (!positive(p.nullspace_gain)) throw ConfigError("solver: nullspace_gain must be finite and >= 0");
  if (!(std::isfinite(p.singular_threshold) && p.singular_threshold > 0.0))
    throw ConfigError("solver: singular_threshold must be finite and > 0");
  if (!(std::isfinite(p.max_damping) && p.max_damping > 0.0)) throw ConfigError("solver: max_damping must be finite and > 0");
  if (!positive(p.nullspace_rate_change_limit))
    throw ConfigError("solver: nullspace_rate_change_limit must be finite and >= 0 (0 = off)");
}

/// 1 - cos^2 of the angle by which an inverse-iteration step may still turn the iterate
/// for its estimate to stand near the threshold (else one more step): the Rayleigh
/// quotient's relative error is then about this or less (measured on G1's moving targets).
constexpr double kSettledIterate = 1e-5;

}  // namespace

WholeBodySolver::WholeBodySolver(const Model& model, int max_rows, const SolverParameters& parameters)
    : model_(model), parameters_(parameters), max_rows_(max_rows), gram_(internal::select_weighted_gram()),
      transpose_products_(internal::select_transpose_products()),
      three_solves_(internal::select_three_solves()),
      elimination_(std::make_unique<internal::UnitRowElimination>(model.num_dofs(), std::max(max_rows, 1))),
      blocks_(std::make_unique<internal::RowBlocks>(std::max(max_rows, 1))) {
  check(parameters);
  if (max_rows < 0) throw ConfigError("solver: max_rows must be >= 0");
  const int n = model.num_dofs();
  const int m = std::max(max_rows, 1);
  free_.setConstant(n, true);
  frozen_at_limit_.setConstant(n, false);
  w_.setZero(n);
  range_.resize(n);
  range_sq_.resize(n);
  for (int i = 0; i < n; ++i) {
    range_[i] = model.dof(i).work_range;
    range_sq_[i] = range_[i] * range_[i];
  }
  free_index_.assign(n, 0);
  remaining_index_.assign(n, 0);
  extent_.assign(m, 0);
  single_entry_.assign(m, 0);
  H_.setZero(n + 3, m);  // spare rows: padding to a multiple of four free dofs
  gradient_free_.setZero(n + 3);
  zero_column_.setZero(m);
  task_free_.setZero(n + 3);
  null_free_.setZero(n + 3);
  u_rhs_.setZero(m);
  A_.setZero(m, m);
  L_.setZero(m, m);
  E_.setZero(m, m);
  pivot_.setZero(m);
  inverse_diagonal_.setZero(m);
  interleaved_.setZero(4 * m);
  y_.setZero(m);
  v_.setZero(m);
  step_.setZero(m);
  u_.setZero(m);
  z_.setZero(m);
  g_.setZero(n);
  previous_null_.setZero(n);
  previous_qdot_.setZero(n);
  previous_change_.setZero(n);
  previous_xdot_.setZero(m);
  out_.qdot.setZero(n);
  out_.qdot_task.setZero(n);
  out_.qdot_null.setZero(n);
  out_.row_damping.setZero(m);
  for (Eigen::VectorXd* v : {&block_v_, &block_w_, &block_z_, &block_lambda_, &block_mu2_, &block_sum2_,
                             &block_change_, &block_old_, &elim_mu2_})
    v->setZero(m);
  // block_sum1_ also holds a scale per block of the speed scaling (scale_task_blocks): the
  // kept rows' blocks (one, empty, when every row is eliminated) and one per isolated row,
  // so up to m + 1.
  block_sum1_.setZero(m + 1);
  row_block_.assign(m, -1);
  dof_block_.assign(n, -1);
  braking_time_per_rate_.resize(n);
  set_parameters(parameters);
}

WholeBodySolver::~WholeBodySolver() = default;

void WholeBodySolver::set_parameters(const SolverParameters& parameters) {
  check(parameters);
  parameters_ = parameters;
  for (int i = 0; i < model_.num_dofs(); ++i)
    braking_time_per_rate_[i] = 1.0 / (parameters.nullspace_rate_change_limit * model_.max_speeds()[i]);
}

void WholeBodySolver::reset() {
  previous_null_.setZero();
  frozen_at_limit_.setConstant(false);
  any_frozen_at_limit_ = false;
  previous_qdot_.setZero();
  previous_change_.setZero();
  alternations_ = 0;
  previous_xdot_rows_ = -1;
  damping_factor_ = 1.0;
  effective_damping_factor_ = 1.0;
  previous_rows_ = -1;
}


bool WholeBodySolver::factorize(int m) {
  // A = L D L^T (square-root-free Cholesky), L unit lower triangular, row-major, and
  // E = L D (row-major), so that each entry is an inner product of two contiguous rows:
  // E_ij = A_ij - sum_k<j L_ik E_jk, L_ij = E_ij / D_j. Two columns at a time (2 x 2 blocks
  // of inner products, as for A). The pivots D_i are running sums updated as soon as each
  // column is known: the chain from one pivot to the next is a division and a few
  // multiply-adds, no square root and no inner product.
  double max_diagonal = 0.0;
  for (int j = 0; j < m; ++j) {
    pivot_[j] = A_(j, j);
    max_diagonal = std::max(max_diagonal, A_(j, j));
  }
  const double tiny = 1e-13 * std::max(max_diagonal, 1e-300);
  int j = 0;
  for (; j + 1 < m; j += 2) {
    const int j1 = j + 1;
    const double* Ej = &E_(j, 0);
    const double* Ej1 = &E_(j1, 0);
    if (!(pivot_[j] > tiny)) return false;
    const double inv0 = 1.0 / pivot_[j];
    inverse_diagonal_[j] = inv0;
    double s[4];
    internal::two_dot_products(Ej, &L_(j1, 0), &L_(j1, 0), j, s);
    const double e = A_(j1, j) - s[0];
    const double l = e * inv0;
    // Entries in column pairs (j, j + 1), the pairs the dot products load; the diagonal
    // stays zero in L (the backward solve relies on it) and is never read in E.
    internal::store_pair(&E_(j1, j), e, 0.0);
    internal::store_pair(&L_(j1, j), l, 0.0);
    pivot_[j1] -= l * e;
    if (!(pivot_[j1] > tiny)) return false;
    const double inv1 = 1.0 / pivot_[j1];
    inverse_diagonal_[j1] = inv1;
    const double e_j1j = e;
    for (int i = j + 2; i < m; i += 2) {
      const int i1 = std::min(i + 1, m - 1);
      internal::four_dot_products(Ej, Ej1, &L_(i, 0), &L_(i1, 0), j, s);
      // Column j, then column j + 1 with its k = j term.
      const double e00 = A_(i, j) - s[0], e10 = A_(i1, j) - s[2];
      const double l00 = e00 * inv0, l10 = e10 * inv0;
      const double e01 = A_(i, j1) - s[1] - l00 * e_j1j, e11 = A_(i1, j1) - s[3] - l10 * e_j1j;
      const double l01 = e01 * inv1, l11 = e11 * inv1;
      internal::store_pair(&E_(i, j), e00, e01);
      internal::store_pair(&L_(i, j), l00, l01);
      pivot_[i] -= l00 * e00 + l01 * e01;
      if (i1 != i) {
        internal::store_pair(&E_(i1, j), e10, e11);
        internal::store_pair(&L_(i1, j), l10, l11);
        pivot_[i1] -= l10 * e10 + l11 * e11;
      }
    }
  }
  if (j < m) {  // odd m: the last pivot
    if (!(pivot_[j] > tiny)) return false;
    inverse_diagonal_[j] = 1.0 / pivot_[j];
  }
  return true;
}

template <int K>
void WholeBodySolver::solve_in_place(int m, double* const (&x)[K]) const {
  // L z = b by rows (dot products), y = D^-1 z, then L^T x = y by rows of L (axpy): both
  // over contiguous rows. The K right-hand sides share each pass over L, so that their
  // dependency chains overlap.
  const double* __restrict__ inv = inverse_diagonal_.data();
  for (int i = 1; i < m; ++i) {
    const double* __restrict__ Li = &L_(i, 0);
    // Two partial sums per right-hand side halve the dependency chain of the inner product.
    double s[K], t[K];
    for (int r = 0; r < K; ++r) {
      s[r] = x[r][i];
      t[r] = 0.0;
    }
    int k = 0;
    for (; k + 1 < i; k += 2)
      for (int r = 0; r < K; ++r) {
        s[r] -= Li[k] * x[r][k];
        t[r] -= Li[k + 1] * x[r][k + 1];
      }
    if (k < i)
      for (int r = 0; r < K; ++r) s[r] -= Li[k] * x[r][k];
    for (int r = 0; r < K; ++r) x[r][i] = s[r] + t[r];
  }
  for (int i = 0; i < m; ++i)
    for (int r = 0; r < K; ++r) x[r][i] *= inv[i];
  // Backward: x_k -= L_ik x_i for k < i, two entries per operation. For odd i the pair
  // (i - 1, i) also "updates" x_i by L_ii x_i with L_ii = 0 as stored (only the part below
  // the diagonal is ever written), so every row works on the same aligned pairs.
  for (int i = m - 1; i > 0; --i) {
    const double* __restrict__ Li = &L_(i, 0);
    for (int r = 0; r < K; ++r) {
      double* __restrict__ xr = x[r];
      const double xi = xr[i];
#if defined(__GNUC__)
      const internal::Lanes v = {xi, xi};
      for (int k = 0; k < i; k += 2) {
        const internal::Lanes updated = internal::load_lanes(xr + k) - internal::load_lanes(Li + k) * v;
        __builtin_memcpy(xr + k, &updated, sizeof updated);
      }
#else
      for (int k = 0; k < i; ++k) xr[k] -= Li[k] * xi;
#endif
    }
  }
}

int WholeBodySolver::start_inverse_iteration(int m) {
  // One step per cycle continues the iteration of the previous cycles (the configuration
  // changes little between cycles); three after a change of the row count.
  // @pre a row that is not isolated (whose eigenvalue the iteration is for).
  auto v = v_.head(m);
  const internal::UnitRowElimination& elimination = *elimination_;
  // Isolated rows are blocks of A of their own, with their eigenvalues known: the iterate
  // lives on the other rows (A keeps it there).
  auto drop_isolated_rows = [&] {
    for (int k = 0; k < elimination.num_eliminated(); ++k)
      if (elimination.is_isolated(k)) v[elimination.eliminated_row(k)] = 0.0;
  };
  // v is the previous cycle's normalised iterate, unless the row count changed or it broke.
  int steps = 1;
  if (m != previous_rows_ || !internal::all_finite(v.data(), m) || !(v.squaredNorm() > 0.0)) {
    for (int i = 0; i < m; ++i) v[i] = 1.0 + 0.37 * i;
    previous_rows_ = m;
    steps = 3;
  } else if (elimination.num_isolated() == 0) {
    return 1;  // unit already
  }
  if (elimination.num_isolated() > 0) {
    drop_isolated_rows();
    if (!(v.squaredNorm() > 0.0)) {  // it lay on rows isolated now: start again on the others
      for (int i = 0; i < m; ++i) v[i] = 1.0 + 0.37 * i;
      drop_isolated_rows();
      steps = 3;
    }
  }
  v.normalize();
  return steps;
}

double WholeBodySolver::finish_inverse_iteration_step(int m, double& cosine) {
  // step_ holds w = A^-1 v for the unit iterate v in v_. The Rayleigh quotient of A at w,
  // (w^T A w) / (w^T w) = (v . w) / |w|^2, bounds lambda_min from above, as 1 / |w| does, and
  // is the tighter bound (v . w <= |w|): both errors are second order in the angle between
  // the iterate and the eigenvector, the quotient's smaller by the ratio of the two smallest
  // eigenvalues.
  const double* __restrict__ w = step_.data();
  double* __restrict__ v = v_.data();
  double w2 = 0.0, vw = 0.0;
  for (int i = 0; i < m; ++i) {
    w2 += w[i] * w[i];
    vw += v[i] * w[i];
  }
  const double growth = std::sqrt(w2);
  const double scale = 1.0 / growth;
  for (int i = 0; i < m; ++i) v[i] = scale * w[i];
  cosine = vw * scale;
  return vw / w2;
}

void WholeBodySolver::apply_inverse(int m, double shift, const double* v, double* z, double* w) const {
  const internal::UnitRowElimination& elimination = *elimination_;
  const int mk = elimination.num_kept();
  if (elimination.num_eliminated() > 0) {
    elimination.reduce(v, z, shift);
    double* const rhs[1] = {z};
    solve_in_place<1>(mk, rhs);
    elimination.expand(v, z, w, shift);
  } else {
    std::copy_n(v, m, w);
    double* const rhs[1] = {w};
    solve_in_place<1>(m, rhs);
  }
}

double WholeBodySolver::inverse_iteration_step(int m, double& cosine) {
  apply_inverse(m, 0.0, v_.data(), z_.data(), step_.data());
  return finish_inverse_iteration_step(m, cosine);
}

void WholeBodySolver::clear_row_damping() {
  if (row_damping_zero_) return;
  out_.row_damping.setZero();
  row_damping_zero_ = true;
}

bool WholeBodySolver::block_iteration_step(int m, int blocks, double shift) {
  // w = (A + shift E)^-1 v, then each block's part of v and w on its own.
  const int* label = row_block_.data();
  double* __restrict__ v = block_v_.data();
  double* __restrict__ w = block_w_.data();
  apply_inverse(m, shift, v, block_z_.data(), w);
  double* w2 = block_sum1_.data();
  double* vw = block_sum2_.data();
  std::fill_n(w2, blocks, 0.0);
  std::fill_n(vw, blocks, 0.0);
  for (int i = 0; i < m; ++i) {
    if (label[i] < 0) continue;
    w2[label[i]] += w[i] * w[i];
    vw[label[i]] += v[i] * w[i];
  }
  const double eps2 = parameters_.singular_threshold * parameters_.singular_threshold;
  bool turning = false;
  for (int b = 0; b < blocks; ++b) {
    block_lambda_[b] = vw[b] / w2[b] - shift;
    const double cosine = vw[b] / std::sqrt(w2[b]);
    turning = turning || (block_lambda_[b] < 4.0 * eps2 && 1.0 - cosine * cosine > kSettledIterate);
    w2[b] = 1.0 / std::sqrt(w2[b]);  // the block's scale
  }
  for (int i = 0; i < m; ++i) v[i] = label[i] < 0 ? 0.0 : w[i] * w2[label[i]];
  return turning;
}

double WholeBodySolver::resolve_blocks(int m, int mk, int blocks, const Eigen::Ref<const Eigen::VectorXd>& xdot,
                                       const Eigen::Ref<const Eigen::VectorXd>& gradient, double& max_mu2,
                                       std::uint32_t& flags) {
  // As the one-block path in resolve(), block by block: the full A is block diagonal, so
  // A^-1 v is each block's inverse applied to its part of v, and one solve serves all.
  // Rare (robots whose tasks share no free dof), so written plainly: no fused kernel.
  const internal::RowBlocks& rows = *blocks_;
  internal::UnitRowElimination& elimination = *elimination_;
  const int p = elimination.num_eliminated();
  const double eps2 = parameters_.singular_threshold * parameters_.singular_threshold;
  double* A = A_.data();
  const Eigen::Index lda = A_.outerStride();
  // Each row's block: the kept rows' from `rows`, an eliminated row's that of the kept rows
  // it couples to, -1 for an isolated one (damped alone, below in resolve()).
  int* label = row_block_.data();
  for (int j = 0; j < mk; ++j) label[elimination.kept_row(j)] = rows.block(j);
  for (int k = 0; k < p; ++k) {
    int first = 0;
    const double* b = elimination.coupling(k);
    while (first + 1 < mk && b[first] == 0.0) ++first;
    label[elimination.eliminated_row(k)] = elimination.is_isolated(k) ? -1 : rows.block(first);
  }
  // A singular block (more rows than its dofs) fails the factorisation; the blocks are then
  // estimated on A + shift E (the same eigenvectors, eigenvalues shifted), the shift small
  // (so that the iteration still separates a zero eigenvalue from the next) but far above
  // the factorisation's pivot tolerance (1e-13 of A's largest diagonal entry).
  double shift = 0.0;
  bool factored = factorize(mk);
  if (!factored) {
    double largest = eps2;
    for (int j = 0; j < mk; ++j) largest = std::max(largest, A[j + j * lda]);
    shift = 1e-9 * largest;
    elimination.add_damping(A, lda, shift, 0.0);
    factored = factorize(mk);
  }
  double* lambda = block_lambda_.data();
  double* mu2 = block_mu2_.data();
  std::fill_n(lambda, blocks, 0.0);
  double* task_rhs = block_z_.data();
  if (factored) {
    double* v = block_v_.data();
    int steps = 1;
    if (!rows.unchanged() || m != block_rows_ || !internal::all_finite(v, m)) {
      double* norm2 = block_sum1_.data();
      std::fill_n(norm2, blocks, 0.0);
      for (int i = 0; i < m; ++i) {
        v[i] = label[i] < 0 ? 0.0 : 1.0 + 0.37 * i;
        if (label[i] >= 0) norm2[label[i]] += v[i] * v[i];
      }
      for (int i = 0; i < m; ++i)
        if (label[i] >= 0) v[i] /= std::sqrt(norm2[label[i]]);
      block_rows_ = m;
      steps = 3;
    }
    bool turning = false;
    for (int k = 0; k < steps; ++k) turning = block_iteration_step(m, blocks, shift);
    if (turning) block_iteration_step(m, blocks, shift);
    // The task and null-space solves (of A + shift E), and each block's bound from the task
    // solve (see resolve()): lambda_b + shift <= |b_b| / |y_b| over its kept rows.
    if (p > 0)
      elimination.reduce(xdot.data(), task_rhs, shift);
    else
      std::copy_n(xdot.data(), m, task_rhs);
    std::copy_n(task_rhs, mk, y_.data());
    u_.head(mk) = u_rhs_.head(mk);
    elimination.add_damped_gradient(gradient.data(), range_.data(), u_.data(), shift);
    double* const rhs[2] = {y_.data(), u_.data()};
    solve_in_place<2>(mk, rhs);
    double* rhs2 = block_sum1_.data();
    double* y2 = block_sum2_.data();
    std::fill_n(rhs2, blocks, 0.0);
    std::fill_n(y2, blocks, 0.0);
    for (int j = 0; j < mk; ++j) {
      rhs2[rows.block(j)] += task_rhs[j] * task_rhs[j];
      y2[rows.block(j)] += y_[j] * y_[j];
    }
    for (int b = 0; b < blocks; ++b) {
      const double bound = std::sqrt(rhs2[b] / y2[b]) - shift;
      if (bound < lambda[b]) lambda[b] = bound;
      if (!(lambda[b] >= 0.0)) lambda[b] = 0.0;  // no estimate (overflow): as singular
    }
  }
  const double max2 = effective_damping_factor_ * parameters_.max_damping * parameters_.max_damping;
  double lambda_min = std::numeric_limits<double>::infinity();
  max_mu2 = 0.0;
  for (int b = 0; b < blocks; ++b) {
    lambda_min = std::min(lambda_min, lambda[b]);
    mu2[b] = lambda[b] < eps2 ? max2 * (1.0 - std::max(lambda[b], 0.0) / eps2) : 0.0;
    max_mu2 = std::max(max_mu2, mu2[b]);
  }
  // A from the shift to each block's damping: the kept rows' diagonal, the eliminated
  // rows' couplings (an isolated row's has none: its own damping is applied in resolve()).
  double* change = block_change_.data();
  double* elim_old = block_old_.data();
  double* elim_mu2 = elim_mu2_.data();
  auto set_damping = [&] {
    for (int j = 0; j < mk; ++j) change[j] = mu2[rows.block(j)] - change[j];
    for (int k = 0; k < p; ++k) {
      const int b = label[elimination.eliminated_row(k)];
      elim_old[k] = elim_mu2[k];
      elim_mu2[k] = b < 0 ? 0.0 : mu2[b];
    }
    elimination.add_damping(A, lda, change, elim_mu2, elim_old);
    for (int j = 0; j < mk; ++j) change[j] = mu2[rows.block(j)];  // what the diagonal holds now
  };
  if (max_mu2 > 0.0 || shift > 0.0) {
    if (max_mu2 > 0.0) flags |= kDamped;
    std::fill_n(change, mk, shift);
    std::fill_n(elim_mu2, p, shift);
    set_damping();
    if (!factorize(mk)) {  // as in resolve(): the largest damping for every block
      std::fill_n(mu2, blocks, max2);
      max_mu2 = max2;
      set_damping();
      factorize(mk);
    }
    if (p > 0)
      elimination.reduce(xdot.data(), y_.data(), elim_mu2);
    else
      std::copy_n(xdot.data(), m, y_.data());
    u_.head(mk) = u_rhs_.head(mk);
    elimination.add_damped_gradient(gradient.data(), range_.data(), u_.data(), elim_mu2);
    double* const rhs[2] = {y_.data(), u_.data()};
    solve_in_place<2>(mk, rhs);
  } else {
    std::fill_n(elim_mu2, p, 0.0);
  }
  return lambda_min;
}

double WholeBodySolver::scale_task_blocks() {
  // Each block's task part scaled to the speed limits on its own (blocks share no dof, so
  // each keeps its direction), not every block by the most limited one's factor.
  const Eigen::VectorXd& vmax = model_.max_speeds();
  double* scale = block_sum1_.data();  // m + 1 entries
  std::fill_n(scale, task_blocks_, 1.0);
  for (int i = 0; i < model_.num_dofs(); ++i) {
    const double v = std::abs(out_.qdot_task[i]);
    if (dof_block_[i] >= 0 && v > vmax[i]) scale[dof_block_[i]] = std::min(scale[dof_block_[i]], vmax[i] / v);
  }
  double smallest = 1.0;
  for (int i = 0; i < model_.num_dofs(); ++i)
    if (dof_block_[i] >= 0) out_.qdot_task[i] *= scale[dof_block_[i]];
  for (int b = 0; b < task_blocks_; ++b) smallest = std::min(smallest, scale[b]);
  return smallest;
}

int WholeBodySolver::scale_rows(const Eigen::Ref<const Eigen::MatrixXd>& J,
                                const Eigen::Ref<const Eigen::VectorXd>& gradient, const int* dofs, int nf,
                                int columns) {
  // Two dofs at a time: a 2 x 2 transpose per two rows, two stores.
  const int np = (nf + 3) & ~3;
  const Eigen::Index ld = H_.outerStride();
  double* H = H_.data();
  const double* zero = zero_column_.data();
  for (int c = 0; c < np; c += 2) {
    const int k0 = c < nf ? dofs[c] : -1;
    const int k1 = c + 1 < nf ? dofs[c + 1] : -1;
    internal::scaled_transpose_two_columns(k0 >= 0 ? J.data() + k0 * J.outerStride() : zero,
                                           k1 >= 0 ? J.data() + k1 * J.outerStride() : zero,
                                           k0 >= 0 ? range_[k0] : 0.0, k1 >= 0 ? range_[k1] : 0.0, columns, H + c,
                                           ld);
    gradient_free_[c] = k0 >= 0 ? range_[k0] * gradient[k0] : 0.0;
    gradient_free_[c + 1] = k1 >= 0 ? range_[k1] * gradient[k1] : 0.0;
  }
  return np;
}

int WholeBodySolver::find_row_ends(int m, int nf) {
  // The virtual dofs come first in every model and the limbs after them, so hand and head
  // rows end well before the last dof; A's sums skip the zeros behind (exactly: they add
  // nothing). Rows with one non-zero entry or none are marked (for the row elimination).
  const double* H = H_.data();
  int single = 0;
  for (int i = 0; i < m; ++i) {
    const double* row = H + i * H_.outerStride();
    int e = nf;
    while (e > 0 && row[e - 1] == 0.0) --e;
    extent_[i] = e;
    // One non-zero entry or none? Rarely: the entry before a row's last one is almost always
    // non-zero (the joint before the last of a chain), which settles it at once.
    bool at_most_one = false;
    if (e < 2 || row[e - 2] == 0.0) {
      int first = 0;
      while (first + 1 < e && row[first] == 0.0) ++first;
      at_most_one = first + 1 >= e;
    }
    single_entry_[i] = at_most_one;
    single += at_most_one;
  }
  return single;
}

int WholeBodySolver::prepare_rows(const Eigen::Ref<const Eigen::MatrixXd>& J,
                                  const Eigen::Ref<const Eigen::VectorXd>& gradient, int nf, int& nr,
                                  const int*& dofs) {
  // The previous cycle's eliminated rows first; if H shows that a fresh search would give
  // other rows, the search on H over all free dofs.
  internal::UnitRowElimination& elimination = *elimination_;
  const int m = static_cast<int>(J.rows());
  const Eigen::Index ld = H_.outerStride();
  double* __restrict__ H = H_.data();
  bool reused = elimination.reuse(J, free_.data(), range_.data());
  int np = 0;
  for (;;) {
    nr = nf;
    dofs = free_index_.data();
    if (!reused) {  // find the rows on H over all free dofs
      np = scale_rows(J, gradient, dofs, nf, m);
      find_row_ends(m, nf);
      elimination.find(J, H, ld, extent_.data(), single_entry_.data(), dofs);
      if (elimination.num_eliminated() == 0) break;  // H and the row ends are complete
    }
    if (elimination.num_eliminated() > 0) {
      nr = 0;
      for (int c = 0; c < nf; ++c)
        if (!elimination.is_eliminated_dof(free_index_[c])) remaining_index_[nr++] = free_index_[c];
      dofs = remaining_index_.data();
    }
    const bool leading = elimination.kept_rows_are_leading();
    np = scale_rows(J, gradient, dofs, nr, reused || !leading ? m : elimination.num_kept());
    if (reused && !elimination.eliminated_rows_vanish(J, H, ld, np)) {
      reused = false;
      continue;
    }
    for (int j = 0; j < elimination.num_kept() && !leading; ++j) {  // move the kept rows forward
      const int from = elimination.kept_row(j);
      if (from != j) std::copy_n(H + from * ld, np, H + j * ld);
    }
    const int single_rows = find_row_ends(elimination.num_kept(), nr);
    if (reused && single_rows > 0 && !elimination.kept_rows_stay(J, extent_.data(), single_entry_.data())) {
      reused = false;
      continue;
    }
    break;
  }
  elimination.find_couplings(J, range_.data());
  return np;
}

std::uint32_t WholeBodySolver::resolve(const Eigen::Ref<const Eigen::MatrixXd>& J,
                                       const Eigen::Ref<const Eigen::VectorXd>& xdot,
                                       const Eigen::Ref<const Eigen::VectorXd>& gradient) {
  std::uint32_t flags = kSolverOk;
  const int n = model_.num_dofs();
  const int m = static_cast<int>(J.rows());
  // The free dofs, compacted; frozen dofs (W^-1_ii = 0) take no part in the products.
  int nf = 0;
  // g = W^-1 dH/dq in the same pass (loads of w in pairs right after these stores would
  // wait for failed store-to-load forwarding).
  for (int i = 0; i < n; ++i) {
    w_[i] = free_[i] ? range_sq_[i] : 0.0;
    g_[i] = w_[i] * gradient[i];
    if (free_[i]) free_index_[nf++] = i;
  }
  if (nf == 0) {
    clear_row_damping();
    return kAllDofsFrozen;
  }
  if (m > nf) flags |= kOverdetermined;
  out_.damping = 0.0;
  if (m == 0) {
    flags |= kNoActiveRows;
    out_.qdot_null = -parameters_.nullspace_gain * g_;
    out_.min_singular_value = std::numeric_limits<double>::infinity();
    return flags;
  }
  // Rows on a single free dof (joint rows) are eliminated exactly (unit_row_elimination.hpp):
  // undamped, their dofs take the commanded rates and leave the system of the kept rows,
  // which is solved over the other free dofs (mk x mk instead of m x m).
  // The kept rows become contiguous columns over the remaining free dofs: H = W^-1/2 J^T
  // (nr x mk, zero-padded to np, a multiple of four, for the two- and four-lane kernels).
  // One scaled copy serves all products: A = J W^-1 J^T = H^T H, J W^-1 g = H^T (W^-1/2 g),
  // W^-1 J^T y = W^-1/2 H y.
  internal::UnitRowElimination& elimination = *elimination_;
  const Eigen::Index ld = H_.outerStride();
  const double* H = H_.data();
  int nr = nf;
  const int* dofs = free_index_.data();  // the remaining free dofs
  const int np = prepare_rows(J, gradient, nf, nr, dofs);
  const int p = elimination.num_eliminated();
  const int mk = elimination.num_kept();
  const int isolated = elimination.num_isolated();
  // A = H^T H (lower triangle).
  gram_(H, H, ld, mk, np, extent_.data(), A_.data(), A_.outerStride());
  // Independent blocks of rows (no free dof in common, also through the eliminated rows'
  // couplings: the full A block diagonal), each damped by its own sigma_min.
  const int blocks = mk > 1 ? blocks_->find(A_.data(), A_.outerStride(), mk, elimination) : 1;
  // u = J W^-1 dH/dq = H^T (W^-1/2 dH/dq), two rows at a time.
  for (int i = 0; i < mk; i += 2) {
    const int i1 = std::min(i + 1, mk - 1);
    double s[2];
    internal::two_dot_products(gradient_free_.data(), H + i * ld, H + i1 * ld, np, s);
    u_rhs_[i] = s[0];
    u_rhs_[i1] = s[1];
  }

  // The smallest eigenvalue of the full A (sigma_min^2) by inverse iteration (with the
  // eliminated rows: through the Schur complement); its last step shares the pass over the
  // factor with the two solves, which are repeated only when damping.
  // Isolated joint rows (on a dof no other row touches) are blocks of A of their own, with
  // the eigenvalue h_k^2, and are damped by it alone (below); lambda_min is that of the other
  // rows, infinite if there are none.
  const double eps2 = parameters_.singular_threshold * parameters_.singular_threshold;
  double lambda_min = 0.0;
  double mu2 = 0.0;  // damping lambda^2 of the rows that are not isolated (the largest of the blocks')
  if (isolated == m) {
    lambda_min = std::numeric_limits<double>::infinity();
  } else if (blocks > 1) {
    lambda_min = resolve_blocks(m, mk, blocks, xdot, gradient, mu2, flags);
  } else if (factorize(mk)) {
    const int steps = start_inverse_iteration(m);
    double cosine = 1.0;  // between the iterate before and after a step
    for (int k = 1; k < steps; ++k) inverse_iteration_step(m, cosine);
    if (p > 0) {
      elimination.reduce(xdot.data(), y_.data(), 0.0);
      elimination.reduce(v_.data(), z_.data(), 0.0);
    }
    // The task's right-hand side: x_dot itself without eliminated rows (what reduce() gives).
    const double* task_rhs = p > 0 ? y_.data() : xdot.data();
    const double task_rhs2 = Eigen::Map<const Eigen::VectorXd>(task_rhs, mk).squaredNorm();
    // The task, null-space and inverse-iteration solves in one pass over the factor (a
    // CPU-dispatched kernel: four lanes hold the three right-hand sides' entries of a row),
    // read from where they are (no copies into y and u just before); the iterate's step
    // goes to w = step_ (v stays for the Rayleigh quotient).
    three_solves_(L_.data(), L_.outerStride(), inverse_diagonal_.data(), mk, task_rhs, u_rhs_.data(),
                  p > 0 ? z_.data() : v_.data(), y_.data(), u_.data(), p > 0 ? z_.data() : step_.data(),
                  interleaved_.data());
    if (p > 0) elimination.expand(v_.data(), z_.data(), step_.data(), 0.0);
    lambda_min = finish_inverse_iteration_step(m, cosine);
    // Near the threshold, where the estimate sets the damping, an iterate that still turned
    // in this step (after a dof froze or the targets jumped) takes another step. In steady
    // motion the iterate has settled (the warm start) and one step per cycle suffices.
    if (lambda_min < 4.0 * eps2 && 1.0 - cosine * cosine > kSettledIterate)
      lambda_min = inverse_iteration_step(m, cosine);
    // The task solve bounds it as well: |A^-1 b| <= |b| / lambda_min for every b, so
    // lambda_min <= |b| / |A^-1 b| (for the system reduced by joint rows too: its smallest
    // eigenvalue is at least A's). Inverse iteration warm-started from the last cycle can
    // lag behind where the free dofs change (a dof frozen at its limit): an undamped solve of
    // a nearly singular A then drove a dof at its speed limit for a cycle (H1, hands out of
    // reach: 10,000 rad/s^2). No division in the common case.
    const double task_solution2 = y_.head(mk).squaredNorm();
    if (task_rhs2 < lambda_min * lambda_min * task_solution2) lambda_min = std::sqrt(task_rhs2 / task_solution2);
    // Rows scaled to the edge of the double range: the step overflows (inf - inf in the
    // solves) and gives no estimate. A number is needed for the damping decision: that of a
    // singular A (the iterate, not finite, restarts next cycle).
    if (!(lambda_min >= 0.0)) lambda_min = 0.0;
  }
  if (blocks == 1 && lambda_min < eps2) {
    flags |= kDamped;
    const double max2 = parameters_.max_damping * parameters_.max_damping;
    // lambda^2 from sigma_min, times the factor adapt_damping() raised after an overshoot.
    mu2 = effective_damping_factor_ * max2 * (1.0 - std::max(lambda_min, 0.0) / eps2);
    elimination.add_damping(A_.data(), A_.outerStride(), mu2, 0.0);  // A + mu^2 E (its Schur complement)
    if (!factorize(mk)) {
      elimination.add_damping(A_.data(), A_.outerStride(), effective_damping_factor_ * max2, mu2);
      mu2 = effective_damping_factor_ * max2;
      factorize(mk);
    }
    if (p > 0)
      elimination.reduce(xdot.data(), y_.data(), mu2);
    else
      y_.head(m) = xdot;
    u_.head(mk) = u_rhs_.head(mk);
    elimination.add_damped_gradient(gradient.data(), range_.data(), u_.data(), mu2);
    double* const rhs[2] = {y_.data(), u_.data()};
    solve_in_place<2>(mk, rhs);
  }
  // Each row's lambda (isolated rows' below): zero in the common case, written only when
  // some row is damped, and cleared once after.
  clear_row_damping();
  if (blocks > 1) {
    for (int i = 0; i < m && mu2 > 0.0; ++i)
      if (row_block_[i] >= 0) out_.row_damping[i] = std::sqrt(block_mu2_[row_block_[i]]);
  } else if (mu2 > 0.0) {
    std::fill_n(out_.row_damping.data(), m, std::sqrt(mu2));
  }
  row_damping_zero_ = mu2 == 0.0;
  // Each dof's block, for scaling each block's task part to the speed limits apart: that of
  // the rows it has entries in, and one more block per isolated row.
  task_blocks_ = 1;
  if (blocks > 1 || isolated > 0) {
    std::fill(dof_block_.begin(), dof_block_.end(), -1);
    for (int c = 0; c < nr && mk > 0; ++c) {
      int j = 0;
      while (j + 1 < mk && H[c + j * ld] == 0.0) ++j;
      dof_block_[dofs[c]] = blocks > 1 ? blocks_->block(j) : 0;
    }
    task_blocks_ = blocks;
    for (int e = 0; e < p; ++e)
      dof_block_[elimination.eliminated_dof(e)] = elimination.is_isolated(e) ? task_blocks_++
                                                  : blocks > 1 ? row_block_[elimination.eliminated_row(e)]
                                                               : 0;
  }
  // An isolated row's damping from its own singular value |h_k|, by the same rule (raised
  // alike: a row of a custom element on one dof can pass through J_ik = 0).
  const double raised_max2 = effective_damping_factor_ * parameters_.max_damping * parameters_.max_damping;
  auto isolated_damping = [&](int k) {
    const double h2 = elimination.entry(k) * elimination.entry(k);
    return h2 < eps2 ? raised_max2 * (1.0 - h2 / eps2) : 0.0;
  };
  double min_eigenvalue = lambda_min, max_mu2 = mu2;
  for (int k = 0; k < p && isolated > 0; ++k) {
    if (!elimination.is_isolated(k)) continue;
    const double mu2_k = isolated_damping(k);
    min_eigenvalue = std::min(min_eigenvalue, elimination.entry(k) * elimination.entry(k));
    max_mu2 = std::max(max_mu2, mu2_k);
    if (mu2_k > 0.0 || !row_damping_zero_) out_.row_damping[elimination.eliminated_row(k)] = std::sqrt(mu2_k);
    if (mu2_k > 0.0) {
      row_damping_zero_ = false;
      flags |= kDamped;
    }
  }
  out_.min_singular_value = std::sqrt(min_eigenvalue);
  out_.damping = std::sqrt(max_mu2);
  // W^-1 J^T y = W^-1/2 H y and W^-1 J^T u = W^-1/2 H u over the free dofs.
  const double* task = task_free_.data();
  const double* null = null_free_.data();
  transpose_products_(H, ld, mk, np, y_.data(), u_.data(), task_free_.data(), null_free_.data());
  out_.qdot_task.setZero();
  out_.qdot_null = g_;
  for (int c = 0; c < nr; ++c) {
    const int k = dofs[c];
    out_.qdot_task[k] = range_[k] * task[c];
    out_.qdot_null[k] -= range_[k] * null[c];
  }
  for (int e = 0; e < p; ++e) {
    const int k = elimination.eliminated_dof(e);
    const double mu2_e = isolated > 0 && elimination.is_isolated(e) ? isolated_damping(e)
                         : blocks > 1                                 ? elim_mu2_[e]
                                                                      : mu2;
    out_.qdot_task[k] = range_[k] * elimination.task_entry(e, y_.data(), xdot.data(), mu2_e);
    out_.qdot_null[k] = range_[k] * elimination.null_entry(e, u_.data(), range_[k] * gradient[k], mu2_e);
  }
  out_.qdot_null *= -parameters_.nullspace_gain;
  return flags;
}

SolverStatus WholeBodySolver::solve(const Eigen::Ref<const Eigen::MatrixXd>& J,
                                    const Eigen::Ref<const Eigen::VectorXd>& xdot,
                                    const Eigen::Ref<const Eigen::VectorXd>& gradient, const Mask& free_dofs, double dt,
                                    const Eigen::VectorXd* q) {
  SolverStatus status;
  const int n = model_.num_dofs();
  const int m = static_cast<int>(J.rows());
  out_.qdot.setZero();
  out_.qdot_task.setZero();
  out_.qdot_null.setZero();
  out_.min_singular_value = 0.0;
  out_.damping = 0.0;
  out_.nullspace_scale = 1.0;
  out_.task_scale = 1.0;
  if (J.cols() != n || xdot.size() != m || gradient.size() != n || free_dofs.size() != n || m > max_rows_ ||
      !(std::isfinite(dt) && dt > 0.0) || !internal::all_finite(xdot.data(), m) ||
      !internal::all_finite(gradient.data(), n) ||
      (q != nullptr && q->size() != n)) {
    status.flags |= kInvalidInput;
    clear_row_damping();
    return status;
  }
  // A raised damping holds as long as the command is as fast as when it was raised: the
  // overshoot it stops grows with |x_dot| (docs/solver.md), and a command that slows down
  // (the error shrinking, a target back in reach) needs less, down to none.
  effective_damping_factor_ = 1.0;
  if (damping_factor_ > 1.0) {
    const double rate = std::min(1.0, xdot.norm() / raised_at_rate_);
    effective_damping_factor_ = std::max(1.0, damping_factor_ * rate);
  }
  // A dof at a position limit that the solution would drive further out is frozen and the
  // solve repeated (at most kMaxFreezeRounds times): the other dofs take over its share.
  free_ = free_dofs;
  for (int attempt = 0;; ++attempt) {
    const std::uint32_t flags = resolve(J, xdot, gradient);
    if (flags & kAllDofsFrozen) {
      status.flags |= flags;
      out_.qdot_task.setZero();
      out_.qdot_null.setZero();
      previous_null_.setZero();
      previous_xdot_rows_ = -1;  // q_dot = 0 is nothing to compare the next solve with
      return status;
    }
    bool changed = false;
    if (q != nullptr && attempt < kMaxFreezeRounds &&
        internal::any_driven_outwards(q->data(), out_.qdot_task.data(), out_.qdot_null.data(),
                                      model_.lower_limits().data(), model_.upper_limits().data(), n)) {
      for (int i = 0; i < n; ++i) {
        const double v = out_.qdot_task[i] + out_.qdot_null[i];
        const bool outwards = ((*q)[i] <= model_.lower_limits()[i] && v < 0.0) ||
                              ((*q)[i] >= model_.upper_limits()[i] && v > 0.0);
        if (free_[i] && outwards) {
          free_[i] = false;
          changed = true;
        }
      }
    }
    if (!changed) {
      status.flags |= flags;
      break;
    }
    status.flags |= kDofAtLimitFrozen;
  }
  // Where the set of dofs frozen at their limits changes, the motion is split differently
  // between the task and the null-space part (a dof's share moves from one to the other),
  // so this cycle's null-space part is not comparable with the last one's and the jerk
  // limit below is skipped once. Releasing a dof whose free rate has just turned inwards
  // leaves q_dot continuous (its rate crosses zero there); jerk-limiting the new split
  // instead scaled the whole null space down at that instant and drove the dof back into
  // the clamp, a hand-over repeating every 20 ms with crossed arms (docs/solver.md).
  bool frozen_set_changed = false;
  const bool any_frozen = (status.flags & kDofAtLimitFrozen) != 0;
  if (any_frozen || any_frozen_at_limit_) {  // the common case (none, before and now) skips the loop
    for (int i = 0; i < n; ++i) {
      const bool frozen = free_dofs[i] && !free_[i];
      frozen_set_changed = frozen_set_changed || frozen != frozen_at_limit_[i];
      frozen_at_limit_[i] = frozen;
    }
    any_frozen_at_limit_ = any_frozen;
  }
  out_.frozen_set_changed = frozen_set_changed;

  const Eigen::VectorXd& vmax = model_.max_speeds();
  if (parameters_.limit_speeds) {
    double task_scale = 1.0;
    if (internal::any_exceeds(out_.qdot_task.data(), vmax.data(), n)) {
      if (task_blocks_ > 1) {
        task_scale = scale_task_blocks();
      } else {
        for (int i = 0; i < n; ++i) {
          const double v = std::abs(out_.qdot_task[i]);
          if (v > vmax[i]) task_scale = std::min(task_scale, vmax[i] / v);
        }
        out_.qdot_task *= task_scale;
      }
    }
    if (task_scale < 1.0) {
      status.flags |= kTaskSpeedLimited;
      out_.task_scale = task_scale;
    }
    // Largest s in [0, 1] with |qdot_task + s qdot_null| <= vmax for every dof; s = 1
    // when the sum is within the limits (the common case: no divisions). Also after the
    // task part was scaled: dropping the null space there would make q_dot jump where
    // the task part crosses a speed limit, and out of reach, where the damped task part
    // grows as the null space moves the arm away from the singularity, it crosses it
    // again and again (a limit cycle at 15-20 Hz; docs/solver.md).
    const bool within =
        !internal::any_combination_exceeds(1.0, out_.qdot_null.data(), out_.qdot_task.data(), 1.0, vmax.data(), n);
    double s = 1.0;
    if (!within) {
      for (int i = 0; i < n; ++i) {
        const double qn = out_.qdot_null[i];
        if (qn == 0.0) continue;
        const double bound = (std::copysign(vmax[i], qn) - out_.qdot_task[i]) / qn;
        s = std::min(s, std::max(bound, 0.0));
      }
    }
    if (s < 1.0) status.flags |= kNullSpaceSpeedScaled;
    out_.nullspace_scale = s;
  }
  if (parameters_.nullspace_rate_change_limit > 0.0 && out_.nullspace_scale > 0.0 && !frozen_set_changed) {
    // Jerk limit: the largest s' <= s with |s' qdot_null - previous| <= k vmax dt for all
    // dofs. s itself satisfies it in the common case, checked first without divisions.
    const double k_dt = parameters_.nullspace_rate_change_limit * dt;
    const double scale = out_.nullspace_scale;
    // |-scale qdot_null + previous| is |scale qdot_null - previous| exactly.
    if (internal::any_combination_exceeds(-scale, out_.qdot_null.data(), previous_null_.data(), k_dt, vmax.data(),
                                          n)) {
      double lo = 0.0, hi = scale;
      double num = 0.0, den = 0.0;
      for (int i = 0; i < n; ++i) {
        const double qn = out_.qdot_null[i];
        const double step = k_dt * vmax[i];
        const double prev = previous_null_[i];
        if (qn == 0.0) continue;
        double a = (prev - step) / qn, b = (prev + step) / qn;
        if (a > b) std::swap(a, b);
        lo = std::max(lo, a);
        hi = std::min(hi, b);
        num += qn * prev / (step * step);
        den += qn * qn / (step * step);
      }
      double s = hi;
      if (lo > hi) s = std::clamp(den > 0.0 ? num / den : 0.0, 0.0, scale);  // closest feasible
      if (s < scale) {
        status.flags |= kNullSpaceJerkLimited;
        out_.nullspace_scale = s;
      }
    }
  }
  out_.qdot_null *= out_.nullspace_scale;
  out_.qdot = out_.qdot_task + out_.qdot_null;
  if (q != nullptr && parameters_.nullspace_rate_change_limit > 0.0) {
    // The paper clamps a joint at its limit (IV.E), so a dof that reaches it at speed stops
    // within a cycle. Here the rate is clamped instead, before the limit: a dof moving
    // towards a limit d away faster than sqrt(k v_max d) (from which it stops there at the
    // deceleration k v_max / 2) or than d / dt (which lands it on the limit) is slowed to
    // that rate; the other dofs are left as solved, as the paper's clamp leaves them, and
    // the task error this makes is fed back next cycle. The dof then reaches its limit at
    // a rate falling by at most k v_max dt per cycle (the Controller's bound across the
    // freeze that follows there; docs/solver.md). The common case, no dof that close, is
    // one pass without a division or square root.
    const double k = parameters_.nullspace_rate_change_limit;
    const double* lower = model_.lower_limits().data();
    const double* upper = model_.upper_limits().data();
    const double* position = q->data();
    const double* qdot = out_.qdot.data();
    const double* speed = vmax.data();
    // Close: where the dof would be after this cycle's step, or after its braking distance
    // v |v| / (k v_max) at the rate it has, lies beyond a limit.
    const double* braking_time_per_rate = braking_time_per_rate_.data();  // 1 / (k v_max)
    const bool close = internal::any_close_to_a_limit(position, qdot, braking_time_per_rate, dt, lower, upper, n);
    for (int i = 0; close && i < n; ++i) {
      const double v = qdot[i];
      const double rate = internal::braked_rate(v, internal::distance_ahead(v, position[i], lower[i], upper[i]),
                                                k * speed[i], dt);
      if (!(std::abs(rate) < std::abs(v))) continue;  // not braked (or NaN, caught below)
      const double f = rate / v;
      out_.qdot_task[i] *= f;
      out_.qdot_null[i] *= f;
      out_.qdot[i] = rate;
      status.flags |= kDofBraked;
    }
  }
  if (!internal::all_finite(out_.qdot.data(), n)) {
    out_.qdot.setZero();
    out_.qdot_task.setZero();
    out_.qdot_null.setZero();
    status.flags |= kInvalidInput;
  }
  previous_null_ = out_.qdot_null;
  if (effective_damping_factor_ > 1.0 && (status.flags & kDamped)) status.flags |= kDampingRaised;
  adapt_damping(xdot, status.flags);
  return status;
}

void WholeBodySolver::adapt_damping(const Eigen::Ref<const Eigen::VectorXd>& xdot, std::uint32_t flags) {
  const int n = model_.num_dofs();
  const int m = static_cast<int>(xdot.size());
  if (!(flags & kDamped)) {
    damping_factor_ = 1.0;  // out of the singular region: lambda from sigma_min again
    previous_xdot_rows_ = -1;  // nothing to compare the next solve with (no copies here)
    alternations_ = 0;
    return;
  }
  if (m == previous_xdot_rows_) {
    // q_dot turned back (more than 120 degrees) at a comparable size while the command did
    // not turn (less than 60 degrees): the damped step overshot (docs/solver.md).
    const double a = out_.qdot.norm(), b = previous_qdot_.norm();
    const double c = xdot.norm(), d = previous_xdot_.head(m).norm();
    bool noticeable = false;  // some dof's rate changed by more than 1 % of its speed limit
    // Also a period-2 oscillation riding on a drift, which the whole q_dot does not show turning
    // back: q_dot's change turned back (more than 120 degrees) and grew, some dof's by more than
    // 0.1 % of its speed limit, in kAlternations solves in a row (docs/solver.md).
    double turn = 0.0, change2 = 0.0, previous2 = 0.0;
    bool visible = false;
    for (int i = 0; i < n; ++i) {
      const double change = out_.qdot[i] - previous_qdot_[i];
      noticeable = noticeable || std::abs(change) > 0.01 * model_.max_speeds()[i];
      visible = visible || std::abs(change) > 0.001 * model_.max_speeds()[i];
      turn += change * previous_change_[i];
      change2 += change * change;
      previous2 += previous_change_[i] * previous_change_[i];
      previous_change_[i] = change;
    }
    const bool alternating = visible && change2 > previous2 && turn < -0.5 * std::sqrt(change2 * previous2);
    alternations_ = alternating ? alternations_ + 1 : 0;
    const bool same_command = xdot.dot(previous_xdot_.head(m)) > 0.5 * c * d;
    if (same_command && ((noticeable && a > 0.5 * b && out_.qdot.dot(previous_qdot_) < -0.5 * a * b) ||
                         alternations_ >= kAlternations)) {
      damping_factor_ = std::min(kDampingFactorStep * effective_damping_factor_, kMaxDampingFactor);
      raised_at_rate_ = c;
      alternations_ = 0;
    }
  } else {
    alternations_ = 0;
    previous_change_.setZero();
  }
  previous_qdot_ = out_.qdot;
  previous_xdot_.head(m) = xdot;
  previous_xdot_rows_ = m;
}

Eigen::MatrixXd WholeBodySolver::pseudo_inverse(const Eigen::MatrixXd& J, const Mask& free_dofs) {
  const int m = static_cast<int>(J.rows());
  const int n = model_.num_dofs();
  Eigen::MatrixXd result = Eigen::MatrixXd::Zero(n, m);
  for (int k = 0; k < m; ++k) {
    const Eigen::VectorXd e = Eigen::VectorXd::Unit(m, k);
    SolverParameters p = parameters_;
    SolverParameters saved = parameters_;
    p.limit_speeds = false;
    p.nullspace_rate_change_limit = 0.0;
    parameters_ = p;
    solve(J, e, Eigen::VectorXd::Zero(n), free_dofs, 1.0);
    parameters_ = saved;
    result.col(k) = out_.qdot_task;
  }
  return result;
}

std::uint32_t integrate(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                        const Eigen::Ref<const Eigen::VectorXd>& qdot, double dt, Eigen::Ref<Eigen::VectorXd> q_next) {
  std::uint32_t flags = kSolverOk;
  const int n = static_cast<int>(q.size());
  auto step = [&](int i) {
    const double x = q[i] + qdot[i] * dt;
    const double clamped = std::clamp(x, model.lower_limits()[i], model.upper_limits()[i]);
    // A step that lands on the limit (a braked dof, solve()) may round past it by an ulp;
    // put back there, it is not a clamp.
    if (clamped != x && std::abs(x - clamped) > 4.0 * std::numeric_limits<double>::epsilon() * (1.0 + std::abs(clamped)))
      flags |= kJointLimitClamped;
    return clamped;
  };
  // Stored in pairs: the caller reads q_next in pairs at once (q_dot from the step), and a
  // 16-byte load of two fresh 8-byte stores waits for failed store-to-load forwarding.
  int i = 0;
  for (; i + 1 < n; i += 2) {
    const double first = step(i);
    internal::store_pair(q_next.data() + i, first, step(i + 1));
  }
  if (i < n) q_next[i] = step(i);
  return flags;
}

}  // namespace wbm
