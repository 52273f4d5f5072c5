#include "dot_kernels.hpp"

#include <algorithm>

namespace wbm::internal {

void weighted_gram_portable(const double* Jt, const double* Jwt, Eigen::Index ld, int m, int /*n*/,
                            const int* extent, double* A, Eigen::Index lda) {
  // 2 x 2 blocks: one pass over the dofs gives four entries.
  for (int j = 0; j < m; j += 2) {
    const int j1 = std::min(j + 1, m - 1);
    for (int i = j; i < m; i += 2) {
      const int i1 = std::min(i + 1, m - 1);
      double s[4];
      four_dot_products(Jt + j * ld, Jt + j1 * ld, Jwt + i * ld, Jwt + i1 * ld, block_extent(extent, j, j1, i, i1), s);
      A[j * lda + i] = s[0];
      A[j1 * lda + i] = s[1];
      A[j * lda + i1] = s[2];
      A[j1 * lda + i1] = s[3];
    }
  }
}

void transpose_products_portable(const double* Jwt, Eigen::Index ld, int m, int n, const double* y1,
                                 const double* y2, double* x1, double* x2) {
  for (int c = 0; c < n; c += 4) {
#if defined(__GNUC__)
    Lanes t0 = {0.0, 0.0}, t1 = t0, u0 = t0, u1 = t0;
    for (int i = 0; i < m; ++i) {
      const double* column = Jwt + i * ld + c;
      const Lanes a = load_lanes(column), b = load_lanes(column + 2);
      const Lanes s1 = {y1[i], y1[i]}, s2 = {y2[i], y2[i]};
      t0 += a * s1;
      t1 += b * s1;
      u0 += a * s2;
      u1 += b * s2;
    }
    __builtin_memcpy(x1 + c, &t0, sizeof t0);
    __builtin_memcpy(x1 + c + 2, &t1, sizeof t1);
    __builtin_memcpy(x2 + c, &u0, sizeof u0);
    __builtin_memcpy(x2 + c + 2, &u1, sizeof u1);
#else
    for (int k = c; k < c + 4; ++k) x1[k] = x2[k] = 0.0;
    for (int i = 0; i < m; ++i)
      for (int k = c; k < c + 4; ++k) {
        x1[k] += Jwt[i * ld + k] * y1[i];
        x2[k] += Jwt[i * ld + k] * y2[i];
      }
#endif
  }
}

#if defined(__GNUC__) && defined(__x86_64__)

namespace {

using Lanes4 = double __attribute__((vector_size(32)));

__attribute__((target("avx2,fma"))) inline Lanes4 load4(const double* p) {
  Lanes4 v;
  __builtin_memcpy(&v, p, sizeof v);
  return v;
}

__attribute__((target("avx2,fma"))) inline double sum4(Lanes4 v) { return (v[0] + v[2]) + (v[1] + v[3]); }

/// out[0] = sum of a's lanes, out[1] = sum of b's lanes: interleave, add, fold the halves.
__attribute__((target("avx2,fma"))) inline void store_pair_sums(Lanes4 a, Lanes4 b, double* out) {
  const Lanes4 pairs = __builtin_shufflevector(a, b, 0, 4, 2, 6) + __builtin_shufflevector(a, b, 1, 5, 3, 7);
  const Lanes sums = __builtin_shufflevector(pairs, pairs, 0, 1) + __builtin_shufflevector(pairs, pairs, 2, 3);
  __builtin_memcpy(out, &sums, sizeof sums);
}

__attribute__((target("avx2,fma"))) void weighted_gram_avx2_kernel(const double* Jt, const double* Jwt,
                                                                   Eigen::Index ld, int m, int /*n*/,
                                                                   const int* extent, double* A, Eigen::Index lda) {
  for (int j = 0; j < m; j += 2) {
    const int j1 = std::min(j + 1, m - 1);
    const double* a0 = Jt + j * ld;
    const double* a1 = Jt + j1 * ld;
    for (int i = j; i < m; i += 2) {
      const int i1 = std::min(i + 1, m - 1);
      const double* b0 = Jwt + i * ld;
      const double* b1 = Jwt + i1 * ld;
      const int length = block_extent(extent, j, j1, i, i1);
      Lanes4 s00 = {0.0, 0.0, 0.0, 0.0}, s01 = s00, s10 = s00, s11 = s00;
      for (int k = 0; k < length; k += 4) {
        const Lanes4 x0 = load4(a0 + k), x1 = load4(a1 + k);
        const Lanes4 y0 = load4(b0 + k), y1 = load4(b1 + k);
        s00 += y0 * x0;
        s01 += y0 * x1;
        s10 += y1 * x0;
        s11 += y1 * x1;
      }
      if (i1 == i + 1) {
        // Rows i and i + 1 of columns j and j1 are neighbours in A: the four sums pairwise,
        // two stores.
        store_pair_sums(s00, s10, A + j * lda + i);
        store_pair_sums(s01, s11, A + j1 * lda + i);
      } else {
        A[j * lda + i] = sum4(s00);
        A[j1 * lda + i] = sum4(s01);
      }
    }
  }
}

__attribute__((target("avx2,fma"))) void transpose_products_avx2_kernel(const double* Jwt, Eigen::Index ld, int m,
                                                                        int n, const double* y1, const double* y2,
                                                                        double* x1, double* x2) {
  for (int c = 0; c < n; c += 4) {
    Lanes4 t = {0.0, 0.0, 0.0, 0.0}, u = t;
    for (int i = 0; i < m; ++i) {
      const Lanes4 a = load4(Jwt + i * ld + c);
      const Lanes4 s1 = {y1[i], y1[i], y1[i], y1[i]}, s2 = {y2[i], y2[i], y2[i], y2[i]};
      t += a * s1;
      u += a * s2;
    }
    __builtin_memcpy(x1 + c, &t, sizeof t);
    __builtin_memcpy(x2 + c, &u, sizeof u);
  }
}

bool cpu_has_avx2_fma() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}

}  // namespace

GramKernel weighted_gram_avx2() { return &weighted_gram_avx2_kernel; }
TransposeProductsKernel transpose_products_avx2() { return &transpose_products_avx2_kernel; }
TransposeProductsKernel select_transpose_products() {
  return cpu_has_avx2_fma() ? &transpose_products_avx2_kernel : &transpose_products_portable;
}

GramKernel select_weighted_gram() { return cpu_has_avx2_fma() ? &weighted_gram_avx2_kernel : &weighted_gram_portable; }

#else

GramKernel weighted_gram_avx2() { return nullptr; }
GramKernel select_weighted_gram() { return &weighted_gram_portable; }
TransposeProductsKernel transpose_products_avx2() { return nullptr; }
TransposeProductsKernel select_transpose_products() { return &transpose_products_portable; }

#endif

}  // namespace wbm::internal
