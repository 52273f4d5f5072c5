#pragma once
/// @file
/// Internal (not installed): clearing the small strided Jacobian blocks of the cycle.

#include <Eigen/Core>

namespace wbm::internal {

/// Zeroes R entries of each column from data to end (outer stride `stride`), as R plain stores
/// per column (a fixed-size inner loop is unrolled, not turned into a memset call).
template <int R>
inline void zero_columns(double* data, const double* end, Eigen::Index stride) {
  for (double* col = data; col != end; col += stride)
    for (int r = 0; r < R; ++r) col[r] = 0.0;
}

/// Sets a rows x cols block with outer stride `stride` to zero. Row counts up to 8 (every
/// task element's, and joint rows of up to 8 dofs) are written as plain stores, one loop
/// per row count: a generic inner loop becomes one memset call per column (G1's posture
/// element of 5 joint rows: 26 calls per cycle), which costs more than the stores
/// themselves, and a switch inside the loop over columns cost a branch per column.
inline void zero_block(double* data, Eigen::Index rows, Eigen::Index cols, Eigen::Index stride) {
  if (rows == stride) {
    for (Eigen::Index i = 0; i < rows * cols; ++i) data[i] = 0.0;
    return;
  }
  // One loop per row count (the switch outside the loop over columns).
  const double* end = data + cols * stride;
  switch (rows) {
    case 1: return zero_columns<1>(data, end, stride);
    case 2: return zero_columns<2>(data, end, stride);
    case 3: return zero_columns<3>(data, end, stride);
    case 4: return zero_columns<4>(data, end, stride);
    case 5: return zero_columns<5>(data, end, stride);
    case 6: return zero_columns<6>(data, end, stride);
    case 7: return zero_columns<7>(data, end, stride);
    case 8: return zero_columns<8>(data, end, stride);
    default:
      for (double* col = data; col != end; col += stride)
        for (Eigen::Index r = 0; r < rows; ++r) col[r] = 0.0;
  }
}

inline void zero_block(Eigen::Ref<Eigen::MatrixXd> J) { zero_block(J.data(), J.rows(), J.cols(), J.outerStride()); }

}  // namespace wbm::internal
