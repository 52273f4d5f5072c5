#pragma once
/// @file
/// Speed-limited higher-order low-pass filter between actual and target values (section III).

#include <Eigen/Core>

#include "wbm/task_element.hpp"

namespace wbm {

struct FilterParameters {
  /// Corner frequency omega of every stage [1/s], at least TrajectoryFilter::kMinBandwidth.
  double bandwidth = 5.0;
  /// Speed limit of the output: [m/s] for positions, [rad/s] for axes and angles. For
  /// vector targets the limit applies to the Euclidean norm of the velocity.
  double max_speed = 0.5;
  /// Filter order n >= 2: a rate-limited first-order stage followed by n-1 first-order
  /// low-pass stages (n equal real poles: critically damped, no overshoot).
  int order = 2;
};

/// The filter: stage 1 moves towards the target at rate omega * distance but never faster
/// than max_speed; stages 2..n are first-order low-passes of the previous stage. Each stage
/// approaches its input monotonically, so the output never overshoots; the output speed is
/// a low-pass of stage 1's speed and so never exceeds max_speed; the output velocity is
/// continuous even when the target jumps. All stages are discretised exactly
/// (factor 1 - exp(-omega dt)).
///
/// Direction targets (2-dof axes) move the same way along great circles: distances are
/// angles, max_speed is an angular speed.
class TrajectoryFilter {
 public:
  /// Smallest bandwidth accepted [1/s]: a time constant of at most 1000 s. The filter starts
  /// from a moving value with its stages at x + (n - k) v / omega, which leaves every
  /// workspace for smaller omega and overflows for tiny ones (the filter then emits NaN).
  static constexpr double kMinBandwidth = 1e-3;

  /// @throws ConfigError for bandwidth < kMinBandwidth or not finite, max_speed <= 0 or not
  /// finite, order outside [2, 6] or a bad size.
  TrajectoryFilter(TargetKind kind, int dim, const FilterParameters& parameters);

  /// Starts from the actual value and velocity, so nothing jumps when an element is
  /// switched on: the stages are placed on the line x + (n - k) v / omega.
  void reset(const Eigen::Ref<const Eigen::VectorXd>& value, const Eigen::Ref<const Eigen::VectorXd>& velocity);
  /// Restarts one component of a vector filter from its actual value and velocity (a row
  /// of a partly active element being switched on); the other components keep going.
  void reset_component(int i, double value, double velocity);
  /// Advances by dt towards `target`. Never allocates.
  void update(const Eigen::Ref<const Eigen::VectorXd>& target, double dt);
  /// update(targets[i], dt) for each filters[i] (targets[i]: its dim entries), stage by stage
  /// across the filters: each filter's stages are a chain of dependent operations, and
  /// interleaving the filters lets the core overlap their chains (the paper model's filter
  /// stage took 20-25 % less time so). Same results as one update() after another. Never
  /// allocates.
  static void update_together(TrajectoryFilter* const* filters, const double* const* targets, int count, double dt);
  /// Filtered value and its time derivative.
  const Eigen::VectorXd& value() const { return value_; }
  const Eigen::VectorXd& velocity() const { return velocity_; }
  const FilterParameters& parameters() const { return parameters_; }

 private:
  /// The constants of the cycle time dt (recomputed only when it changes).
  void prepare(double dt);
  /// Stage k's step towards stage k - 1 (k > 0, already advanced) or the target (k = 0).
  void advance_stage(int k, const double* target, double dt);
  /// The output and its velocity from the last stage.
  void finish(double dt);
  /// One stage step. Directions: x and `to` are unit vectors.
  void move_towards(Eigen::Ref<Eigen::VectorXd> x, const Eigen::Ref<const Eigen::VectorXd>& to, double fraction,
                    double max_step) const;
  /// A direction stage moved by the fraction of its angle to `to` (the step when the speed
  /// limit does not bind) as x' = alpha x + beta to, with alpha and beta polynomials in
  /// 4 sin^2(angle/2) = 2 (1 - x.to); false (nothing done) if that exceeds v_limit.
  bool slerp_by_fraction(Eigen::Ref<Eigen::VectorXd> x, const Vector3& to, double v_limit) const;

  TargetKind kind_;
  FilterParameters parameters_;
  Eigen::MatrixXd stages_;  // dim x order; the last column is the output
  Eigen::VectorXd value_, velocity_;  // value_ == the last stage between updates
  double fraction_dt_ = 0.0, fraction_ = 0.0;  // 1 - exp(-omega dt) for the last dt
  // Directions, for the fraction_ above: Taylor coefficients of alpha and beta (see
  // slerp_by_fraction) and the largest 2 (1 - cos angle) at which stage 1's step is
  // fraction * angle (the speed limit does not bind) and the series applies.
  double slerp_alpha_[8] = {}, slerp_beta_[8] = {};
  double stage1_v_limit_ = -1.0;
};

}  // namespace wbm
