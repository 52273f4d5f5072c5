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

#include <Eigen/Core>

namespace wbm::internal {

inline constexpr double kSmallAngle = 0.1;

/// The angle between two unit vectors from s = |a x b| (= sin angle), its square s2 and
/// c = a . b: for small angles (c > 0, s <= kSmallAngle) the series of asin(s), which needs
/// no division and can start on s2 before the square root is done; atan2(s, c) otherwise.
inline double angle_between_unit_vectors(double s, double s2, double c) {
  if (!(c > 0.0 && s2 <= kSmallAngle * kSmallAngle)) return std::atan2(s, c);
  // asin(s) = s (1 + s^2/6 + 3 s^4/40 + 5 s^6/112 + ...), to s^17; next term < 1e-21.
  // Estrin's scheme (pairs of terms, then pairs of pairs): a third of Horner's latency.
  const double y = s2, y2 = y * y, y4 = y2 * y2;
  const double q0 = 1.0 + y * (1.0 / 6), q1 = 3.0 / 40 + y * (5.0 / 112);
  const double q2 = 35.0 / 1152 + y * (63.0 / 2816), q3 = 231.0 / 13312 + y * (143.0 / 10240);
  const double r0 = q0 + y2 * q1, r1 = q2 + y2 * q3;
  return s * (r0 + y4 * (r1 + y4 * (6435.0 / 557056)));
}

/// v / |v| (and 0 for v = 0, as Eigen's normalized()): for |v|^2 within 1e-8 of 1 (unit
/// vectors up to rounding: rotation-matrix columns, filter outputs) one Newton step of
/// 1/sqrt, error below 4e-17, without the square root and the division.
inline Eigen::Vector3d normalized_near_unit(const Eigen::Vector3d& v) {
  const double length2 = v.squaredNorm();
  if (std::abs(length2 - 1.0) <= 1e-8) return v * (1.5 - 0.5 * length2);
  return length2 > 0.0 ? Eigen::Vector3d(v / std::sqrt(length2)) : v;
}

/// sin(x) and cos(x).
inline void small_angle_sincos(double x, double* sin_x, double* cos_x) {
  if (!(std::abs(x) <= kSmallAngle)) {
    *sin_x = std::sin(x);
    *cos_x = std::cos(x);
    return;
  }
  // Taylor series to x^9 and x^10 (next terms: x^11/11! < 3e-19, x^12/12! < 3e-21), in
  // Estrin's scheme.
  const double y = x * x, y2 = y * y;
  const double s0 = 1.0 - y * (1.0 / 6), s1 = 1.0 / 120 - y * (1.0 / 5040);
  *sin_x = x * (s0 + y2 * (s1 + y2 * (1.0 / 362880)));
  const double c0 = 1.0 - y * 0.5, c1 = 1.0 / 24 - y * (1.0 / 720), c2 = 1.0 / 40320 - y * (1.0 / 3628800);
  *cos_x = c0 + y2 * (c1 + y2 * c2);
}

}  // namespace wbm::internal
