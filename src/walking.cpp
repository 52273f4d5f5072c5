#include "wbm/walking.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <string>
#include <tuple>

#include "wbm/errors.hpp"

namespace wbm {
namespace {

double wrap(double a) { return std::remainder(a, 2.0 * M_PI); }

}  // namespace

WalkingParameters scaled_walking_parameters(const Model& model, const FootGeometry& feet) {
  const int ub_z = model.virtual_dofs().ub_z;
  WalkingParameters p;
  const double width_scale = feet.spacing / FootGeometry{}.spacing;
  p.max_step_width *= width_scale;
  // Not narrower than the feet (a tenth of their width between them), unless they stand
  // closer: 0.78 x the spacing let Bioloid's, Darwin-OP's and NAO's feet land on each other
  // in half their steps (0.044 m between the centre lines of feet 0.05 m wide).
  p.min_step_width = std::min(feet.spacing, std::max(p.min_step_width * width_scale, 1.1 * feet.width));
  const double height = ub_z >= 0 ? model.dof(ub_z).upper : 0.0;
  if (std::isfinite(height) && height > 0.05) {
    p.max_step_length *= height / kDefaultWalkingHeight;
    p.position_tolerance *= height / kDefaultWalkingHeight;
    p.step_duration *= std::sqrt(height / kDefaultWalkingHeight);
  }
  return p;
}

WalkingModule::WalkingModule(const Model& model, const FootGeometry& feet, const WalkingParameters& p)
    : feet_(feet), p_(p) {
  const VirtualDofs& v = model.virtual_dofs();
  heel_dofs_[0] = v.heel_x;
  heel_dofs_[1] = v.heel_y;
  heel_dofs_[2] = v.heel_yaw;
  num_dofs_ = model.num_dofs();
  if (v.heel_x < 0 || v.heel_y < 0 || v.heel_yaw < 0)
    throw ConfigError("walking: model '" + model.name() + "' has no virtual heel dofs");
  if (!(p.max_step_length > 0 && p.min_step_width >= 0 && p.max_step_turn > 0 && p.step_duration > 0 &&
        p.converged_speed > 0 && p.converge_time >= 0 && p.feet_tolerance > 0 && p.max_steps > 0 && p.max_walks > 0 &&
        p.trigger_time >= 0))
    throw ConfigError("walking: step limits, durations, tolerances and counts must be positive");
  // Errors are counted in tolerances (update): a zero tolerance would divide by zero. A
  // scenario's walking block names them; ConfigError's text says which.
  for (const auto& [value, name, unit] : {std::tuple{p.position_tolerance, "position_tolerance", "m"},
                                          std::tuple{p.angle_tolerance, "angle_tolerance", "rad"}})
    if (!(value > 0.0 && std::isfinite(value))) {
      std::ostringstream msg;
      msg << "walking: " << name << " must be finite and > 0 [" << unit << "], got " << value;
      throw ConfigError(msg.str());
    }
  per_length_tolerance_ = 1.0 / p.position_tolerance;
  per_angle_tolerance_ = 1.0 / p.angle_tolerance;
  if (!(p.max_step_width > p.min_step_width)) {
    std::ostringstream msg;
    msg << "walking: max_step_width (" << p.max_step_width << " m) must be above min_step_width (" << p.min_step_width
        << " m)";
    throw ConfigError(msg.str());
  }
  // The feet stand `spacing` apart beside the heel; a step width range without it would
  // never let the swing foot land there, and no walk would end but by max_steps.
  if (!(feet.spacing >= p.min_step_width && feet.spacing <= p.max_step_width)) {
    std::ostringstream msg;
    msg << "walking: the feet stand " << feet.spacing << " m apart (foot spacing), outside the step widths ["
        << p.min_step_width << ", " << p.max_step_width << "] m (min_step_width, max_step_width): the feet could "
        << "never reach their places beside the heel; widen the step widths to include the spacing";
    throw ConfigError(msg.str());
  }
  if (!std::isfinite(p.heel_stop_time)) throw ConfigError("walking: heel_stop_time must be finite");
  // Released half a step nearer: below one step the heel could be held with the feet at it.
  if (!std::isfinite(p.max_heel_lead) || (p.max_heel_lead > 0.0 && p.max_heel_lead < 1.0)) {
    std::ostringstream msg;
    msg << "walking: max_heel_lead must be >= 1 (in max_step_length), or <= 0 for a heel never held; got "
        << p.max_heel_lead;
    throw ConfigError(msg.str());
  }
  for (int k = 0; k < 3; ++k)
    heel_deceleration_[k] = p.heel_stop_time > 0.0 ? model.max_speeds()[heel_dofs_[k]] / p.heel_stop_time : 0.0;
  stand_at(model.home());
}

FootPose WalkingModule::stance_target(bool left, const Vector2& heel, double yaw) const {
  return standing_foot(left, heel, yaw, feet_.spacing);
}

FootPose WalkingModule::real_heel() const {
  const double yaw = left_.yaw + 0.5 * wrap(right_.yaw - left_.yaw);
  return {0.5 * (left_.position + right_.position), yaw};
}

void WalkingModule::update_support() {
  const std::array<FootPose, 2> feet = {left_, right_};
  support_ = SupportPolygon::from_feet(feet, feet_);
}

SupportPolygon WalkingModule::planned_support(const Eigen::VectorXd& q) const {
  if (q.size() != num_dofs_)
    throw ConfigError("walking: planned_support: q has " + std::to_string(q.size()) + " entries, the model " +
                      std::to_string(num_dofs_) + " dofs");
  return SupportPolygon::standing(Vector2(q[heel_dofs_[0]], q[heel_dofs_[1]]), q[heel_dofs_[2]], feet_);
}

void WalkingModule::stand_at(const Eigen::VectorXd& q) {
  if (q.size() != num_dofs_)
    throw ConfigError("walking: stand_at: q has " + std::to_string(q.size()) + " entries, the model " +
                      std::to_string(num_dofs_) + " dofs");
  if (walking_) throw ConfigError("walking: stand_at: a walk is under way");
  const Vector2 heel(q[heel_dofs_[0]], q[heel_dofs_[1]]);
  left_ = stance_target(true, heel, q[heel_dofs_[2]]);
  right_ = stance_target(false, heel, q[heel_dofs_[2]]);
  update_support();
}

void WalkingModule::target_changed() {
  given_up_ = false;
  walks_without_progress_ = 0;
  best_error_ = 1e300;
  stall_timer_ = 0.0;
}

void WalkingModule::set_heel_free(Command& command, bool free) const {
  for (int d : heel_dofs_) command.free_dofs[d] = free;
}

bool WalkingModule::feet_at(const Vector2& heel, double yaw) const {
  const FootPose l = stance_target(true, heel, yaw), r = stance_target(false, heel, yaw);
  const double tol = p_.feet_tolerance;
  return (l.position - left_.position).norm() < tol && (r.position - right_.position).norm() < tol &&
         std::abs(wrap(l.yaw - left_.yaw)) < 2 * tol && std::abs(wrap(r.yaw - right_.yaw)) < 2 * tol;
}

FootPose WalkingModule::limited_step(bool left, const FootPose& support, const FootPose& target) const {
  // The target in the support foot's frame, clamped to the step limits.
  const Eigen::Rotation2Dd R(support.yaw);
  Vector2 d = R.inverse() * (target.position - support.position);
  d.x() = std::clamp(d.x(), -0.5 * p_.max_step_length, p_.max_step_length);
  const double side = left ? 1.0 : -1.0;
  d.y() = side * std::clamp(side * d.y(), p_.min_step_width, p_.max_step_width);
  const double turn = std::clamp(wrap(target.yaw - support.yaw), -p_.max_step_turn, p_.max_step_turn);
  return {support.position + R * d, support.yaw + turn};
}

std::uint32_t WalkingModule::update(const Controller& c, const ControllerStatus& last, double time, double dt,
                                    Command& command) {
  const bool was_free = heel_free_;
  const std::uint32_t flags = update_walk(c, last, time, dt, command);
  heel_free_ = command.free_dofs[heel_dofs_[0]];
  brake_heel(c, was_free, dt, command);
  return flags;
}

void WalkingModule::brake_heel(const Controller& c, bool was_free, double dt, Command& command) {
  const bool external = command.external_velocity.size() == num_dofs_;
  for (int k = 0; k < 3; ++k) {
    const int d = heel_dofs_[k];
    if (heel_free_ || !external || heel_deceleration_[k] == 0.0) {
      heel_brake_[k] = 0.0;
    } else {
      // Frozen this cycle while it moved: from the rate it had; then towards zero.
      if (was_free) heel_brake_[k] = c.qdot()[d];
      const double v = heel_brake_[k], fall = heel_deceleration_[k] * dt;
      heel_brake_[k] = std::abs(v) <= fall ? 0.0 : v - std::copysign(fall, v);
    }
    if (external) command.external_velocity[d] = heel_brake_[k];
  }
}

std::uint32_t WalkingModule::update_walk(const Controller& c, const ControllerStatus& last, double time, double dt,
                                         Command& command) {
  std::uint32_t flags = kWalkStanding;
  const Eigen::VectorXd& q = c.q();
  const Vector2 heel(q[heel_dofs_[0]], q[heel_dofs_[1]]);
  const double yaw = q[heel_dofs_[2]];
  // The largest error of an active row, in units of its tolerance (position_tolerance for
  // lengths, angle_tolerance for angles): 1 is at the tolerance. The stall and progress tests
  // below compare it only with itself, as ratios.
  double error = 0.0;
  const TaskStack& stack = c.tasks();
  const Mask& active = command.task_active;
  const Eigen::VectorXd& values = c.values();
  for (int e = 0; e < stack.num_elements(); ++e) {
    const TaskElement& element = stack.element(e);
    const int r0 = stack.row_offset(e);
    const auto per_tolerance = [&](int row) {
      return element.row_unit(row) == RowUnit::kAngle ? per_angle_tolerance_ : per_length_tolerance_;
    };
    for (int i = 0; i < element.dim(); ++i)
      if (active[r0 + i] && stack.activation()[r0 + i])
        error = std::max(error, std::abs(stack.errors()[r0 + i]) * per_tolerance(i));
    // The stack's errors are to the filtered targets; the distance still to go is what
    // matters for the stall test, so use the largest distance to the commanded targets too.
    if (element.target_kind() != TargetKind::kVector) continue;
    const int t0 = stack.target_offset(e), n = element.target_dim();
    const double period = element.target_period();  // angles: the short way round
    for (int i = 0; i < n && i < element.dim(); ++i) {
      if (!active[r0 + i]) continue;
      const double d = command.targets[t0 + i] - values[t0 + i];
      error = std::max(error, std::abs(period > 0.0 ? std::remainder(d, period) : d) * per_tolerance(i));
    }
  }

  // Stalled: the error has not fallen by 1 % for stall_time. A growing error (a target
  // moving away: by more than 1 %) is not a stall; it restarts the measurement. Smaller
  // rises are wobble (a target out of reach, the body still turning a little) and must not
  // keep a walk going step after step.
  if (error < best_error_ * 0.99 || error > best_error_ * 1.01) {
    best_error_ = error;
    stall_timer_ = 0.0;
  } else if (!holding_) {  // a held heel does not stall the walk: the feet are catching up
    stall_timer_ += dt;
  }
  bool stalled = p_.stall_time > 0.0 && stall_timer_ > p_.stall_time;

  if (!walking_) {
    set_heel_free(command, false);
    if (given_up_) return flags | kWalkGivenUp;
    const bool limit = p_.trigger_on_joint_limit && last.has(kJointLimitClamped | kDofAtLimitFrozen);
    const bool cost = p_.cost_threshold > 0.0 && c.nullspace_cost() > p_.cost_threshold;
    const bool wanted = error > 1.0 && (limit || cost || stalled);
    trigger_timer_ = wanted ? trigger_timer_ + dt : 0.0;
    if (trigger_timer_ < p_.trigger_time || trigger_timer_ == 0.0) return flags;
    walking_ = true;
    finishing_ = false;
    holding_ = false;
    steps_this_walk_ = 0;
    converge_timer_ = 0.0;
    step_timer_ = 0.0;
    trigger_timer_ = 0.0;
    stall_timer_ = 0.0;
    best_error_ = error;
    error_at_trigger_ = error;
    // A stall that triggered the walk is not one of the walk: it ended every walk that a
    // stall alone started in the cycle it started (the heel never released, 0 footsteps).
    stalled = false;
    flags |= kWalkTriggered;
  }

  flags |= kWalking;
  // A walk that no longer reduces the error ends: the heel stays where it is.
  if (stalled) finishing_ = true;
  // The floating heel held while it is more than max_heel_lead steps ahead of the real heel,
  // released when a landing has brought the feet half a step nearer (hysteresis: no
  // holding and releasing cycle after cycle). The real heel moves only when a foot lands
  // below, so `to_go` also serves the step generator.
  const Vector2 to_go = heel - real_heel().position;
  const double lead = to_go.norm(), max_lead = p_.max_heel_lead * p_.max_step_length;
  if (p_.max_heel_lead > 0.0 && !finishing_)
    holding_ = lead > max_lead || (holding_ && lead > max_lead - 0.5 * p_.max_step_length);
  else
    holding_ = false;
  set_heel_free(command, !finishing_ && !holding_);
  // Step generator: every step_duration the swing foot lands at the limited step towards
  // its place beside the floating heel; the feet alternate.
  step_timer_ += dt;
  if (step_timer_ >= p_.step_duration) {
    step_timer_ = 0.0;
    const FootPose& support = next_left_ ? right_ : left_;
    FootPose& swing = next_left_ ? left_ : right_;
    // Far from the floating heel (more than two steps), the feet face the way there and walk
    // forward; near it, they turn to its yaw.
    const bool far = lead > 2.0 * p_.max_step_length || holding_;
    const double step_yaw = far ? std::atan2(to_go.y(), to_go.x()) : yaw;
    const FootPose target = stance_target(next_left_, heel, step_yaw);
    if (!feet_at(heel, yaw)) {
      swing = limited_step(next_left_, support, target);
      update_support();
      last_footstep_ = {time, next_left_, swing};
      ++num_footsteps_;
      flags |= kFootstepLanded;
      ++steps_this_walk_;
      next_left_ = !next_left_;
    }
  }
  double heel_speed = 0.0;
  for (int d : heel_dofs_) heel_speed = std::max(heel_speed, std::abs(c.qdot()[d]));
  // (Also while the heel is held: it is then more than half a step ahead of the feet, so
  // feet_at() is false and the walk cannot end there.)
  converge_timer_ = heel_speed < p_.converged_speed || finishing_ ? converge_timer_ + dt : 0.0;
  if (holding_) flags |= kHeelHeld;
  const bool done = converge_timer_ >= p_.converge_time && feet_at(heel, yaw);
  const bool too_many = steps_this_walk_ >= p_.max_steps;
  if (done || too_many) {
    walking_ = false;
    finishing_ = false;
    holding_ = false;
    set_heel_free(command, false);
    flags |= kWalkFinished;
    if (too_many) flags |= kStepLimitReached;
    walks_without_progress_ = error > 0.9 * error_at_trigger_ ? walks_without_progress_ + 1 : 0;
    if (too_many) walks_without_progress_ = p_.max_walks;
    if (walks_without_progress_ >= p_.max_walks) given_up_ = true;
    best_error_ = 1e300;
    stall_timer_ = 0.0;
  }
  return flags;
}

}  // namespace wbm
