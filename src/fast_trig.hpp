#pragma once
/// @file
/// Internal (not installed): atan2, sin and cos for the small angles the filters and axis
/// elements meet every cycle, inline and several times cheaper than the library calls:
/// truncated Taylor series, accurate to a few ulp for |angle| <= kSmallAngle (the
/// truncation error is below 1e-17 relative); the library outside that range. (For joint
/// angles of any size, a Cody-Waite reduction plus series was tried and was slower than
/// glibc's sincos: its Horner chain is longer than the library's table lookup.)

#include <cmath>

namespace wbm::internal {

inline constexpr double kSmallAngle = 0.1;

/// atan2(s, c) for s >= 0.
inline double small_angle_atan2(double s, double c) {
  if (!(c > 0.0 && s <= kSmallAngle * c)) return std::atan2(s, c);
  const double t = s / c, t2 = t * t;
  // t - t^3/3 + t^5/5 - ... - t^15/15; next term t^17/17 < 6e-19.
  return t * (1.0 + t2 * (-1.0 / 3 + t2 * (1.0 / 5 + t2 * (-1.0 / 7 + t2 * (1.0 / 9 + t2 * (-1.0 / 11 +
                                                                                         t2 * (1.0 / 13 - t2 * (1.0 / 15))))))));
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
