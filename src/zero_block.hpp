#pragma once
/// @file
/// Internal (not installed): clearing the small strided Jacobian blocks of the cycle.

#include <Eigen/Core>

namespace wbm::internal {

/// Sets a rows x cols block with outer stride `stride` to zero. The row counts of task
/// elements (2, 3, 6) are written as plain stores: a generic inner loop becomes one
/// memset call per column, which costs more than the stores themselves.
inline void zero_block(double* data, Eigen::Index rows, Eigen::Index cols, Eigen::Index stride) {
  if (rows == stride) {
    for (Eigen::Index i = 0; i < rows * cols; ++i) data[i] = 0.0;
    return;
  }
  for (Eigen::Index c = 0; c < cols; ++c) {
    double* col = data + c * stride;
    switch (rows) {
      case 6:
        col[5] = col[4] = col[3] = 0.0;
        [[fallthrough]];
      case 3:
        col[2] = 0.0;
        [[fallthrough]];
      case 2:
        col[1] = 0.0;
        [[fallthrough]];
      case 1:
        col[0] = 0.0;
        break;
      default:
        for (Eigen::Index r = 0; r < rows; ++r) col[r] = 0.0;
    }
  }
}

inline void zero_block(Eigen::Ref<Eigen::MatrixXd> J) { zero_block(J.data(), J.rows(), J.cols(), J.outerStride()); }

}  // namespace wbm::internal
