#include "dot_kernels.hpp"

#include <algorithm>

namespace wbm::internal {

void weighted_gram_portable(const double* Jt, const double* Jwt, Eigen::Index ld, int m, int n, double* A,
                            Eigen::Index lda) {
  // 2 x 2 blocks: one pass over the dofs gives four entries.
  for (int j = 0; j < m; j += 2) {
    const int j1 = std::min(j + 1, m - 1);
    for (int i = j; i < m; i += 2) {
      const int i1 = std::min(i + 1, m - 1);
      double s[4];
      four_dot_products(Jt + j * ld, Jt + j1 * ld, Jwt + i * ld, Jwt + i1 * ld, n, s);
      A[j * lda + i] = s[0];
      A[j1 * lda + i] = s[1];
      A[j * lda + i1] = s[2];
      A[j1 * lda + i1] = s[3];
    }
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

__attribute__((target("avx2,fma"))) void weighted_gram_avx2_kernel(const double* Jt, const double* Jwt,
                                                                   Eigen::Index ld, int m, int n, double* A,
                                                                   Eigen::Index lda) {
  for (int j = 0; j < m; j += 2) {
    const int j1 = std::min(j + 1, m - 1);
    const double* a0 = Jt + j * ld;
    const double* a1 = Jt + j1 * ld;
    for (int i = j; i < m; i += 2) {
      const int i1 = std::min(i + 1, m - 1);
      const double* b0 = Jwt + i * ld;
      const double* b1 = Jwt + i1 * ld;
      Lanes4 s00 = {0.0, 0.0, 0.0, 0.0}, s01 = s00, s10 = s00, s11 = s00;
      for (int k = 0; k < n; k += 4) {
        const Lanes4 x0 = load4(a0 + k), x1 = load4(a1 + k);
        const Lanes4 y0 = load4(b0 + k), y1 = load4(b1 + k);
        s00 += y0 * x0;
        s01 += y0 * x1;
        s10 += y1 * x0;
        s11 += y1 * x1;
      }
      A[j * lda + i] = sum4(s00);
      A[j1 * lda + i] = sum4(s01);
      A[j * lda + i1] = sum4(s10);
      A[j1 * lda + i1] = sum4(s11);
    }
  }
}

}  // namespace

GramKernel weighted_gram_avx2() { return &weighted_gram_avx2_kernel; }

GramKernel select_weighted_gram() {
  __builtin_cpu_init();
  const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return avx2 ? &weighted_gram_avx2_kernel : &weighted_gram_portable;
}

#else

GramKernel weighted_gram_avx2() { return nullptr; }
GramKernel select_weighted_gram() { return &weighted_gram_portable; }

#endif

}  // namespace wbm::internal
