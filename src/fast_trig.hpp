#pragma once
/// @file
/// Internal (not installed): the angle between unit vectors, sin and cos for the small
/// angles the filters and axis elements meet every cycle, inline and several times cheaper
/// than the library calls: truncated Taylor series, accurate to a few ulp for
/// |angle| <= kSmallAngle (the truncation error is below 1e-17 relative); the library
/// outside that range. (For joint
/// angles of any size, a Cody-Waite reduction plus series was tried and was slower than
/// glibc's sincos: its Horner chain is longer than the library's table lookup.)

#include <cmath>

namespace wbm::internal {

inline constexpr double kSmallAngle = 0.1;

/// The angle between two unit vectors from s = |a x b| (= sin angle), its square s2 and
/// c = a . b: for small angles (c > 0, s <= kSmallAngle) the series of asin(s), which needs
/// no division and can start on s2 before the square root is done; atan2(s, c) otherwise.
inline double angle_between_unit_vectors(double s, double s2, double c) {
  if (!(c > 0.0 && s2 <= kSmallAngle * kSmallAngle)) return std::atan2(s, c);
  // asin(s) = s (1 + s^2/6 + 3 s^4/40 + 5 s^6/112 + ...), to s^17; next term < 1e-21.
  return s * (1.0 + s2 * (1.0 / 6 + s2 * (3.0 / 40 + s2 * (5.0 / 112 + s2 * (35.0 / 1152 + s2 * (63.0 / 2816 +
                                                                                           s2 * (231.0 / 13312 + s2 * (143.0 / 10240 + s2 * (6435.0 / 557056)))))))));
}

/// sin(x) and cos(x).
inline void small_angle_sincos(double x, double* sin_x, double* cos_x) {
  if (!(std::abs(x) <= kSmallAngle)) {
    *sin_x = std::sin(x);
    *cos_x = std::cos(x);
    return;
  }
  const double x2 = x * x;
  // Next terms: x^11/11! < 3e-19 and x^12/12! < 3e-21.
  *sin_x = x * (1.0 + x2 * (-1.0 / 6 + x2 * (1.0 / 120 + x2 * (-1.0 / 5040 + x2 * (1.0 / 362880)))));
  *cos_x = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24 + x2 * (-1.0 / 720 + x2 * (1.0 / 40320 - x2 * (1.0 / 3628800)))));
}

}  // namespace wbm::internal
