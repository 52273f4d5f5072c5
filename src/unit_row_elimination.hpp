#pragma once
/// @file
/// Internal (not installed): exact elimination of the task rows that touch one free dof
/// only (joint/posture rows) from the solver's m x m system, by block elimination.
///
/// Notation (scaled, as in the solver): H = W^-1/2 J^T over the free dofs, A = H^T H. A row
/// i_k whose only non-zero entry among the free dofs is at dof d_k has the single entry
/// h_k = r_dk J(i_k, d_k) in H; the other ("kept") rows have the entries b_k = r_dk J(R, d_k)
/// at that dof. With the kept rows R first and the eliminated rows P last, and mu^2 >= 0 the
/// damping,
///
///   A + mu^2 E = [ A_R + sum_k b_k b_k^T + mu^2 E    h_k b_k        ]
///                [ h_k b_k^T                          h_k^2 + mu^2   ]  (diagonal block),
///
/// where A_R = H_R^T H_R is the kept rows' matrix over the free dofs without the d_k (their
/// entries of H zeroed). Its Schur complement is
///
///   S(mu) = A_R + mu^2 E + sum_k (mu^2 / dd_k) b_k b_k^T,   dd_k = h_k^2 + mu^2,
///
/// i.e. S(0) = A_R: undamped, the eliminated dofs simply leave the kept rows' system. A
/// right-hand side f solves as x_R = S^-1 (f_R - sum_k b_k h_k f_k / dd_k),
/// x_k = (f_k - h_k b_k . x_R) / dd_k. Exact (no approximation); the smallest eigenvalue of
/// the full A, which sets the damping, is estimated from the same iteration as before.
///
/// A row is eliminated only if its dof is not taken by an earlier eliminated row and
/// h_k^2 > 1e-200 (so that 1 / dd_k stays finite); otherwise it stays a kept row.
///
/// An eliminated row with b_k = 0 (no other row has an entry at its dof: a gripper's
/// stroke, a joint task outside every other task's chain) is isolated: A is block diagonal
/// with h_k^2 as one block. The solver damps such a row by its own singular value |h_k|
/// alone (mu2 of the functions below is then that row's), and the other rows by theirs.
///
/// Finding the rows scans every row of H for its non-zero entries. Between cycles the rows
/// rarely change, so the solver first tries the previous cycle's rows (reuse()), builds H
/// over the remaining dofs and checks that the result is exactly what find() would give
/// (eliminated_rows_vanish(), kept_rows_stay()); only if not does it run find().

#include <vector>

#include <Eigen/Core>

namespace wbm::internal {

class UnitRowElimination {
 public:
  UnitRowElimination(int num_dofs, int max_rows);

  /// Finds the eliminated rows of J (m x n, m <= max_rows). H = W^-1/2 J^T over the free dofs
  /// free_index[...] (column i: row i of J; leading dimension ld); row i has its last
  /// non-zero entry at extent[i] - 1 (none if 0) and single[i] is true if it has at most
  /// one. Never allocates (nor do the other functions).
  void find(const Eigen::Ref<const Eigen::MatrixXd>& J, const double* H, Eigen::Index ld, const int* extent,
            const char* single, const int* free_index);
  /// Keeps the previous rows if J has as many rows and each eliminated row's dof is still
  /// free (free[d]) with an entry h_k as required; false (nothing kept) otherwise.
  bool reuse(const Eigen::Ref<const Eigen::MatrixXd>& J, const bool* free, const double* range) {
    return p_ == 0 ? J.rows() == m_ : reuse_rows(J, free, range);
  }
  /// After reuse(): true if each eliminated row has no other non-zero entry among the free
  /// dofs: its column of H is zero (H built over the free dofs other than the eliminated
  /// ones, all rows, np entries per column) and so are its entries of J at the other
  /// eliminated rows' dofs.
  bool eliminated_rows_vanish(const Eigen::Ref<const Eigen::MatrixXd>& J, const double* H, Eigen::Index ld,
                              int np) const {
    return p_ == 0 || rows_vanish(J, H, ld, np);
  }
  /// After reuse(), with H compacted to the kept rows, extent[j] their row ends and single[j]
  /// whether they have at most one non-zero entry over the remaining dofs: true if no kept
  /// row is a unit row (of a remaining free dof, or of an eliminated row's dof).
  bool kept_rows_stay(const Eigen::Ref<const Eigen::MatrixXd>& J, const int* extent, const char* single) const;
  /// The couplings b_k from J, once the rows are settled.
  void find_couplings(const Eigen::Ref<const Eigen::MatrixXd>& J, const double* range) {
    num_isolated_ = 0;
    if (p_ > 0) gather_couplings(J, range);
  }
  /// Whether eliminated row k is isolated (b_k = 0, after find_couplings()).
  bool is_isolated(int k) const { return isolated_[k] != 0; }
  /// How many eliminated rows are isolated.
  int num_isolated() const { return num_isolated_; }
  /// The original row of eliminated row k and its single scaled entry h_k.
  int eliminated_row(int k) const { return row_[k]; }
  double entry(int k) const { return h_[k]; }

  int num_eliminated() const { return p_; }
  int num_kept() const { return m_kept_; }
  /// Original index of kept row j (j < num_kept()), in increasing order.
  int kept_row(int j) const { return kept_rows_[j]; }
  /// True while the kept rows are rows 0 .. num_kept() - 1 (eliminated rows last).
  bool kept_rows_are_leading() const { return kept_leading_; }
  /// Whether dof d is the dof of an eliminated row.
  bool is_eliminated_dof(int d) const { return row_of_dof_[d] >= 0; }
  /// The dof of eliminated row k (k < num_eliminated()).
  int eliminated_dof(int k) const { return dof_[k]; }

  /// z_R = f_R - sum_k b_k h_k f_k / dd_k (f in the original row order, m entries).
  void reduce(const double* f, double* z, double mu2) const;
  /// x in the original order from the kept part z: x_R = z, x_k = (f_k - h_k b_k . z) / dd_k.
  /// x may be f.
  void expand(const double* f, const double* z, double* x, double mu2) const;
  /// A (lower triangle, column-major, leading dimension lda) from S(mu_old) to S(mu_new).
  void add_damping(double* A, Eigen::Index lda, double mu2_new, double mu2_old) const;
  /// The null-space right-hand side from H_R^T g~ to S(mu)'s: z += sum_k b_k g~_k mu^2 / dd_k,
  /// with g~_k = r_dk dH/dq_dk.
  void add_damped_gradient(const double* gradient, const double* range, double* z, double mu2) const;
  /// As reduce(), add_damping() and add_damped_gradient(), with a damping mu2[k] of its own
  /// for each eliminated row k (independent blocks of rows damped apart); add_damping()
  /// changes kept row j's diagonal entry by kept_change[j].
  void reduce(const double* f, double* z, const double* mu2) const;
  void add_damping(double* A, Eigen::Index lda, const double* kept_change, const double* mu2_new,
                   const double* mu2_old) const;
  void add_damped_gradient(const double* gradient, const double* range, double* z, const double* mu2) const;
  /// b_k over the kept rows (num_kept() entries).
  const double* coupling(int k) const { return &b_(k, 0); }
  /// Scaled task part (H y)_dk of eliminated dof k from the kept rows' solution y_R:
  /// (mu^2 b_k . y_R + h_k xdot_k) / dd_k.
  double task_entry(int k, const double* y_kept, const double* xdot, double mu2) const;
  /// Scaled null-space part g~_k - (H u)_dk = mu^2 (g~_k - b_k . u_R) / dd_k (zero undamped).
  double null_entry(int k, const double* u_kept, double scaled_gradient, double mu2) const;

 private:
  bool reuse_rows(const Eigen::Ref<const Eigen::MatrixXd>& J, const bool* free, const double* range);
  bool rows_vanish(const Eigen::Ref<const Eigen::MatrixXd>& J, const double* H, Eigen::Index ld, int np) const;
  void gather_couplings(const Eigen::Ref<const Eigen::MatrixXd>& J, const double* range);
  double coupling_dot(int k, const double* x) const;  // b_k . x over the kept rows
  // The damped functions for a damping given per eliminated row, mu2(k).
  template <class Damping>
  void reduce_with(const double* f, double* z, Damping mu2) const;
  template <class KeptChange, class New, class Old>
  void add_damping_with(double* A, Eigen::Index lda, KeptChange kept_change, New mu2_new, Old mu2_old) const;
  template <class Damping>
  void add_damped_gradient_with(const double* gradient, const double* range, double* z, Damping mu2) const;
  double h_over_dd(int k, double mu2) const {           // h_k / dd_k
    return mu2 == 0.0 ? inverse_h_[k] : h_[k] / (h_[k] * h_[k] + mu2);
  }

  int m_ = -1, p_ = 0, m_kept_ = 0, num_isolated_ = 0;
  std::vector<char> isolated_;  // per eliminated row: b_k = 0
  bool kept_leading_ = true;
  std::vector<int> kept_rows_, row_, dof_;  // kept rows; row and dof of each eliminated row
  std::vector<int> row_of_dof_;             // per dof: its eliminated row, or -1
  std::vector<double> h_, inverse_h_;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> b_;  // row k: b_k over the kept rows
};

}  // namespace wbm::internal
