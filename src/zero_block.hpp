#pragma once
/// @file
/// Internal (not installed): clearing the small strided Jacobian blocks of the cycle.

#include <Eigen/Core>

namespace wbm::internal {

/// Sets a rows x cols block with outer stride `stride` to zero. The row counts of task
/// elements (2, 3, 6) are written as plain stores, one loop per row count: a generic inner
/// loop becomes one memset call per column, which costs more than the stores themselves,
/// and a switch inside the loop over columns cost a branch per column.
inline void zero_block(double* data, Eigen::Index rows, Eigen::Index cols, Eigen::Index stride) {
  if (rows == stride) {
    for (Eigen::Index i = 0; i < rows * cols; ++i) data[i] = 0.0;
    return;
  }
  // One loop per row count (the switch outside the loop over columns).
  const double* end = data + cols * stride;
  switch (rows) {
    case 2:
      for (double* col = data; col != end; col += stride) col[0] = col[1] = 0.0;
      return;
    case 3:
      for (double* col = data; col != end; col += stride) col[0] = col[1] = col[2] = 0.0;
      return;
    case 6:
      for (double* col = data; col != end; col += stride) col[0] = col[1] = col[2] = col[3] = col[4] = col[5] = 0.0;
      return;
    default:
      for (double* col = data; col != end; col += stride)
        for (Eigen::Index r = 0; r < rows; ++r) col[r] = 0.0;
  }
}

inline void zero_block(Eigen::Ref<Eigen::MatrixXd> J) { zero_block(J.data(), J.rows(), J.cols(), J.outerStride()); }

}  // namespace wbm::internal
