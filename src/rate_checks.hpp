#pragma once
/// @file
/// Internal (not installed): the per-dof checks after a solve, one pass each over the dofs
/// without a branch per dof, two dofs per operation (SSE2; plain loops elsewhere). Each
/// answers "does any dof need the slow path?"; in the common case none does, and these
/// passes are all the limits cost (the loops with a branch per dof they replace cost about
/// 520 more instructions per paper-model cycle, 710 per G1 cycle).
/// NaN entries compare false throughout: they never ask for the slow path (the solver's
/// final check for finite rates catches them).

#include <algorithm>
#include <cmath>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace wbm::internal {

#if defined(__SSE2__)
inline __m128d abs_lanes(__m128d x) { return _mm_andnot_pd(_mm_set1_pd(-0.0), x); }
#endif

/// true if |a x_i + y_i| > s bound_i for some i < n.
inline bool any_combination_exceeds(double a, const double* x, const double* y, double s, const double* bound,
                                    int n) {
  int i = 0;
  bool exceeded = false;
#if defined(__SSE2__)
  const __m128d va = _mm_set1_pd(a), vs = _mm_set1_pd(s);
  __m128d any = _mm_setzero_pd();
  for (; i + 1 < n; i += 2) {
    const __m128d v = _mm_add_pd(_mm_mul_pd(va, _mm_loadu_pd(x + i)), _mm_loadu_pd(y + i));
    any = _mm_or_pd(any, _mm_cmpgt_pd(abs_lanes(v), _mm_mul_pd(vs, _mm_loadu_pd(bound + i))));
  }
  exceeded = _mm_movemask_pd(any) != 0;
#endif
  for (; i < n; ++i) exceeded |= std::abs(a * x[i] + y[i]) > s * bound[i];
  return exceeded;
}

/// true if |x_i| > bound_i for some i < n.
inline bool any_exceeds(const double* x, const double* bound, int n) {
  int i = 0;
  bool exceeded = false;
#if defined(__SSE2__)
  __m128d any = _mm_setzero_pd();
  for (; i + 1 < n; i += 2)
    any = _mm_or_pd(any, _mm_cmpgt_pd(abs_lanes(_mm_loadu_pd(x + i)), _mm_loadu_pd(bound + i)));
  exceeded = _mm_movemask_pd(any) != 0;
#endif
  for (; i < n; ++i) exceeded |= std::abs(x[i]) > bound[i];
  return exceeded;
}

/// true if |v_i - (last_i - external_i)| > k_dt vmax_i for some i < n: a rate changed by
/// more than the bound against the one realised last cycle (the Controller's bound).
inline bool rate_change_exceeds(const double* v, const double* last, const double* external, const double* vmax,
                                double k_dt, int n) {
  int i = 0;
  bool exceeded = false;
#if defined(__SSE2__)
  const __m128d k = _mm_set1_pd(k_dt);
  __m128d any = _mm_setzero_pd();
  for (; i + 1 < n; i += 2) {
    const __m128d d = _mm_sub_pd(_mm_loadu_pd(v + i), _mm_sub_pd(_mm_loadu_pd(last + i), _mm_loadu_pd(external + i)));
    any = _mm_or_pd(any, _mm_cmpgt_pd(abs_lanes(d), _mm_mul_pd(k, _mm_loadu_pd(vmax + i))));
  }
  exceeded = _mm_movemask_pd(any) != 0;
#endif
  for (; i < n; ++i) exceeded |= std::abs(v[i] - (last[i] - external[i])) > k_dt * vmax[i];
  return exceeded;
}

/// true if some dof i < n at or beyond a limit (q_i <= lower_i, q_i >= upper_i) has a rate
/// v_i = x_i + y_i that drives it further out.
inline bool any_driven_outwards(const double* q, const double* x, const double* y, const double* lower,
                                const double* upper, int n) {
  int i = 0;
  bool outwards = false;
#if defined(__SSE2__)
  const __m128d zero = _mm_setzero_pd();
  __m128d any = zero;
  for (; i + 1 < n; i += 2) {
    const __m128d v = _mm_add_pd(_mm_loadu_pd(x + i), _mm_loadu_pd(y + i)), p = _mm_loadu_pd(q + i);
    const __m128d below = _mm_and_pd(_mm_cmple_pd(p, _mm_loadu_pd(lower + i)), _mm_cmplt_pd(v, zero));
    const __m128d above = _mm_and_pd(_mm_cmpge_pd(p, _mm_loadu_pd(upper + i)), _mm_cmpgt_pd(v, zero));
    any = _mm_or_pd(any, _mm_or_pd(below, above));
  }
  outwards = _mm_movemask_pd(any) != 0;
#endif
  for (; i < n; ++i) {
    const double v = x[i] + y[i];
    outwards |= (q[i] <= lower[i] && v < 0.0) || (q[i] >= upper[i] && v > 0.0);
  }
  return outwards;
}

/// true if some dof i < n would pass a limit where it is after this cycle's step or after
/// its braking distance: q_i + v_i max(dt, |v_i| t_i) outside [lower_i, upper_i], with
/// t_i = 1 / (k v_max,i) the braking time per unit of rate.
inline bool any_close_to_a_limit(const double* q, const double* v, const double* t, double dt, const double* lower,
                                 const double* upper, int n) {
  int i = 0;
  bool close = false;
#if defined(__SSE2__)
  const __m128d vdt = _mm_set1_pd(dt);
  __m128d any = _mm_setzero_pd();
  for (; i + 1 < n; i += 2) {
    const __m128d rate = _mm_loadu_pd(v + i);
    // max(dt, x) as std::max(dt, x) gives it: dt unless x > dt (also for NaN x).
    const __m128d time = _mm_max_pd(_mm_mul_pd(abs_lanes(rate), _mm_loadu_pd(t + i)), vdt);
    const __m128d reach = _mm_add_pd(_mm_loadu_pd(q + i), _mm_mul_pd(rate, time));
    any = _mm_or_pd(any, _mm_or_pd(_mm_cmpgt_pd(reach, _mm_loadu_pd(upper + i)),
                                   _mm_cmplt_pd(reach, _mm_loadu_pd(lower + i))));
  }
  close = _mm_movemask_pd(any) != 0;
#endif
  for (; i < n; ++i) {
    const double reach = q[i] + v[i] * std::max(dt, std::abs(v[i]) * t[i]);
    close |= (reach > upper[i]) | (reach < lower[i]);
  }
  return close;
}

}  // namespace wbm::internal
