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

void three_solves_portable(const double* L, Eigen::Index ld, const double* inv_d, int m, const double* b0,
                           const double* b1, const double* b2, double* x0, double* x1, double* x2, double* X) {
  const double* const b[3] = {b0, b1, b2};
  double* const x[3] = {x0, x1, x2};
  for (int i = 0; i < m; ++i)
    for (int r = 0; r < 3; ++r) X[4 * i + r] = b[r][i];
  // Forward, L z = b, by rows (inner products), then z / D, then backward, L^T x = y, by
  // rows of L (x_k -= L_ik x_i for k < i).
  for (int i = 1; i < m; ++i) {
    const double* Li = L + i * ld;
    double* Xi = X + 4 * i;
    for (int k = 0; k < i; ++k)
      for (int r = 0; r < 3; ++r) Xi[r] -= Li[k] * X[4 * k + r];
  }
  for (int i = 0; i < m; ++i)
    for (int r = 0; r < 3; ++r) X[4 * i + r] *= inv_d[i];
  for (int i = m - 1; i > 0; --i) {
    const double* Li = L + i * ld;
    const double* Xi = X + 4 * i;
    for (int k = 0; k < i; ++k)
      for (int r = 0; r < 3; ++r) X[4 * k + r] -= Li[k] * Xi[r];
  }
  for (int i = 0; i < m; ++i)
    for (int r = 0; r < 3; ++r) x[r][i] = X[4 * i + r];
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

__attribute__((target("avx2,fma"))) inline void store4(double* p, Lanes4 v) { __builtin_memcpy(p, &v, sizeof v); }

__attribute__((target("avx2,fma"))) void three_solves_avx2_kernel(const double* L, Eigen::Index ld,
                                                                  const double* inv_d, int m, const double* b0,
                                                                  const double* b1, const double* b2, double* x0,
                                                                  double* x1, double* x2, double* X) {
  // Interleave four rows at a time: a 4 x 4 transpose of (x0, x1, x2, 0).
  const Lanes4 zero = {0.0, 0.0, 0.0, 0.0};
  int i0 = 0;
  for (; i0 + 3 < m; i0 += 4) {
    const Lanes4 a = load4(b0 + i0), b = load4(b1 + i0), c = load4(b2 + i0);
    const Lanes4 t0 = __builtin_shufflevector(a, b, 0, 4, 2, 6), t1 = __builtin_shufflevector(a, b, 1, 5, 3, 7);
    const Lanes4 t2 = __builtin_shufflevector(c, zero, 0, 4, 2, 6), t3 = __builtin_shufflevector(c, zero, 1, 5, 3, 7);
    store4(X + 4 * i0, __builtin_shufflevector(t0, t2, 0, 1, 4, 5));
    store4(X + 4 * i0 + 4, __builtin_shufflevector(t1, t3, 0, 1, 4, 5));
    store4(X + 4 * i0 + 8, __builtin_shufflevector(t0, t2, 2, 3, 6, 7));
    store4(X + 4 * i0 + 12, __builtin_shufflevector(t1, t3, 2, 3, 6, 7));
  }
  for (int i = i0; i < m; ++i) store4(X + 4 * i, Lanes4{b0[i], b1[i], b2[i], 0.0});
  // One operation per entry of L for all three right-hand sides. Forward: two partial sums
  // per row halve its dependency chain.
  for (int i = 1; i < m; ++i) {
    const double* Li = L + i * ld;
    Lanes4 s = load4(X + 4 * i), t = {0.0, 0.0, 0.0, 0.0};
    int k = 0;
    for (; k + 1 < i; k += 2) {
      s -= Li[k] * load4(X + 4 * k);
      t -= Li[k + 1] * load4(X + 4 * k + 4);
    }
    if (k < i) s -= Li[k] * load4(X + 4 * k);
    store4(X + 4 * i, s + t);
  }
  for (int i = 0; i < m; ++i) store4(X + 4 * i, load4(X + 4 * i) * inv_d[i]);
  // Backward: the updates of one row of L are independent of each other.
  for (int i = m - 1; i > 0; --i) {
    const double* Li = L + i * ld;
    const Lanes4 xi = load4(X + 4 * i);
    for (int k = 0; k < i; ++k) store4(X + 4 * k, load4(X + 4 * k) - Li[k] * xi);
  }
  // And back (the inverse transpose).
  for (int i = 0; i < i0; i += 4) {
    const Lanes4 r0 = load4(X + 4 * i), r1 = load4(X + 4 * i + 4), r2 = load4(X + 4 * i + 8),
                 r3 = load4(X + 4 * i + 12);
    const Lanes4 t0 = __builtin_shufflevector(r0, r1, 0, 4, 2, 6), t1 = __builtin_shufflevector(r0, r1, 1, 5, 3, 7);
    const Lanes4 t2 = __builtin_shufflevector(r2, r3, 0, 4, 2, 6), t3 = __builtin_shufflevector(r2, r3, 1, 5, 3, 7);
    store4(x0 + i, __builtin_shufflevector(t0, t2, 0, 1, 4, 5));
    store4(x1 + i, __builtin_shufflevector(t1, t3, 0, 1, 4, 5));
    store4(x2 + i, __builtin_shufflevector(t0, t2, 2, 3, 6, 7));
  }
  for (int i = i0; i < m; ++i) {
    x0[i] = X[4 * i];
    x1[i] = X[4 * i + 1];
    x2[i] = X[4 * i + 2];
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

ThreeSolvesKernel three_solves_avx2() { return &three_solves_avx2_kernel; }
ThreeSolvesKernel select_three_solves() {
  return cpu_has_avx2_fma() ? &three_solves_avx2_kernel : &three_solves_portable;
}

#else

GramKernel weighted_gram_avx2() { return nullptr; }
GramKernel select_weighted_gram() { return &weighted_gram_portable; }
TransposeProductsKernel transpose_products_avx2() { return nullptr; }
TransposeProductsKernel select_transpose_products() { return &transpose_products_portable; }
ThreeSolvesKernel three_solves_avx2() { return nullptr; }
ThreeSolvesKernel select_three_solves() { return &three_solves_portable; }

#endif

}  // namespace wbm::internal
