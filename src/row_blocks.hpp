#pragma once
/// @file
/// Internal (not installed): the independent blocks of the solver's task rows. Two kept rows
/// are in one block if the kept rows' matrix A couples them (A_ij != 0) or an eliminated
/// joint row has coupling entries at both (unit_row_elimination.hpp), directly or through
/// other rows; rows of different blocks have no free dof in common (a dual-arm robot on a
/// fixed base: one block per arm), the full A is block diagonal, and each block is damped by
/// its own smallest singular value (docs/solver.md, "Independent blocks of rows").

#include <vector>

#include <Eigen/Core>

namespace wbm::internal {

class UnitRowElimination;

class RowBlocks {
 public:
  explicit RowBlocks(int max_rows);

  /// Finds the blocks of the kept rows from the mk x mk matrix A (its lower triangle,
  /// column-major, leading dimension lda) and the eliminated rows' couplings, and returns
  /// their number. The common case, every row coupled to the first one in A, is one pass
  /// over A's first column. Never allocates.
  int find(const double* A, Eigen::Index lda, int mk, const UnitRowElimination& elimination) {
    int zeros = 0;  // in A's first column below the diagonal (no branch per entry)
    for (int i = 1; i < mk; ++i) zeros += A[i] == 0.0;
    if (zeros == 0) {
      unchanged_ = count_ == 1 && mk == previous_rows_;
      count_ = 1;
      previous_rows_ = mk;
      return 1;
    }
    return find_blocks(A, lda, mk, elimination);
  }
  /// Whether the blocks are those of the find() before the last (same count and labels).
  bool unchanged() const { return unchanged_; }
  /// Block of row j (0 .. count - 1, in the order of the blocks' first rows), after a
  /// find() that returned more than 1.
  int block(int j) const { return label_[j]; }

 private:
  int find_blocks(const double* A, Eigen::Index lda, int mk, const UnitRowElimination& elimination);
  int root(int j);
  std::vector<int> parent_, label_, previous_label_;
  int count_ = 1, previous_rows_ = -1;
  bool unchanged_ = false;
};

}  // namespace wbm::internal
