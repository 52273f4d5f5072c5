#include "wbm/nullspace_criterion.hpp"

#include <cmath>

#include "wbm/errors.hpp"

namespace wbm {
namespace {

void setup(const Model& model, const Eigen::VectorXd& weights, Eigen::VectorXd& center, Eigen::VectorXd& half_range,
           Eigen::VectorXd& weight) {
  const int n = model.num_dofs();
  if (weights.size() != n)
    throw ConfigError("null-space criterion: " + std::to_string(weights.size()) + " weights for " + std::to_string(n) +
                      " dofs");
  center.resize(n);
  half_range.resize(n);
  weight = weights;
  for (int i = 0; i < n; ++i) {
    const Dof& d = model.dof(i);
    if (!std::isfinite(weights[i]) || weights[i] < 0.0)
      throw ConfigError("null-space criterion: weight of dof '" + d.name + "' must be finite and >= 0");
    center[i] = d.center();
    half_range[i] = 0.5 * d.work_range;
    if (d.continuous) weight[i] = 0.0;
  }
}

}  // namespace

Eigen::VectorXd default_criterion_weights(const Model& model) {
  Eigen::VectorXd w = Eigen::VectorXd::Ones(model.num_dofs());
  for (int i = 0; i < model.num_dofs(); ++i) {
    const DofRole role = model.dof(i).role;
    if (model.dof(i).continuous || role == DofRole::kHeelX || role == DofRole::kHeelY || role == DofRole::kHeelYaw)
      w[i] = 0.0;
  }
  return w;
}

JointCenterCriterion::JointCenterCriterion(const Model& model)
    : JointCenterCriterion(model, default_criterion_weights(model)) {}

JointCenterCriterion::JointCenterCriterion(const Model& model, const Eigen::VectorXd& weights) {
  setup(model, weights, center_, half_range_, weight_);
}

double JointCenterCriterion::cost(const Eigen::Ref<const Eigen::VectorXd>& q) const {
  return 0.5 * (weight_.array() * ((q - center_).array() / half_range_.array()).square()).sum();
}

void JointCenterCriterion::gradient(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> grad) const {
  grad = (weight_.array() * (q - center_).array() / half_range_.array().square()).matrix();
}

CubicJointLimitCriterion::CubicJointLimitCriterion(const Model& model, double band)
    : CubicJointLimitCriterion(model, band, default_criterion_weights(model)) {}

CubicJointLimitCriterion::CubicJointLimitCriterion(const Model& model, double band, const Eigen::VectorXd& weights)
    : band_(band) {
  if (!(band >= 0.0 && band < 1.0))
    throw ConfigError("cubic joint-limit criterion: band must be in [0, 1), got " + std::to_string(band));
  setup(model, weights, center_, half_range_, weight_);
  inverse_half_range_ = half_range_.cwiseInverse();
  gradient_scale_ = 3.0 / std::pow(1.0 - band_, 3);
}

double CubicJointLimitCriterion::cost(const Eigen::Ref<const Eigen::VectorXd>& q) const {
  double h = 0.0;
  for (int i = 0; i < q.size(); ++i) {
    const double excess = std::abs(q[i] - center_[i]) / half_range_[i] - band_;
    if (excess > 0.0) h += weight_[i] * std::pow(excess / (1.0 - band_), 3);
  }
  return h;
}

void CubicJointLimitCriterion::gradient(const Eigen::Ref<const Eigen::VectorXd>& q,
                                        Eigen::Ref<Eigen::VectorXd> grad) const {
  for (int i = 0; i < q.size(); ++i) {
    const double d = (q[i] - center_[i]) * inverse_half_range_[i];
    const double excess = std::abs(d) - band_;
    grad[i] = excess > 0.0
                  ? weight_[i] * gradient_scale_ * excess * excess * std::copysign(1.0, d) * inverse_half_range_[i]
                  : 0.0;
  }
}

}  // namespace wbm
