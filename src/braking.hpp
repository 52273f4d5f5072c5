#pragma once
/// @file
/// Internal (not installed): braking a dof before its position limit (docs/solver.md).

#include <algorithm>
#include <cmath>

namespace wbm::internal {

/// A dof moving at rate `v` towards a limit `distance` away (>= 0) is braked where it is
/// faster than sqrt(k_vmax distance), the rate from which it stops at the limit at the
/// deceleration k_vmax / 2, or than distance / dt, the rate that lands it on the limit in
/// this cycle. Returns the rate it may keep (v itself when not braked; the sign of v).
/// The common case, far from the limit, costs no division or square root.
inline double braked_rate(double v, double distance, double k_vmax, double dt) {
  if (v == 0.0 || !(v * v > k_vmax * distance || std::abs(v) * dt > distance)) return v;
  const double rate = distance > 0.0 ? std::min(std::sqrt(k_vmax * distance), distance / dt) : 0.0;
  return std::copysign(rate, v);
}

/// The distance from q to the limit in the direction of v (upper for v > 0, else lower).
inline double distance_ahead(double v, double q, double lower, double upper) {
  return v > 0.0 ? upper - q : q - lower;
}

}  // namespace wbm::internal
