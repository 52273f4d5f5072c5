#pragma once
/// @file
/// Velocity-level redundancy resolution (section IV): weighted pseudo-inverse (eq. 6),
/// null-space projection (eq. 7), dof constraints b_C (IV.D), speed and jerk limits and
/// clamping (IV.E).

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "wbm/model.hpp"
#include "wbm/task_stack.hpp"

namespace wbm {
namespace internal {
class UnitRowElimination;
class RowBlocks;
}

struct SolverParameters {
  /// Null-space step width alpha of eq. (5) [1/s with the criteria of this library].
  double nullspace_gain = 0.5;
  /// sigma_min of J W^-1/2 below which damping starts (task units per normalised dof).
  double singular_threshold = 0.04;
  /// Damping lambda at sigma_min = 0 (same units).
  double max_damping = 0.04;
  /// The paper's "jerk limit" on the null-space rates (IV.E): the null-space velocity of
  /// a dof may change by at most this many times its speed limit per second [1/s]; 0 turns
  /// it off. When exceeded, the whole null-space vector is scaled down (direction kept).
  /// Not applied in a solve where the set of dofs frozen at their limits changes (the
  /// task/null-space split changes there; docs/solver.md). The Controller uses the same
  /// factor to limit the change of the whole q_dot in every cycle.
  double nullspace_rate_change_limit = 20.0;
  /// Scale velocities so that no dof exceeds its speed limit (IV.E).
  bool limit_speeds = true;
};

/// Flags of a solve; several may be set at once.
enum SolverFlag : std::uint32_t {
  kSolverOk = 0,
  kDamped = 1u << 0,                ///< Near-singular: damped least squares was used.
  kOverdetermined = 1u << 1,        ///< More active rows than free dofs.
  kTaskSpeedLimited = 1u << 2,      ///< The task part alone broke a speed limit: it was scaled to it.
  kNullSpaceSpeedScaled = 1u << 3,  ///< Null-space part scaled to respect the speed limits.
  kNullSpaceJerkLimited = 1u << 4,  ///< Null-space part scaled by the jerk limit.
  kNoActiveRows = 1u << 5,          ///< No task row active: null-space motion only.
  kAllDofsFrozen = 1u << 6,         ///< Every dof constrained: q_dot = 0.
  kInvalidInput = 1u << 7,          ///< NaN/inf input or wrong sizes: q_dot = 0, state kept.
  kJointLimitClamped = 1u << 8,     ///< A joint was clamped at its limit (integrate()).
  kDofAtLimitFrozen = 1u << 9,      ///< A dof at its limit was frozen for the cycle (Controller).
  kDampingRaised = 1u << 10,        ///< Damped more than sigma_min alone gives: q_dot overshot near a singularity.
  kDofBraked = 1u << 11,            ///< A dof nearing a position limit was slowed to a rate that stops it there (Controller).
};

struct SolverStatus {
  std::uint32_t flags = kSolverOk;
  bool has(SolverFlag f) const { return (flags & f) != 0; }
  /// False only for kInvalidInput (nothing was computed).
  bool ok() const { return !has(kInvalidInput); }
};

/// Result of one solve; all vectors have nq entries.
struct SolverOutput {
  Eigen::VectorXd qdot;       ///< Total joint velocity [rad/s or m/s].
  Eigen::VectorXd qdot_task;  ///< J# x_dot part (after scaling).
  Eigen::VectorXd qdot_null;  ///< -alpha N W^-1 dH/dq part (after scaling).
  double min_singular_value = 0.0;  ///< Estimate of sigma_min of J W^-1/2.
  double damping = 0.0;             ///< The largest lambda used (of row_damping).
  /// lambda of each active row (the first m entries; max_rows in all): the same for the rows
  /// of one independent block, each block's from its own sigma_min.
  Eigen::VectorXd row_damping;
  double nullspace_scale = 1.0;     ///< Factor applied to the null-space part.
  double task_scale = 1.0;          ///< Factor applied to the task part (the smallest block's).
  bool frozen_set_changed = false;  ///< The dofs frozen at their limits differ from the last solve's.
};

/// Solves eq. (5) with W^-1 = diag(r_i^2) (r_i the work range of dof i: the minimum-norm
/// solution in range-normalised coordinates q_i / r_i, so that each dof contributes in
/// proportion to its range, IV.C) and W^-1_ii = 0 for frozen dofs.
///
/// Frozen dofs (b_C = 0): zeroing W^-1_ii removes the dof from J W^-1 J^T, makes row i of
/// J# zero and row i of N W^-1 zero, exactly as the paper's zero column plus N diagonal rule
/// (IV.D); the dof moves exactly zero.
///
/// Factorisation: A = J W^-1 J^T = L D L^T (m x m, square-root-free Cholesky). The
/// smallest eigenvalue of A (sigma_min^2) is estimated by inverse iteration warm-started
/// from the previous cycle (one step per cycle, its Rayleigh quotient the estimate; another
/// near the threshold while the iterate still turns; three when the row count changed), and
/// bounded by the task solve: lambda_min <= |x_dot| / |A^-1 x_dot|.
/// Below the threshold eps the damped form A + lambda^2 E is used with
/// lambda^2 = lambda_max^2 (1 - sigma_min^2 / eps^2) (singularity-robust inverse, Nakamura
/// 1986): lambda is continuous in the configuration and J J# = E holds exactly away from
/// singularities. More rows than free dofs make A singular and take the same path.
///
/// Rows with one non-zero entry among the free dofs (joint rows) are solved exactly by
/// block elimination instead of inside A (same result up to rounding; docs/solver.md).
/// Independent blocks of rows (no free dof in common, directly or through other rows: the
/// arms of a robot on a fixed base; a joint row on a dof no other row touches, such as a
/// gripper's) are damped each by its own sigma_min (row_damping) and their task parts
/// scaled to the speed limits each on its own, so that an arm out of reach does not hold
/// back the other arm or a gripper (docs/solver.md).
class WholeBodySolver {
 public:
  /// @param max_rows the largest number of task rows that will be passed.
  /// @throws ConfigError for invalid parameters.
  WholeBodySolver(const Model& model, int max_rows, const SolverParameters& parameters = {});
  ~WholeBodySolver();
  WholeBodySolver(const WholeBodySolver&) = delete;
  WholeBodySolver& operator=(const WholeBodySolver&) = delete;

  const SolverParameters& parameters() const { return parameters_; }
  /// @throws ConfigError for invalid parameters.
  void set_parameters(const SolverParameters& parameters);

  /// One solve (eq. 5, or eq. 21 with x_dot already reduced by x_bal). Never allocates,
  /// never throws. On invalid input (wrong sizes, NaN/inf, dt <= 0) sets kInvalidInput and
  /// q_dot = 0.
  /// @param J m x nq Jacobian of the active rows; @param xdot m commanded task velocities;
  /// @param gradient dH/dq (nq); @param free_dofs b_C (nq); @param dt cycle time [s] (jerk limit).
  /// @param q optional current configuration (nq): a dof at a position limit that the
  ///   solution would drive further out is then frozen for this solve and the solve repeated
  ///   (at most kMaxFreezeRounds times; kDofAtLimitFrozen), so that the other dofs take over
  ///   its share instead of the task stalling against the clamp. With
  ///   nullspace_rate_change_limit k > 0, a dof moving towards a limit d away faster than
  ///   sqrt(k v_max d) or d / dt is slowed to that rate (both parts scaled; kDofBraked): it
  ///   reaches the limit decelerating by at most k v_max instead of stopping there at once.
  /// Near a singularity the damping is raised (kDampingRaised) after q_dot turned back
  /// between two solves under an unchanged command, in proportion to |x_dot| against its
  /// value then, until a solve is undamped again (docs/solver.md).
  SolverStatus solve(const Eigen::Ref<const Eigen::MatrixXd>& J, const Eigen::Ref<const Eigen::VectorXd>& xdot,
                     const Eigen::Ref<const Eigen::VectorXd>& gradient, const Mask& free_dofs, double dt,
                     const Eigen::VectorXd* q = nullptr);
  const SolverOutput& output() const { return out_; }
  /// Forget the previous null-space velocity (jerk limit), eigenvector estimate and
  /// raised damping.
  void reset();

  /// Repeated solves at most, each freezing more dofs at their limits (1 + this many solves).
  static constexpr int kMaxFreezeRounds = 8;
  /// Near a singularity, the damping lambda^2 is multiplied by this factor after each
  /// overshoot (q_dot turning back while the command did not), up to kMaxDampingFactor;
  /// the raise shrinks with the command's speed |x_dot| against that at the raise.
  static constexpr double kDampingFactorStep = 4.0;
  static constexpr double kMaxDampingFactor = 256.0;
  /// An overshoot is also a change of q_dot that turned back and grew this many solves in a
  /// row under the same command: a period-2 oscillation riding on a slow drift.
  static constexpr int kAlternations = 4;

  /// Weighted (damped, as in solve) pseudo-inverse J# (nq x m) for analysis and tests:
  /// column k is solve()'s q_dot_task for x_dot = e_k. At sigma_min >= singular_threshold
  /// no column is damped (J J# = I); below it each column's damping follows that solve's
  /// estimate, which also bounds sigma_min by the right-hand side (|b| / |A^-1 b|), so the
  /// columns may differ in damping. Allocates: not for the real-time cycle.
  Eigen::MatrixXd pseudo_inverse(const Eigen::MatrixXd& J, const Mask& free_dofs);

 private:
  /// Raises the damping factor after an overshoot, resets it to 1 after an undamped solve,
  /// and keeps this solve's q_dot and x_dot for the next.
  void adapt_damping(const Eigen::Ref<const Eigen::VectorXd>& xdot, std::uint32_t flags);
  /// Unscaled task and null-space parts for the dofs in free_; returns status flags.
  std::uint32_t resolve(const Eigen::Ref<const Eigen::MatrixXd>& J, const Eigen::Ref<const Eigen::VectorXd>& xdot,
                        const Eigen::Ref<const Eigen::VectorXd>& gradient);
  /// H = W^-1/2 J^T for the nf dofs dofs[...] and the first `columns` rows of J, and
  /// W^-1/2 dH/dq; returns nf rounded up to a multiple of four (the zero padding).
  int scale_rows(const Eigen::Ref<const Eigen::MatrixXd>& J, const Eigen::Ref<const Eigen::VectorXd>& gradient,
                 const int* dofs, int nf, int columns);
  /// extent_[i] = 1 + the last of the nf dofs with a non-zero entry in column i of H (i < m),
  /// single_entry_[i] whether it has one non-zero entry or none; returns how many have.
  int find_row_ends(int m, int nf);
  /// Finds the eliminated (joint) rows and builds H over the remaining free dofs (nr of
  /// them, dofs[...]) for the kept rows, with their row ends; returns the padded dof count.
  int prepare_rows(const Eigen::Ref<const Eigen::MatrixXd>& J, const Eigen::Ref<const Eigen::VectorXd>& gradient,
                   int nf, int& nr, const int*& dofs);
  bool factorize(int m);
  /// Solves A x = b in place with the factor for K right-hand sides at once.
  template <int K>
  void solve_in_place(int m, double* const (&x)[K]) const;
  /// Prepares the inverse-iteration vector v for this cycle; returns the number of steps.
  int start_inverse_iteration(int m);
  /// One step v <- A^-1 v / |A^-1 v| (apply_inverse()); returns the Rayleigh quotient, an
  /// upper bound of lambda_min.
  double inverse_iteration_step(int m, double& cosine);
  /// w = (A + shift E)^-1 v over the m rows (through the eliminated rows' Schur complement
  /// of the factor's matrix, which must be that of A + shift E); z: scratch of mk entries.
  void apply_inverse(int m, double shift, const double* v, double* z, double* w) const;
  /// v <- w / |w| for w = A^-1 v (in step_); returns the Rayleigh quotient (v . w) / |w|^2
  /// and the cosine of the angle between v and w.
  double finish_inverse_iteration_step(int m, double& cosine);
  /// resolve() for independent blocks of rows (m rows, mk kept): sigma_min^2 and damping per
  /// block, y and u solved, row_damping written for the rows that are not isolated, the
  /// eliminated rows' damping in elim_mu2_; returns the smallest sigma_min^2 and sets the
  /// largest damping mu^2 in max_mu2.
  double resolve_blocks(int m, int mk, int blocks, const Eigen::Ref<const Eigen::VectorXd>& xdot,
                        const Eigen::Ref<const Eigen::VectorXd>& gradient, double& max_mu2, std::uint32_t& flags);
  /// One inverse-iteration step on every block at once with A + shift E: the iterate
  /// normalised per block, each block's Rayleigh quotient minus the shift in block_lambda_;
  /// returns whether a block near the threshold still turned.
  bool block_iteration_step(int m, int blocks, double shift);
  /// Sets every entry of row_damping to zero unless they are.
  void clear_row_damping();
  /// Scales each block's task part to the speed limits on its own; returns the smallest factor.
  double scale_task_blocks();

  const Model& model_;
  SolverParameters parameters_;
  int max_rows_;
  /// Kernel of A = J W^-1 J^T = H^T H, chosen for this CPU at construction (AVX2/FMA or portable).
  void (*gram_)(const double* Jt, const double* Jwt, Eigen::Index ld, int m, int n, const int* extent, double* A,
                Eigen::Index lda);
  /// Kernel of H y and H u, chosen likewise.
  void (*transpose_products_)(const double* Jwt, Eigen::Index ld, int m, int n, const double* y1, const double* y2,
                              double* x1, double* x2);
  /// Kernel of the cycle's three triangular solves (task, null space, inverse iteration), chosen likewise.
  void (*three_solves_)(const double* L, Eigen::Index ld, const double* inv_d, int m, const double* b0,
                        const double* b1, const double* b2, double* x0, double* x1, double* x2, double* X);
  std::unique_ptr<internal::UnitRowElimination> elimination_;  // joint rows, solved exactly outside A
  std::unique_ptr<internal::RowBlocks> blocks_;  // independent blocks of the kept rows
  // Per row: the blocks' iterate, its step and reduced form; per block: sigma_min^2, damping
  // mu^2, and sums of the iteration and the task bound; per kept row the diagonal's change,
  // per eliminated row its damping before and now (the block path of resolve()).
  Eigen::VectorXd block_v_, block_w_, block_z_, block_lambda_, block_mu2_, block_sum1_, block_sum2_;
  Eigen::VectorXd block_change_, block_old_, elim_mu2_;
  std::vector<int> row_block_;  // per row: its block, -1 for an isolated row
  int block_rows_ = -1;         // the row count of the block path's last iterate
  bool row_damping_zero_ = true;  // every entry of out_.row_damping is zero
  std::vector<int> dof_block_;  // per dof: its block of rows for the speed scaling (-1: none)
  int task_blocks_ = 1;         // the number of those blocks in the last resolve() (<= m + 1)
  Mask free_;                 // b_C, plus dofs frozen at their limits
  Mask frozen_at_limit_;      // the dofs frozen at their limits in the last solve
  bool any_frozen_at_limit_ = false;
  Eigen::VectorXd w_;         // W^-1 diagonal with frozen dofs zeroed
  Eigen::VectorXd range_;     // r_i: W^-1 = diag(r_i^2)
  Eigen::VectorXd range_sq_;  // r_i^2
  std::vector<int> free_index_;  // the free dofs, in order
  std::vector<int> remaining_index_;  // the free dofs without those of eliminated rows
  std::vector<int> extent_;      // per task row: 1 + its last free dof with a non-zero entry
  std::vector<char> single_entry_;  // per task row: at most one non-zero entry in H
  // Over the free dofs, zero-padded to a multiple of four: H = W^-1/2 J^T ((n+3) x m),
  // W^-1/2 dH/dq, H y and H u.
  Eigen::MatrixXd H_;
  Eigen::VectorXd gradient_free_, task_free_, null_free_;
  Eigen::VectorXd zero_column_;  // max rows zeros: the padding column
  Eigen::MatrixXd A_;   // J W^-1 J^T (lower triangle used)
  // A = L D L^T: L unit lower triangular and E = L D, below the diagonal (row-major).
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> L_, E_;
  Eigen::VectorXd pivot_;             // running pivots during the factorisation
  Eigen::VectorXd inverse_diagonal_;  // D^-1
  Eigen::VectorXd interleaved_;       // the three right-hand sides of three_solves_, four entries per row
  Eigen::VectorXd y_, v_, g_, u_, u_rhs_, z_;  // z_: the kept part of v
  Eigen::VectorXd step_;                       // w = A^-1 v, the inverse-iteration step
  Eigen::VectorXd previous_null_;
  Eigen::VectorXd previous_qdot_;  // the last solve's q_dot and x_dot (adapt_damping)
  Eigen::VectorXd previous_xdot_;
  Eigen::VectorXd previous_change_;  // q_dot's change in the last solve (adapt_damping)
  int alternations_ = 0;             // solves in a row whose change turned back and grew
  int previous_xdot_rows_ = -1;
  Eigen::VectorXd braking_time_per_rate_;  // 1 / (k v_max,i): the braking distance is v |v| times this
  double damping_factor_ = 1.0;   // times lambda^2 from sigma_min, while near a singularity
  double raised_at_rate_ = 1.0;   // |x_dot| when it was last raised
  double effective_damping_factor_ = 1.0;  // this solve's: scaled by |x_dot| / raised_at_rate_
  int previous_rows_ = -1;
  SolverOutput out_;
};

/// q_next = q + q_dot dt, clamped to the position limits (IV.E); continuous joints are
/// not clamped. Sets kJointLimitClamped in the returned flags when a joint was clamped
/// (by more than rounding: a step that lands on a limit may round past it by an ulp).
std::uint32_t integrate(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                        const Eigen::Ref<const Eigen::VectorXd>& qdot, double dt, Eigen::Ref<Eigen::VectorXd> q_next);

}  // namespace wbm
