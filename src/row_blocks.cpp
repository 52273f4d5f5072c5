#include "row_blocks.hpp"

#include <algorithm>

#include "unit_row_elimination.hpp"

namespace wbm::internal {

RowBlocks::RowBlocks(int max_rows) : parent_(max_rows), label_(max_rows), previous_label_(max_rows) {}

int RowBlocks::root(int j) {
  while (parent_[j] != j) j = parent_[j] = parent_[parent_[j]];  // path halving
  return j;
}

int RowBlocks::find_blocks(const double* A, Eigen::Index lda, int mk, const UnitRowElimination& elimination) {
  // Not every row is coupled to the first: union-find over A's entries and the couplings.
  const int previous_count = count_;
  for (int j = 0; j < mk; ++j) parent_[j] = j;
  int components = mk;
  auto unite = [&](int i, int j) {
    const int a = root(i), b = root(j);
    if (a == b) return;
    parent_[std::max(a, b)] = std::min(a, b);
    --components;
  };
  for (int j = 0; j < mk && components > 1; ++j)
    for (int i = j + 1; i < mk; ++i)
      if (A[i + j * lda] != 0.0) unite(i, j);
  // An eliminated row couples the kept rows with entries at its dof (its Schur complement
  // term b_k b_k^T), which A, over the other dofs, does not show.
  for (int k = 0; k < elimination.num_eliminated() && components > 1; ++k) {
    const double* b = elimination.coupling(k);
    int first = -1;
    for (int j = 0; j < mk; ++j) {
      if (b[j] == 0.0) continue;
      if (first < 0)
        first = j;
      else
        unite(j, first);
    }
  }
  // Labels in the order of the blocks' first rows: a root is its block's first row.
  count_ = 0;
  for (int j = 0; j < mk; ++j) {
    const int r = root(j);
    label_[j] = r == j ? count_++ : label_[r];
  }
  unchanged_ = count_ == previous_count && mk == previous_rows_ &&
               (count_ == 1 || std::equal(label_.begin(), label_.begin() + mk, previous_label_.begin()));
  if (count_ > 1) std::copy_n(label_.begin(), mk, previous_label_.begin());
  previous_rows_ = mk;
  return count_;
}

}  // namespace wbm::internal
