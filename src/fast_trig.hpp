#pragma once
/// @file
/// Internal (not installed): the angle between unit vectors, sin and cos for the small
/// angles the filters and axis elements meet every cycle, inline and several times cheaper
/// than the library calls: truncated Taylor series, accurate to a few ulp for
/// |angle| <= kSmallAngle (the truncation error is below 1e-17 relative); the library
/// outside that range. Joint angles of any size in forward kinematics: the same series of
/// the difference to an anchor where the library was last called (anchored_sin_cos). (A
/// Cody-Waite reduction plus series was tried for them and was slower than glibc's sincos:
/// its Horner chain is longer than the library's table lookup.)

#include <cmath>
#include <limits>

#include <Eigen/Core>

#include "wbm/kinematics.hpp"

namespace wbm::internal {

/// Range of series_sin_cos_minus_1 [rad], and so the window of anchored_sin_cos.
inline constexpr double kSeriesRange = 0.125;
inline constexpr double kSmallAngle = 0.1;  // <= kSeriesRange
static_assert(kSmallAngle <= kSeriesRange);

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
/// 1/sqrt, error below 4e-17, without the square root and the division. Where |v|^2
/// overflows or underflows (|v| beyond about 1e154 or below 1e-154) by scaling first.
inline Eigen::Vector3d normalized_near_unit(const Eigen::Vector3d& v) {
  const double length2 = v.squaredNorm();
  if (std::abs(length2 - 1.0) <= 1e-8) return v * (1.5 - 0.5 * length2);
  if (length2 > 0.0 && length2 < std::numeric_limits<double>::infinity()) return v / std::sqrt(length2);
  return v.stableNormalized();
}

/// sin(x) and cos(x) - 1 for |x| <= kSeriesRange = 1/8: Taylor series to x^9 and
/// x^10 (next terms: x^11/11! and x^12/12!, below 3e-18 at 1/8) in Estrin's scheme. cos - 1
/// without the rounding of a cosine near 1.
inline void series_sin_cos_minus_1(double x, double& sin_x, double& cos_x_minus_1) {
  const double z = x * x, z2 = z * z;
  const double p = (-1.0 / 6 + z * (1.0 / 120)) + z2 * (-1.0 / 5040 + z * (1.0 / 362880));
  const double q = (-0.5 + z * (1.0 / 24)) + z2 * ((-1.0 / 720 + z * (1.0 / 40320)) + z2 * (-1.0 / 3628800));
  sin_x = x + x * z * p;
  cos_x_minus_1 = z * q;
}

/// sin(x) and cos(x).
inline void small_angle_sincos(double x, double* sin_x, double* cos_x) {
  if (!(std::abs(x) <= kSmallAngle)) {
    *sin_x = std::sin(x);
    *cos_x = std::cos(x);
    return;
  }
  double cos_minus_1;
  series_sin_cos_minus_1(x, *sin_x, cos_minus_1);
  *cos_x = 1.0 + cos_minus_1;
}

/// Sine and cosine of a joint angle [rad] of any size, for forward kinematics. Within 1/8 rad
/// of the anchor (where libm was last called for this joint), the anchor's pair rotated by
/// d = angle - anchor.angle: sin(a0 + d) = s0 + (s0 (cos d - 1) + c0 sin d), the cosine
/// alike, with sin d and cos d - 1 from series_sin_cos_minus_1. The anchor stays where libm
/// was called, so the error does not build up over calls: libm's plus about one rounding of the sum (an
/// absolute error below 2.5e-16; near a zero of sin or cos the relative error grows, which
/// a rotation matrix does not feel). Otherwise (and for the NaN anchor of a fresh Data) libm,
/// and the anchor moves there. A controller's joints move far less than 1/8 rad per cycle,
/// so libm is called once a joint has travelled 1/8 rad.
inline void anchored_sin_cos(double angle, Data::AngleAnchor& anchor, double& s, double& c) {
  const double d = angle - anchor.angle;
  if (std::abs(d) <= kSeriesRange) {
    double sin_d, cos_d_minus_1;
    series_sin_cos_minus_1(d, sin_d, cos_d_minus_1);
    s = anchor.sin + (anchor.sin * cos_d_minus_1 + anchor.cos * sin_d);
    c = anchor.cos + (anchor.cos * cos_d_minus_1 - anchor.sin * sin_d);
    return;
  }
  s = std::sin(angle);
  c = std::cos(angle);
  anchor = {angle, s, c};
}

}  // namespace wbm::internal
