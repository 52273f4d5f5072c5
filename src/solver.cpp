#include "wbm/solver.hpp"

#include <algorithm>
#include <cmath>

#include "wbm/errors.hpp"

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

}  // namespace

WholeBodySolver::WholeBodySolver(const Model& model, int max_rows, const SolverParameters& parameters)
    : model_(model), parameters_(parameters), max_rows_(max_rows) {
  check(parameters);
  if (max_rows < 0) throw ConfigError("solver: max_rows must be >= 0");
  const int n = model.num_dofs();
  const int m = std::max(max_rows, 1);
  free_.setConstant(n, true);
  w_.setZero(n);
  range_sq_.resize(n);
  for (int i = 0; i < n; ++i) range_sq_[i] = model.dof(i).work_range * model.dof(i).work_range;
  Jt_.setZero(n, m);
  A_.setZero(m, m);
  L_.setZero(m, m);
  inverse_diagonal_.setZero(m);
  y_.setZero(m);
  v_.setZero(m);
  u_.setZero(m);
  g_.setZero(n);
  previous_null_.setZero(n);
  out_.qdot.setZero(n);
  out_.qdot_task.setZero(n);
  out_.qdot_null.setZero(n);
}

void WholeBodySolver::set_parameters(const SolverParameters& parameters) {
  check(parameters);
  parameters_ = parameters;
}

void WholeBodySolver::reset() {
  previous_null_.setZero();
  previous_rows_ = -1;
  last_estimate_ = 0.0;
}

bool WholeBodySolver::factorize(int m) {
  // Cholesky A = L L^T (lower triangle of A) into the row-major L: every inner product
  // runs over two contiguous rows. The reciprocal diagonal is kept for the solves.
  double max_diagonal = 0.0;
  for (int j = 0; j < m; ++j) max_diagonal = std::max(max_diagonal, A_(j, j));
  const double tiny = 1e-13 * std::max(max_diagonal, 1e-300);
  for (int j = 0; j < m; ++j) {
    const double* __restrict__ Lj = &L_(j, 0);
    double d = A_(j, j);
    for (int k = 0; k < j; ++k) d -= Lj[k] * Lj[k];
    if (!(d > tiny)) return false;
    const double l = std::sqrt(d);
    L_(j, j) = l;
    const double inv = 1.0 / l;
    inverse_diagonal_[j] = inv;
    for (int i = j + 1; i < m; ++i) {
      const double* __restrict__ Li = &L_(i, 0);
      double sum = A_(i, j);
      for (int k = 0; k < j; ++k) sum -= Li[k] * Lj[k];
      L_(i, j) = sum * inv;
    }
  }
  return true;
}

void WholeBodySolver::solve_in_place(int m, double* __restrict__ x, double* __restrict__ z) const {
  // L y = b by rows (dot products), then L^T x = y by rows of L (axpy): both contiguous.
  // z, if given, is a second right-hand side solved in the same pass over L.
  const double* __restrict__ inv = inverse_diagonal_.data();
  if (z == nullptr) {
    for (int i = 0; i < m; ++i) {
      const double* __restrict__ Li = &L_(i, 0);
      double sx = x[i];
      for (int k = 0; k < i; ++k) sx -= Li[k] * x[k];
      x[i] = sx * inv[i];
    }
    for (int i = m - 1; i >= 0; --i) {
      const double* __restrict__ Li = &L_(i, 0);
      const double xi = x[i] * inv[i];
      x[i] = xi;
      for (int k = 0; k < i; ++k) x[k] -= Li[k] * xi;
    }
    return;
  }
  for (int i = 0; i < m; ++i) {
    const double* __restrict__ Li = &L_(i, 0);
    double sx = x[i], sz = z[i];
    for (int k = 0; k < i; ++k) {
      sx -= Li[k] * x[k];
      sz -= Li[k] * z[k];
    }
    x[i] = sx * inv[i];
    z[i] = sz * inv[i];
  }
  for (int i = m - 1; i >= 0; --i) {
    const double* __restrict__ Li = &L_(i, 0);
    const double xi = x[i] * inv[i], zi = z[i] * inv[i];
    x[i] = xi;
    z[i] = zi;
    for (int k = 0; k < i; ++k) {
      x[k] -= Li[k] * xi;
      z[k] -= Li[k] * zi;
    }
  }
}

double WholeBodySolver::estimate_min_eigenvalue(int m) {
  if (!factorize(m)) return last_estimate_ = 0.0;
  auto v = v_.head(m);
  // One step per cycle continues the iteration of the previous cycles (the configuration
  // changes little between cycles); three after a change of the row count, two near the
  // threshold, where the estimate sets the damping.
  int steps = last_estimate_ < 4.0 * parameters_.singular_threshold * parameters_.singular_threshold ? 2 : 1;
  if (m != previous_rows_ || !v.allFinite() || v.norm() == 0.0) {
    for (int i = 0; i < m; ++i) v[i] = 1.0 + 0.37 * i;
    previous_rows_ = m;
    steps = 3;
  }
  v.normalize();
  double growth = 0.0;
  for (int k = 0; k < steps; ++k) {
    solve_in_place(m, v.data(), nullptr);
    growth = v.norm();
    v /= growth;
  }
  // |A^-1 v| <= 1 / lambda_min, with equality for the converged eigenvector.
  last_estimate_ = 1.0 / growth;
  return last_estimate_;
}

std::uint32_t WholeBodySolver::resolve(const Eigen::Ref<const Eigen::MatrixXd>& J,
                                       const Eigen::Ref<const Eigen::VectorXd>& xdot,
                                       const Eigen::Ref<const Eigen::VectorXd>& gradient) {
  std::uint32_t flags = kSolverOk;
  const int n = model_.num_dofs();
  const int m = static_cast<int>(J.rows());
  int free_count = 0;
  for (int i = 0; i < n; ++i) {
    w_[i] = free_[i] ? range_sq_[i] : 0.0;
    free_count += free_[i] ? 1 : 0;
  }
  if (free_count == 0) return kAllDofsFrozen;
  if (m > free_count) flags |= kOverdetermined;
  out_.damping = 0.0;
  g_ = w_.cwiseProduct(gradient);
  if (m == 0) {
    flags |= kNoActiveRows;
    out_.qdot_null = -parameters_.nullspace_gain * g_;
    out_.min_singular_value = std::numeric_limits<double>::infinity();
  } else {
    // A = J W^-1 J^T from the task rows stored contiguously (Jt = J^T, n x m), in 2 x 2
    // blocks of the lower triangle so that each pass over the dofs fills four entries.
    auto Jt = Jt_.leftCols(m);
    Jt = J.transpose();
    const Eigen::Index ld = Jt_.outerStride();
    const double* __restrict__ w = w_.data();
    for (int j = 0; j < m; j += 2) {
      const int j1 = std::min(j + 1, m - 1);
      const double* __restrict__ a0 = Jt_.data() + j * ld;
      const double* __restrict__ a1 = Jt_.data() + j1 * ld;
      for (int i = j; i < m; i += 2) {
        const int i1 = std::min(i + 1, m - 1);
        const double* __restrict__ b0 = Jt_.data() + i * ld;
        const double* __restrict__ b1 = Jt_.data() + i1 * ld;
        double s00 = 0.0, s01 = 0.0, s10 = 0.0, s11 = 0.0;
        for (int k = 0; k < n; ++k) {
          const double wb0 = w[k] * b0[k], wb1 = w[k] * b1[k];
          s00 += wb0 * a0[k];
          s01 += wb0 * a1[k];
          s10 += wb1 * a0[k];
          s11 += wb1 * a1[k];
        }
        A_(i, j) = s00;
        A_(i, j1) = s01;
        A_(i1, j) = s10;
        A_(i1, j1) = s11;
      }
    }
    auto A = A_.topLeftCorner(m, m);
    const double lambda_min = estimate_min_eigenvalue(m);
    out_.min_singular_value = std::sqrt(std::max(lambda_min, 0.0));
    const double eps2 = parameters_.singular_threshold * parameters_.singular_threshold;
    if (lambda_min < eps2) {
      flags |= kDamped;
      const double max2 = parameters_.max_damping * parameters_.max_damping;
      double damping2 = max2 * (1.0 - std::max(lambda_min, 0.0) / eps2);
      A.diagonal().array() += damping2;
      if (!factorize(m)) {
        A.diagonal().array() += max2 - damping2;
        damping2 = max2;
        factorize(m);
      }
      out_.damping = std::sqrt(damping2);
    }
    auto y = y_.head(m);
    y = xdot;
    auto u = u_.head(m);
    u.noalias() = J * g_;
    solve_in_place(m, y.data(), u.data());
    out_.qdot_task.noalias() = J.transpose() * y;
    out_.qdot_task.array() *= w_.array();
    out_.qdot_null.noalias() = J.transpose() * u;
    out_.qdot_null = -parameters_.nullspace_gain * (g_ - w_.cwiseProduct(out_.qdot_null));
  }

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
      !(std::isfinite(dt) && dt > 0.0) || !xdot.allFinite() || !gradient.allFinite() ||
      (q != nullptr && q->size() != n)) {
    status.flags |= kInvalidInput;
    return status;
  }
  // A dof at a position limit that the solution would drive further out is frozen and the
  // solve repeated (at most three times): the other dofs take over its share.
  free_ = free_dofs;
  for (int attempt = 0;; ++attempt) {
    const std::uint32_t flags = resolve(J, xdot, gradient);
    if (flags & kAllDofsFrozen) {
      status.flags |= flags;
      out_.qdot_task.setZero();
      out_.qdot_null.setZero();
      previous_null_.setZero();
      return status;
    }
    bool changed = false;
    if (q != nullptr && attempt < 3) {
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

  const Eigen::VectorXd& vmax = model_.max_speeds();
  if (parameters_.limit_speeds) {
    double task_scale = 1.0;
    for (int i = 0; i < n; ++i) {
      const double v = std::abs(out_.qdot_task[i]);
      if (v > vmax[i]) task_scale = std::min(task_scale, vmax[i] / v);
    }
    if (task_scale < 1.0) {
      status.flags |= kTaskSpeedLimited;
      out_.qdot_task *= task_scale;
      out_.task_scale = task_scale;
      out_.nullspace_scale = 0.0;
    } else {
      // Largest s in [0, 1] with |qdot_task + s qdot_null| <= vmax for every dof.
      double s = 1.0;
      for (int i = 0; i < n; ++i) {
        const double qn = out_.qdot_null[i];
        if (qn == 0.0) continue;
        const double bound = (std::copysign(vmax[i], qn) - out_.qdot_task[i]) / qn;
        s = std::min(s, std::max(bound, 0.0));
      }
      if (s < 1.0) status.flags |= kNullSpaceSpeedScaled;
      out_.nullspace_scale = s;
    }
  }
  if (parameters_.nullspace_rate_change_limit > 0.0 && out_.nullspace_scale > 0.0) {
    // Jerk limit: the largest s' <= s with |s' qdot_null - previous| <= k vmax dt for all dofs.
    double lo = 0.0, hi = out_.nullspace_scale;
    double num = 0.0, den = 0.0;
    for (int i = 0; i < n; ++i) {
      const double qn = out_.qdot_null[i];
      const double step = parameters_.nullspace_rate_change_limit * vmax[i] * dt;
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
    if (lo > hi) s = std::clamp(den > 0.0 ? num / den : 0.0, 0.0, out_.nullspace_scale);  // closest feasible
    if (s < out_.nullspace_scale) {
      status.flags |= kNullSpaceJerkLimited;
      out_.nullspace_scale = s;
    }
  }
  out_.qdot_null *= out_.nullspace_scale;
  out_.qdot = out_.qdot_task + out_.qdot_null;
  if (!out_.qdot.allFinite()) {
    out_.qdot.setZero();
    out_.qdot_task.setZero();
    out_.qdot_null.setZero();
    status.flags |= kInvalidInput;
  }
  previous_null_ = out_.qdot_null;
  return status;
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
  for (int i = 0; i < q.size(); ++i) {
    const double x = q[i] + qdot[i] * dt;
    const double clamped = std::clamp(x, model.lower_limits()[i], model.upper_limits()[i]);
    if (clamped != x) flags |= kJointLimitClamped;
    q_next[i] = clamped;
  }
  return flags;
}

}  // namespace wbm
