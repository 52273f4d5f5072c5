#pragma once
/// @file
/// Null-space criteria H(q) (section IV.E, Fig. 3) for joint-limit avoidance.

#include <Eigen/Core>

#include "wbm/model.hpp"

namespace wbm {

/// A cost H(q) whose gradient is mapped into the null space (eq. 5). Implement this to add
/// your own criterion; gradient() must not allocate.
class NullSpaceCriterion {
 public:
  virtual ~NullSpaceCriterion() = default;
  virtual double cost(const Eigen::Ref<const Eigen::VectorXd>& q) const = 0;
  /// dH/dq (nq entries).
  virtual void gradient(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> grad) const = 0;
};

/// Per-dof weights of the joint-limit criteria by default: 1 for every dof with position
/// limits, 0 for continuous joints and for the heel dofs (the heel has no preferred place:
/// when released for walking it floats to where the rest of the body is relaxed).
Eigen::VectorXd default_criterion_weights(const Model& model);

/// "Squared sum of the joint centre deviations": H = 1/2 sum_i w_i d_i^2 with the
/// normalised deviation d_i = (q_i - c_i) / (r_i / 2), c the centre and r the work range.
class JointCenterCriterion : public NullSpaceCriterion {
 public:
  /// @throws ConfigError if weights has the wrong size or a negative/non-finite entry.
  explicit JointCenterCriterion(const Model& model);
  JointCenterCriterion(const Model& model, const Eigen::VectorXd& weights);
  double cost(const Eigen::Ref<const Eigen::VectorXd>& q) const override;
  void gradient(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> grad) const override;

 private:
  Eigen::VectorXd center_, half_range_, weight_;
};

/// "Cubic penalty with activation threshold" (Fig. 3, right): zero inside the band
/// |d_i| <= band around the centre, H = sum_i w_i ((|d_i| - band) / (1 - band))^3 outside,
/// so that H_i = w_i at the limit. The gradient is continuous and zero in the band.
class CubicJointLimitCriterion : public NullSpaceCriterion {
 public:
  /// @param band activation threshold as a fraction of the half range, in [0, 1).
  /// @throws ConfigError if band is outside [0, 1) or weights are invalid.
  CubicJointLimitCriterion(const Model& model, double band);
  CubicJointLimitCriterion(const Model& model, double band, const Eigen::VectorXd& weights);
  double cost(const Eigen::Ref<const Eigen::VectorXd>& q) const override;
  void gradient(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> grad) const override;
  double band() const { return band_; }

 private:
  Eigen::VectorXd center_, half_range_, weight_;
  Eigen::VectorXd inverse_half_range_;  // 1 / half_range_: no divisions per cycle
  double gradient_scale_ = 0.0;         // 3 / (1 - band)^3
  double band_;
};

}  // namespace wbm
