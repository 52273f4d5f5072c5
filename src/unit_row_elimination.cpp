#include "unit_row_elimination.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>

namespace wbm::internal {

UnitRowElimination::UnitRowElimination(int num_dofs, int max_rows)
    : isolated_(max_rows, 0),
      kept_rows_(max_rows),
      row_(max_rows),
      dof_(max_rows),
      row_of_dof_(num_dofs, -1),
      h_(max_rows),
      inverse_h_(max_rows),
      b_(max_rows, max_rows) {
  b_.setZero();
}

void UnitRowElimination::find(const Eigen::Ref<const Eigen::MatrixXd>& J, const double* H, Eigen::Index ld,
                              const int* extent, const char* single, const int* free_index) {
  for (int k = 0; k < p_; ++k) row_of_dof_[dof_[k]] = -1;
  const int m = static_cast<int>(J.rows());
  p_ = 0;
  m_kept_ = 0;
  for (int i = 0; i < m; ++i) {
    // A unit row: its only non-zero entry is the last one, at extent - 1.
    const int last = extent[i] - 1;
    bool eliminated = false;
    if (last >= 0 && single[i]) {
      const int dof = free_index[last];
      const double h = H[i * ld + last];
      if (row_of_dof_[dof] < 0 && h * h > 1e-200) {  // false for NaN: such a row stays a kept row
        eliminated = true;
        row_of_dof_[dof] = i;
        row_[p_] = i;
        dof_[p_] = dof;
        h_[p_] = h;
        inverse_h_[p_] = 1.0 / h;
        ++p_;
      }
    }
    if (!eliminated) kept_rows_[m_kept_++] = i;
  }
  kept_leading_ = m_kept_ == 0 || kept_rows_[m_kept_ - 1] == m_kept_ - 1;
  m_ = m;
}

bool UnitRowElimination::reuse_rows(const Eigen::Ref<const Eigen::MatrixXd>& J, const bool* free, const double* range) {
  bool valid = J.rows() == m_;
  for (int k = 0; k < p_ && valid; ++k) {
    const double h = range[dof_[k]] * J(row_[k], dof_[k]);
    valid = free[dof_[k]] && h * h > 1e-200;
    if (h != h_[k]) {
      h_[k] = h;
      inverse_h_[k] = 1.0 / h;
    }
  }
  if (!valid) {
    for (int k = 0; k < p_; ++k) row_of_dof_[dof_[k]] = -1;
    p_ = 0;
    m_ = -1;
  }
  return valid;
}

bool UnitRowElimination::rows_vanish(const Eigen::Ref<const Eigen::MatrixXd>& J, const double* H, Eigen::Index ld,
                                     int np) const {
  // The bits of all entries without their signs, or-ed: zero exactly when every entry is +-0
  // (NaN and inf are not). Integer or-s have no long dependency chain, unlike a
  // floating-point sum, and may be vectorised.
  constexpr std::uint64_t kNoSign = ~(std::uint64_t{1} << 63);
  std::uint64_t bits = 0;
  const double* data = J.data();
  const Eigen::Index ldj = J.outerStride();
  for (int k = 0; k < p_; ++k) {
    const double* column = H + row_[k] * ld;
    for (int c = 0; c < np; ++c) bits |= std::bit_cast<std::uint64_t>(column[c]);
    for (int e = 0; e < p_; ++e)  // the other eliminated rows' dofs
      if (e != k) bits |= std::bit_cast<std::uint64_t>(data[row_[k] + dof_[e] * ldj]);
  }
  return (bits & kNoSign) == 0;
}

bool UnitRowElimination::kept_rows_stay(const Eigen::Ref<const Eigen::MatrixXd>& J, const int* extent,
                                        const char* single) const {
  for (int j = 0; j < m_kept_; ++j) {
    if (!single[j]) continue;
    // At most one non-zero entry among the remaining dofs (none if extent 0): a unit row if
    // the entries at the eliminated rows' dofs make it exactly one in all.
    int count = extent[j] > 0 ? 1 : 0;
    for (int k = 0; k < p_; ++k) count += J(kept_rows_[j], dof_[k]) != 0.0;
    if (count == 1) return false;
  }
  return true;
}

void UnitRowElimination::gather_couplings(const Eigen::Ref<const Eigen::MatrixXd>& J, const double* range) {
  for (int k = 0; k < p_; ++k) {
    const double r = range[dof_[k]];
    const double* column = J.data() + dof_[k] * J.outerStride();
    double* b = &b_(k, 0);
    std::uint64_t bits = 0;  // of all entries: only the sign bit set if every entry is +-0
    if (kept_leading_)
      for (int j = 0; j < m_kept_; ++j) {
        b[j] = r * column[j];
        bits |= std::bit_cast<std::uint64_t>(b[j]);
      }
    else
      for (int j = 0; j < m_kept_; ++j) {
        b[j] = r * column[kept_rows_[j]];
        bits |= std::bit_cast<std::uint64_t>(b[j]);
      }
    const bool isolated = (bits << 1) == 0;
    isolated_[k] = isolated;
    num_isolated_ += isolated;
  }
}

double UnitRowElimination::coupling_dot(int k, const double* x) const {
  const double* b = &b_(k, 0);
  double s0 = 0.0, s1 = 0.0;
  int j = 0;
  for (; j + 1 < m_kept_; j += 2) {
    s0 += b[j] * x[j];
    s1 += b[j + 1] * x[j + 1];
  }
  if (j < m_kept_) s0 += b[j] * x[j];
  return s0 + s1;
}

template <class Damping>
void UnitRowElimination::reduce_with(const double* f, double* __restrict__ z, Damping mu2) const {
  if (kept_leading_)
    std::copy_n(f, m_kept_, z);
  else
    for (int j = 0; j < m_kept_; ++j) z[j] = f[kept_rows_[j]];
  for (int k = 0; k < p_; ++k) {
    const double c = f[row_[k]] * h_over_dd(k, mu2(k));
    const double* __restrict__ b = &b_(k, 0);
    for (int j = 0; j < m_kept_; ++j) z[j] -= b[j] * c;
  }
}

void UnitRowElimination::reduce(const double* f, double* z, double mu2) const {
  reduce_with(f, z, [mu2](int) { return mu2; });
}

void UnitRowElimination::reduce(const double* f, double* z, const double* mu2) const {
  reduce_with(f, z, [mu2](int k) { return mu2[k]; });
}

void UnitRowElimination::expand(const double* f, const double* z, double* x, double mu2) const {
  // The eliminated entries first: with x == f they read only their own f_k.
  for (int k = 0; k < p_; ++k) {
    const double dd = h_[k] * h_[k] + mu2;
    x[row_[k]] = mu2 == 0.0 ? inverse_h_[k] * (f[row_[k]] * inverse_h_[k] - coupling_dot(k, z))
                            : (f[row_[k]] - h_[k] * coupling_dot(k, z)) / dd;
  }
  for (int j = 0; j < m_kept_; ++j) x[kept_rows_[j]] = z[j];
}

template <class KeptChange, class New, class Old>
void UnitRowElimination::add_damping_with(double* A, Eigen::Index lda, KeptChange kept_change, New mu2_new,
                                          Old mu2_old) const {
  for (int j = 0; j < m_kept_; ++j) A[j + j * lda] += kept_change(j);
  for (int k = 0; k < p_; ++k) {
    const double h2 = h_[k] * h_[k];
    const double c = mu2_new(k) / (h2 + mu2_new(k)) - mu2_old(k) / (h2 + mu2_old(k));
    if (c == 0.0) continue;
    const double* b = &b_(k, 0);
    for (int j = 0; j < m_kept_; ++j) {
      const double cb = c * b[j];
      for (int i = j; i < m_kept_; ++i) A[i + j * lda] += cb * b[i];
    }
  }
}

void UnitRowElimination::add_damping(double* A, Eigen::Index lda, double mu2_new, double mu2_old) const {
  add_damping_with(A, lda, [=](int) { return mu2_new - mu2_old; }, [=](int) { return mu2_new; },
                   [=](int) { return mu2_old; });
}

template <class Damping>
void UnitRowElimination::add_damped_gradient_with(const double* gradient, const double* range, double* z,
                                                  Damping mu2) const {
  for (int k = 0; k < p_; ++k) {
    if (mu2(k) == 0.0) continue;
    const int d = dof_[k];
    const double c = range[d] * gradient[d] * mu2(k) / (h_[k] * h_[k] + mu2(k));
    const double* b = &b_(k, 0);
    for (int j = 0; j < m_kept_; ++j) z[j] += b[j] * c;
  }
}

void UnitRowElimination::add_damped_gradient(const double* gradient, const double* range, double* z,
                                             double mu2) const {
  if (mu2 != 0.0) add_damped_gradient_with(gradient, range, z, [mu2](int) { return mu2; });
}

void UnitRowElimination::add_damping(double* A, Eigen::Index lda, const double* kept_change, const double* mu2_new,
                                     const double* mu2_old) const {
  add_damping_with(A, lda, [kept_change](int j) { return kept_change[j]; }, [mu2_new](int k) { return mu2_new[k]; },
                   [mu2_old](int k) { return mu2_old[k]; });
}

void UnitRowElimination::add_damped_gradient(const double* gradient, const double* range, double* z,
                                             const double* mu2) const {
  add_damped_gradient_with(gradient, range, z, [mu2](int k) { return mu2[k]; });
}

double UnitRowElimination::task_entry(int k, const double* y_kept, const double* xdot, double mu2) const {
  if (mu2 == 0.0) return xdot[row_[k]] * inverse_h_[k];
  return (mu2 * coupling_dot(k, y_kept) + h_[k] * xdot[row_[k]]) / (h_[k] * h_[k] + mu2);
}

double UnitRowElimination::null_entry(int k, const double* u_kept, double scaled_gradient, double mu2) const {
  if (mu2 == 0.0) return 0.0;
  return mu2 * (scaled_gradient - coupling_dot(k, u_kept)) / (h_[k] * h_[k] + mu2);
}

}  // namespace wbm::internal
