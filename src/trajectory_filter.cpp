#include "wbm/trajectory_filter.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>

#include "wbm/errors.hpp"

#include "fast_trig.hpp"

namespace wbm {
namespace {

// Great-circle interpolation by a fixed fraction f of the angle theta between unit vectors
// a and b: slerp = alpha a + beta b with alpha = sin((1 - f) theta) / sin theta and
// beta = sin(f theta) / sin theta. Both are power series in v = 4 sin^2(theta/2) = 2 (1 - a.b)
// (radius of convergence 4: theta = pi); for v <= kSlerpMaxV (theta <= 0.1 rad) eight terms
// leave a truncation error below 1e-20. The coefficients depend on f only, so they are
// computed only when the cycle time changes, from a basis that does not depend on f.
constexpr int kSlerpTerms = 8;
constexpr double kSlerpMaxV = 0.01;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

using Series = std::array<double, kSlerpTerms>;

Series multiply(const Series& a, const Series& b) {
  Series r{};
  for (int i = 0; i < kSlerpTerms; ++i)
    for (int j = 0; i + j < kSlerpTerms; ++j) r[i + j] += a[i] * b[j];
  return r;
}

/// The part of the series that does not depend on f: Q_k = u^k / sinc(theta) as series in v,
/// with u = theta^2 = 4 asin^2(sqrt(v) / 2) = sum_n 2 v^n / (n^2 C(2n, n)) and
/// sinc(theta) = sin(theta) / theta = sum_k (-1)^k u^k / (2k + 1)!.
std::array<Series, kSlerpTerms> slerp_basis() {
  Series u{};
  double central = 1.0;  // C(2n, n)
  for (int n = 1; n < kSlerpTerms; ++n) {
    central = central * (2 * n) * (2 * n - 1) / (n * n);
    u[n] = 2.0 / (n * n * central);
  }
  std::array<Series, kSlerpTerms> power{};
  power[0][0] = 1.0;
  for (int k = 1; k < kSlerpTerms; ++k) power[k] = multiply(power[k - 1], u);
  Series sinc{};
  double term = 1.0;  // (-1)^k / (2k + 1)!
  for (int k = 0; k < kSlerpTerms; ++k) {
    for (int i = 0; i < kSlerpTerms; ++i) sinc[i] += term * power[k][i];
    term *= -1.0 / ((2 * k + 2) * (2 * k + 3));
  }
  // 1 / sinc by the recurrence of a reciprocal series (leading coefficient 1).
  Series reciprocal{};
  reciprocal[0] = 1.0;
  for (int n = 1; n < kSlerpTerms; ++n)
    for (int k = 1; k <= n; ++k) reciprocal[n] -= sinc[k] * reciprocal[n - k];
  for (Series& p : power) p = multiply(p, reciprocal);
  return power;
}

/// Coefficients of alpha (fraction 1 - f) and beta (fraction f) in v:
/// sin(lambda theta) / sin(theta) = lambda sum_k (-1)^k lambda^(2k) / (2k + 1)! Q_k.
/// Runs whenever the cycle time changes (a measured dt may change every cycle): 2 x 64
/// multiply-adds on the basis, which is computed once.
void slerp_series(double f, double* alpha, double* beta) {
  static const std::array<Series, kSlerpTerms> basis = slerp_basis();
  auto combine = [&](double lambda, double* out) {
    double term = lambda;  // lambda (-1)^k lambda^(2k) / (2k + 1)!
    for (int i = 0; i < kSlerpTerms; ++i) out[i] = 0.0;
    for (int k = 0; k < kSlerpTerms; ++k) {
      for (int i = 0; i < kSlerpTerms; ++i) out[i] += term * basis[k][i];
      term *= -lambda * lambda / ((2 * k + 2) * (2 * k + 3));
    }
  };
  combine(1.0 - f, alpha);
  combine(f, beta);
}

/// c[0] + c[1] v + ... + c[7] v^7 in Estrin's scheme.
double polynomial8(const double* c, double v) {
  const double v2 = v * v, v4 = v2 * v2;
  return ((c[0] + v * c[1]) + v2 * (c[2] + v * c[3])) + v4 * ((c[4] + v * c[5]) + v2 * (c[6] + v * c[7]));
}

}  // namespace

TrajectoryFilter::TrajectoryFilter(TargetKind kind, int dim, const FilterParameters& parameters)
    : kind_(kind), parameters_(parameters) {
  if (!(std::isfinite(parameters.bandwidth) && parameters.bandwidth >= kMinBandwidth)) {
    std::ostringstream msg;
    msg << "trajectory filter: bandwidth must be finite and >= " << kMinBandwidth << " [1/s], got "
        << parameters.bandwidth;
    throw ConfigError(msg.str());
  }
  if (!(std::isfinite(parameters.max_speed) && parameters.max_speed > 0.0))
    throw ConfigError("trajectory filter: max_speed must be finite and > 0");
  if (parameters.order < 2 || parameters.order > 6) throw ConfigError("trajectory filter: order must be in [2, 6]");
  if (dim <= 0 || (kind == TargetKind::kDirection && dim != 3))
    throw ConfigError("trajectory filter: direction filters have 3 entries, others at least 1");
  stages_.setZero(dim, parameters.order);
  value_.setZero(dim);
  velocity_.setZero(dim);
  if (kind == TargetKind::kDirection) {
    stages_.row(2).setOnes();
    value_[2] = 1.0;
  }
}

void TrajectoryFilter::reset(const Eigen::Ref<const Eigen::VectorXd>& value,
                             const Eigen::Ref<const Eigen::VectorXd>& velocity) {
  const int n = parameters_.order;
  const double w = parameters_.bandwidth;
  if (kind_ == TargetKind::kVector) {
    for (int k = 0; k < n; ++k) stages_.col(k) = value + (n - 1 - k) * velocity / w;
  } else {
    // Rotate the unit value about the axis value x velocity by (n - 1 - k) |velocity| / omega.
    const Vector3 a = value.head<3>().normalized();
    const Vector3 omega = a.cross(Vector3(velocity.head<3>()));
    for (int k = 0; k < n; ++k) {
      const Vector3 rv = omega * ((n - 1 - k) / w);
      const double angle = rv.norm();
      stages_.col(k) = angle > 1e-12 ? Vector3(Eigen::AngleAxisd(angle, rv / angle) * a) : a;
    }
  }
  value_ = stages_.col(n - 1);
  velocity_ = velocity;
}

void TrajectoryFilter::reset_component(int i, double value, double velocity) {
  const int n = parameters_.order;
  for (int k = 0; k < n; ++k) stages_(i, k) = value + (n - 1 - k) * velocity / parameters_.bandwidth;
  value_[i] = value;
  velocity_[i] = velocity;
}

void TrajectoryFilter::move_towards(Eigen::Ref<Eigen::VectorXd> x, const Eigen::Ref<const Eigen::VectorXd>& to,
                                    double fraction, double max_step) const {
  if (kind_ == TargetKind::kVector) {
    // Step fraction * distance, unless that exceeds max_step. Compared squared: the square
    // root and the division are only needed when the speed limit binds.
    if (x.size() == 3) {  // the common case (positions), without dynamic-size overhead
      const Vector3 d = to.head<3>() - x.head<3>();
      const double distance2 = d.squaredNorm();
      if (fraction * fraction * distance2 <= max_step * max_step) {
        x.head<3>() += fraction * d;
      } else {  // distance2 overflows beyond 1e154: the norm by scaling, not the square root of inf
        x.head<3>() += d * (max_step / (distance2 < kInfinity ? std::sqrt(distance2) : d.stableNorm()));
      }
      return;
    }
    // Other sizes (joint rows) in plain loops: Eigen's dynamic-size loops peel entries to
    // align each column, so consecutive stages (columns of odd length) were stored and then
    // loaded in pairs that straddle (failed store-to-load forwarding on the stage chain).
    const int n = static_cast<int>(x.size());
    double distance2 = 0.0;
    for (int i = 0; i < n; ++i) distance2 += (to[i] - x[i]) * (to[i] - x[i]);
    double step = fraction;
    if (!(fraction * fraction * distance2 <= max_step * max_step))
      step = max_step / (distance2 < kInfinity ? std::sqrt(distance2) : (to - x).stableNorm());
    for (int i = 0; i < n; ++i) x[i] += step * (to[i] - x[i]);
    return;
  }
  // Great circle: rotate x towards `to` by the step angle; both are unit vectors (the
  // general case: the caller tries slerp_by_fraction first).
  const Vector3 a = x.head<3>();
  const Vector3 b = to.head<3>();
  const double c = a.dot(b);
  const Vector3 perpendicular = b - c * a;  // |b - (a.b) a| = |a x b| = sin(angle)
  const double s2 = perpendicular.squaredNorm();
  const double s = std::sqrt(s2);
  const double angle = internal::angle_between_unit_vectors(s, s2, c);
  if (angle <= 0.0) return;
  const double step = std::min(angle * fraction, max_step);
  // Rotate a by `step` in the plane of a and b (Rodrigues with the axis perpendicular to a):
  // a' = cos(step) a + sin(step) t, t the unit tangent towards b.
  Vector3 t;
  if (s < 1e-12) {
    // Opposite directions: any great circle is shortest; take a fixed perpendicular.
    t = (std::abs(a.x()) < 0.9 ? a.cross(Vector3::UnitX()) : a.cross(Vector3::UnitY())).normalized();
  } else {
    t = perpendicular * (1.0 / s);
  }
  double sin_step, cos_step;
  internal::small_angle_sincos(step, &sin_step, &cos_step);
  const Vector3 rotated = cos_step * a + sin_step * t;
  // |rotated| = 1 up to rounding: one Newton step towards unit length (no square root)
  // keeps the stages from drifting.
  x = rotated * (0.5 * (3.0 - rotated.squaredNorm()));
}

bool TrajectoryFilter::slerp_by_fraction(Eigen::Ref<Eigen::VectorXd> x, const Vector3& to, double v_limit) const {
  const Vector3 a = x.head<3>();
  const double v = 2.0 - 2.0 * a.dot(to);  // 4 sin^2(angle / 2), absolute error ~1e-16
  if (!(v <= v_limit)) return false;
  const Vector3 moved = polynomial8(slerp_alpha_, v) * a + polynomial8(slerp_beta_, v) * to;
  // One Newton step towards unit length (no square root) keeps the stages from drifting.
  x.head<3>() = moved * (0.5 * (3.0 - moved.squaredNorm()));
  return true;
}

[[gnu::always_inline]] inline void TrajectoryFilter::prepare(double dt) {
  if (dt == fraction_dt_) return;  // the cycle time rarely changes: exp only when it does
  fraction_dt_ = dt;
  fraction_ = 1.0 - std::exp(-parameters_.bandwidth * dt);
  if (kind_ == TargetKind::kDirection) {
    slerp_series(fraction_, slerp_alpha_, slerp_beta_);
    // Stage 1 steps by fraction * angle while that is below max_speed dt.
    const double angle = parameters_.max_speed * dt / fraction_;
    const double half_chord = std::sin(0.5 * std::min(angle, M_PI));
    stage1_v_limit_ = std::min(kSlerpMaxV, 4.0 * half_chord * half_chord);
  }
}

[[gnu::always_inline]] inline void TrajectoryFilter::advance_stage(int k, const double* target, double dt) {
  const double fraction = fraction_;
  if (kind_ == TargetKind::kDirection) {
    if (k == 0) {
      // The stages are unit vectors; so is the target from here on.
      const Vector3 unit_target = internal::normalized_near_unit(Eigen::Map<const Vector3>(target));
      if (!slerp_by_fraction(stages_.col(0), unit_target, stage1_v_limit_))
        move_towards(stages_.col(0), unit_target, fraction, parameters_.max_speed * dt);
    } else {
      const Vector3 previous = stages_.col(k - 1).head<3>();
      if (!slerp_by_fraction(stages_.col(k), previous, kSlerpMaxV))
        move_towards(stages_.col(k), stages_.col(k - 1), fraction, kInfinity);
    }
  } else if (k == 0) {
    move_towards(stages_.col(0), Eigen::Map<const Eigen::VectorXd>(target, stages_.rows()), fraction,
                 parameters_.max_speed * dt);
  } else {
    move_towards(stages_.col(k), stages_.col(k - 1), fraction, kInfinity);
  }
}

[[gnu::always_inline]] inline void TrajectoryFilter::finish(double dt) {
  // value_ is still the last stage before this update (every reset keeps them equal).
  const int n = parameters_.order;
  const double inverse_dt = 1.0 / dt;
  if (value_.size() == 3) {  // positions and directions, without dynamic-size loops
    const Vector3 last = stages_.col(n - 1).head<3>();
    velocity_.head<3>() = (last - value_.head<3>()) * inverse_dt;
    value_.head<3>() = last;
  } else {  // plain loops, as in move_towards()
    const double* last = stages_.col(n - 1).data();
    for (int i = 0; i < value_.size(); ++i) {
      velocity_[i] = (last[i] - value_[i]) * inverse_dt;
      value_[i] = last[i];
    }
  }
}

void TrajectoryFilter::update(const Eigen::Ref<const Eigen::VectorXd>& target, double dt) {
  prepare(dt);
  for (int k = 0; k < parameters_.order; ++k) advance_stage(k, target.data(), dt);
  finish(dt);
}

void TrajectoryFilter::update_together(TrajectoryFilter* const* filters, const double* const* targets, int count,
                                       double dt) {
  int max_order = 0;
  for (int i = 0; i < count; ++i) {
    filters[i]->prepare(dt);
    max_order = std::max(max_order, filters[i]->parameters_.order);
  }
  for (int k = 0; k < max_order; ++k)
    for (int i = 0; i < count; ++i)
      if (k < filters[i]->parameters_.order) filters[i]->advance_stage(k, targets[i], dt);
  for (int i = 0; i < count; ++i) filters[i]->finish(dt);
}

}  // namespace wbm
