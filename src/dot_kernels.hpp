#pragma once
/// @file
/// Internal (not installed): the small inner-product kernels of the solver, and the
/// kernels of A = J W^-1 J^T and of W^-1 J^T y with CPU-dispatched AVX2/FMA variants.

#include <algorithm>

#include <Eigen/Core>

namespace wbm::internal {

#if defined(__GNUC__)
// Two doubles per operation (SSE2 on x86-64, NEON on AArch64) through the GCC/Clang vector
// extension: the compiler may not reorder floating-point sums itself, so the two lanes of
// the reductions below are spelled out (other compilers: the plain loops).
using Lanes = double __attribute__((vector_size(16)));
inline Lanes load_lanes(const double* p) {
  Lanes v;
  __builtin_memcpy(&v, p, sizeof v);
  return v;
}
#endif

/// p[0] = a, p[1] = b as one 16-byte store where the vector extension exists. Rows that the
/// two-lane kernels read back in pairs soon after must be written in such pairs: a 16-byte
/// load is not forwarded from two 8-byte stores and waits until both reach the cache.
inline void store_pair(double* p, double a, double b) {
#if defined(__GNUC__)
  const Lanes v = {a, b};
  __builtin_memcpy(p, &v, sizeof v);
#else
  p[0] = a;
  p[1] = b;
#endif
}

/// true if all n entries are finite: x * 0 is +-0 for finite x and NaN for inf and NaN, so
/// the sum is 0 exactly when all are finite. Two independent sums, no branch per entry
/// (Eigen's allFinite() compares entry by entry with an early exit).
inline bool all_finite(const double* x, int n) {
  double s0 = 0.0, s1 = 0.0;
  int i = 0;
  for (; i + 1 < n; i += 2) {
    s0 += x[i] * 0.0;
    s1 += x[i + 1] * 0.0;
  }
  if (i < n) s0 += x[i] * 0.0;
  return s0 + s1 == 0.0;
}

/// Four inner products of two pairs of vectors of n entries: s = {b0.a0, b0.a1, b1.a0, b1.a1}.
inline void four_dot_products(const double* a0, const double* a1, const double* b0, const double* b1, int n,
                              double s[4]) {
  int k = 0;
#if defined(__GNUC__)
  Lanes s00 = {0.0, 0.0}, s01 = s00, s10 = s00, s11 = s00;
  for (; k + 1 < n; k += 2) {
    const Lanes x0 = load_lanes(a0 + k), x1 = load_lanes(a1 + k);
    const Lanes y0 = load_lanes(b0 + k), y1 = load_lanes(b1 + k);
    s00 += y0 * x0;
    s01 += y0 * x1;
    s10 += y1 * x0;
    s11 += y1 * x1;
  }
  s[0] = s00[0] + s00[1];
  s[1] = s01[0] + s01[1];
  s[2] = s10[0] + s10[1];
  s[3] = s11[0] + s11[1];
#else
  s[0] = s[1] = s[2] = s[3] = 0.0;
#endif
  for (; k < n; ++k) {
    s[0] += b0[k] * a0[k];
    s[1] += b0[k] * a1[k];
    s[2] += b1[k] * a0[k];
    s[3] += b1[k] * a1[k];
  }
}

/// out[i * ld] = {r0 a[i], r1 b[i]} for i < m: two columns (a, b) of a column-major matrix,
/// scaled, as two neighbouring entries of each of m rows (a 2 x 2 transpose per two rows).
inline void scaled_transpose_two_columns(const double* a, const double* b, double r0, double r1, int m, double* out,
                                         Eigen::Index ld) {
  int i = 0;
#if defined(__GNUC__)
  const Lanes s0 = {r0, r0}, s1 = {r1, r1};
  for (; i + 1 < m; i += 2) {
    const Lanes x = load_lanes(a + i) * s0, y = load_lanes(b + i) * s1;
    const Lanes row0 = __builtin_shufflevector(x, y, 0, 2), row1 = __builtin_shufflevector(x, y, 1, 3);
    __builtin_memcpy(out + i * ld, &row0, sizeof row0);
    __builtin_memcpy(out + (i + 1) * ld, &row1, sizeof row1);
  }
#endif
  for (; i < m; ++i) {
    out[i * ld] = r0 * a[i];
    out[i * ld + 1] = r1 * b[i];
  }
}

/// Two inner products of n entries: s = {b0.a, b1.a}.
inline void two_dot_products(const double* a, const double* b0, const double* b1, int n, double s[2]) {
  int k = 0;
#if defined(__GNUC__)
  Lanes s0 = {0.0, 0.0}, s1 = s0;
  for (; k + 1 < n; k += 2) {
    const Lanes x = load_lanes(a + k);
    s0 += load_lanes(b0 + k) * x;
    s1 += load_lanes(b1 + k) * x;
  }
  s[0] = s0[0] + s0[1];
  s[1] = s1[0] + s1[1];
#else
  s[0] = s[1] = 0.0;
#endif
  for (; k < n; ++k) {
    s[0] += b0[k] * a[k];
    s[1] += b1[k] * a[k];
  }
}


/// Lower triangle (and the entries next to it in 2 x 2 blocks) of A = Jt^T Jwt: Jt and Jwt
/// are n x m column-major with leading dimension ld, n a multiple of 4 (zero-padded); A is
/// column-major with leading dimension lda. extent[i] <= n: entries from extent[i] on of
/// column i are zero in both, and the sums skip them (in blocks of four).
using GramKernel = void (*)(const double* Jt, const double* Jwt, Eigen::Index ld, int m, int n, const int* extent,
                            double* A, Eigen::Index lda);
/// Two-lane version (SSE2 on x86-64; any CPU).
void weighted_gram_portable(const double* Jt, const double* Jwt, Eigen::Index ld, int m, int n, const int* extent,
                            double* A, Eigen::Index lda);
/// Length of the sums of the 2 x 2 block of columns (j, j1) x (i, i1): where both pairs
/// still have non-zero entries, rounded up to a multiple of four (<= n).
inline int block_extent(const int* extent, int j, int j1, int i, int i1) {
  const int a = std::max(extent[j], extent[j1]), b = std::max(extent[i], extent[i1]);
  return (std::min(a, b) + 3) & ~3;
}
/// Four-lane AVX2/FMA version, or nullptr where it is not compiled in (not x86-64 GCC/Clang).
GramKernel weighted_gram_avx2();
/// The AVX2/FMA kernel if this CPU has AVX2 and FMA, else the portable one. The results
/// differ only in the order of the sums (a few ulp).
GramKernel select_weighted_gram();

/// x1 = Jwt y1 and x2 = Jwt y2 (n entries each, n a multiple of 4): Jwt is n x m
/// column-major with leading dimension ld. Accumulates in registers, four rows at a time.
using TransposeProductsKernel = void (*)(const double* Jwt, Eigen::Index ld, int m, int n, const double* y1,
                                         const double* y2, double* x1, double* x2);
void transpose_products_portable(const double* Jwt, Eigen::Index ld, int m, int n, const double* y1,
                                 const double* y2, double* x1, double* x2);
/// AVX2/FMA version, or nullptr where it is not compiled in.
TransposeProductsKernel transpose_products_avx2();
/// As select_weighted_gram().
TransposeProductsKernel select_transpose_products();

/// Solves L D L^T x_r = b_r for three right-hand sides (m entries each) in one pass over L:
/// b0, b1, b2 are interleaved into X (m rows of four entries, the fourth unused; 4 m entries
/// of scratch), solved there and written to x0, x1, x2 (each x_r may be its b_r: in place).
/// Separate inputs spare the caller a copy just before: the kernel's 32-byte loads of a
/// vector just written in 16-byte halves would wait for failed store-to-load forwarding.
/// L is unit lower triangular, row-major with leading dimension ld (only the part below the
/// diagonal is read); inv_d holds the m reciprocal pivots 1 / D_i.
using ThreeSolvesKernel = void (*)(const double* L, Eigen::Index ld, const double* inv_d, int m, const double* b0,
                                   const double* b1, const double* b2, double* x0, double* x1, double* x2, double* X);
/// Plain loops (any CPU).
void three_solves_portable(const double* L, Eigen::Index ld, const double* inv_d, int m, const double* b0,
                           const double* b1, const double* b2, double* x0, double* x1, double* x2, double* X);
/// Four-lane AVX2/FMA version (a row of X per operation), or nullptr where it is not compiled in.
ThreeSolvesKernel three_solves_avx2();
/// As select_weighted_gram().
ThreeSolvesKernel select_three_solves();

}  // namespace wbm::internal
