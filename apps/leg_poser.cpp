#include "leg_poser.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "runner.hpp"
#include "wbm/urdf_import.hpp"

namespace wbm {
namespace {

/// The frame a frame hangs from: its own parent frame, else (a body's frame) its parent
/// body's frame, else (a welded frame) its body's frame; -1 at the root.
int parent_frame(const Model& model, int f) {
  const Frame& frame = model.frame(f);
  if (frame.parent >= 0) return frame.parent;
  if (!model.is_body_frame(f)) return model.frame_index(model.body(frame.body).name);
  const int parent_body = model.body(frame.body).parent;
  return parent_body >= 0 ? model.frame_index(model.body(parent_body).name) : -1;
}

/// The foot frame on the floor: at the foot's heel-edge centre, lifted by `lift`, turned by
/// its yaw.
Transform foot_frame(const FootPose& foot, double lift) {
  Transform X;
  X.R = Eigen::AngleAxisd(foot.yaw, Vector3::UnitZ()).toRotationMatrix();
  X.p = Vector3(foot.position.x(), foot.position.y(), lift);
  return X;
}

// [m] per rad: an orientation error counts as a position error of this lever. Large enough
// that a foot out of reach stays flat on the floor and the ankle misses instead (at 0.1 m
// NAO's foot turned 0.3 rad and tilted into the floor to save a centimetre).
constexpr double kRotationWeight = 0.5;
constexpr int kMaxIterations = 100;

}  // namespace

int leg_of(const Model& model, int f, const std::vector<std::string>& legs) {
  for (int g = f; g >= 0; g = parent_frame(model, g)) {
    const auto it = std::find(legs.begin(), legs.end(), model.frame(g).name);
    if (it != legs.end()) return static_cast<int>(it - legs.begin());
  }
  return -1;
}

DrawnFeet drawn_feet(const ScenarioRun& run, double t) {
  // The feet stand beside the heel of the first cycle (walking's too: WalkingModule::stand_at).
  const VirtualDofs& v = run.model->virtual_dofs();
  const Vector2 heel(run.q[0][v.heel_x], run.q[0][v.heel_y]);
  const double yaw = run.q[0][v.heel_yaw];
  const WalkingParameters& p = run.walking_parameters;
  DrawnFeet out;
  for (int side = 0; side < 2; ++side) {
    FootPose from = standing_foot(side == 0, heel, yaw, run.feet.spacing);
    out.pose[side] = from;
    for (const Footstep& step : run.footsteps) {  // in the order they landed
      if (step.left != (side == 0)) continue;
      if (step.time <= t) {
        out.pose[side] = from = step.pose;
        continue;
      }
      const double s = (t - (step.time - p.step_duration)) / p.step_duration;
      if (s > 0) {
        const double blend = s * s * (3 - 2 * s);
        out.pose[side].position = from.position + blend * (step.pose.position - from.position);
        out.pose[side].yaw = from.yaw + blend * std::remainder(step.pose.yaw - from.yaw, 2 * std::numbers::pi);
        out.lift[side] = 0.2 * p.max_step_length * std::sin(std::numbers::pi * s);
      }
      break;
    }
  }
  return out;
}

LegPoser::LegPoser(const Scenario& scenario, const Model& model, double spacing) : model_(&model) {
  const std::vector<std::string>& legs = scenario.urdf_options.legs;
  if (scenario.urdf.empty() || scenario.urdf_options.leg_mode != LegMode::kLock || legs.size() != 2) return;
  const VirtualDofs& v = model.virtual_dofs();
  if (v.upper_body < 0 || v.heel_x < 0) return;
  // The same robot with its legs free. Missing limits of leg joints (which a locked leg
  // does not need) get the defaults; the root height is the model's (only poses relative
  // to the root link are used).
  UrdfImportOptions options = scenario.urdf_options;
  options.legs.clear();
  options.default_limits = true;
  try {
    leg_model_ = std::make_unique<Model>(load_urdf(scenario.urdf, options));
  } catch (const std::exception&) {
    return;  // drawn locked, as before
  }
  const Model& lm = *leg_model_;
  root_ = model.frame_index(model.body(v.upper_body).name);
  leg_root_ = lm.find_frame(model.body(v.upper_body).name);
  if (leg_root_ < 0) return;

  // Each leg's moving links; its last one (the most joints below the root) is the end.
  std::array<int, 2> depth = {-1, -1};
  std::array<int, 2> end = {-1, -1};
  for (int b = 0; b < lm.num_bodies(); ++b) {
    const int f = lm.frame_index(lm.body(b).name);
    const int leg = lm.body(b).dof >= 0 ? leg_of(lm, f, legs) : -1;
    if (leg < 0) continue;
    leg_dofs_.push_back(lm.body(b).dof);
    const int n = static_cast<int>(lm.moving_bodies(b).size());
    if (n > depth[leg]) {
      depth[leg] = n;
      end[leg] = f;
    }
  }
  std::sort(leg_dofs_.begin(), leg_dofs_.end());
  leg_dofs_.erase(std::unique(leg_dofs_.begin(), leg_dofs_.end()), leg_dofs_.end());
  if (end[0] < 0 || end[1] < 0) return;

  dof_in_model_.resize(lm.num_dofs());
  for (int i = 0; i < lm.num_dofs(); ++i)
    dof_in_model_[i] = std::binary_search(leg_dofs_.begin(), leg_dofs_.end(), i) ? -1 : model.find_dof(lm.dof(i).name);
  leg_frame_of_.assign(model.num_frames(), -1);
  for (int f = 0; f < model.num_frames(); ++f)
    if (leg_of(model, f, legs) >= 0) leg_frame_of_[f] = lm.find_frame(model.frame(f).name);
  poses_.assign(model.num_frames(), Transform());

  // The upright pose with straight legs: the heel at the origin facing x, each foot beside
  // it; the legs' ends stand on their feet as there (the locked legs are that pose).
  Data d(model);
  forward_kinematics(model, d, upright_base_configuration(model, Eigen::VectorXd::Zero(model.num_dofs())));
  std::array<bool, 2> left{};
  for (int leg = 0; leg < 2; ++leg) {
    const int end_in_model = model.find_frame(lm.frame(end[leg]).name);
    if (end_in_model < 0) return;
    const Transform X_WE = frame_pose(model, d, end_in_model);
    left[leg] = X_WE.p.y() > 0;  // the world's y is the robot's left here (also with a turned root link)
    legs_[left[leg] ? 0 : 1] = {end[leg], foot_frame(standing_foot(left[leg], Vector2::Zero(), 0.0, spacing), 0.0)
                                              .inverse() * X_WE};
  }
  if (left[0] == left[1]) return;  // both on one side: which foot is whose is unclear
  leg_data_ = std::make_unique<Data>(lm);
  J6_.resize(6, lm.num_dofs());
  // The seed: zero (the straight legs) moved towards the middle of each range by up to a
  // tenth of the range, so that a knee whose range lies mostly on one side of straight
  // starts bent that way (straight, it is singular, and a step from there need not bend it).
  q_leg_ = Eigen::VectorXd::Zero(lm.num_dofs());
  for (int i : leg_dofs_) {
    const Dof& dof = lm.dof(i);
    const double reach = 0.1 * (dof.upper - dof.lower);
    seed_.push_back(dof.continuous ? 0.0 : std::clamp(std::clamp(dof.center(), -reach, reach), dof.lower, dof.upper));
    q_leg_[i] = seed_.back();
  }
  usable_ = true;
}

LegPoser::~LegPoser() = default;

double LegPoser::evaluate_legs(const std::array<Transform, 2>& X_RE_target, Eigen::MatrixXd& J, Eigen::VectorXd& e) {
  const Model& lm = *leg_model_;
  Data& ld = *leg_data_;
  forward_kinematics(lm, ld, q_leg_);
  const Transform X_WR_leg = frame_pose(lm, ld, leg_root_);
  residual_ = position_miss_ = angle_miss_ = 0.0;
  for (int side = 0; side < 2; ++side) {
    const Transform target = X_WR_leg * X_RE_target[side];
    const Transform X = frame_pose(lm, ld, legs_[side].end_frame);
    const Eigen::AngleAxisd turn(target.R * X.R.transpose());
    e.segment<3>(6 * side) = target.p - X.p;
    e.segment<3>(6 * side + 3) = kRotationWeight * turn.angle() * turn.axis();
    position_miss_ = std::max(position_miss_, e.segment<3>(6 * side).norm());
    angle_miss_ = std::max(angle_miss_, std::abs(turn.angle()));
    residual_ = std::max({residual_, e.segment<3>(6 * side).norm(), e.segment<3>(6 * side + 3).norm()});
    frame_jacobian(lm, ld, legs_[side].end_frame, J6_);
    for (int j = 0; j < static_cast<int>(leg_dofs_.size()); ++j) {
      J.block<3, 1>(6 * side, j) = J6_.block<3, 1>(0, leg_dofs_[j]);
      J.block<3, 1>(6 * side + 3, j) = kRotationWeight * J6_.block<3, 1>(3, leg_dofs_[j]);
    }
  }
  return e.squaredNorm();
}

void LegPoser::solve_legs(const std::array<Transform, 2>& X_RE_target) {
  // Levenberg-Marquardt: a damped least-squares step, kept where it lowers the error (the
  // damping then halves), else undone (the damping grows). Straight legs are singular (the
  // knee), so undamped steps there point anywhere.
  const Model& lm = *leg_model_;
  const int n = static_cast<int>(leg_dofs_.size());
  Eigen::MatrixXd J(12, n), J_new(12, n), A(12, 12);
  Eigen::VectorXd e(12), e_new(12), q_before;
  double damping = 1e-4;  // [m^2]
  double error = evaluate_legs(X_RE_target, J, e);
  for (int iteration = 0; iteration < kMaxIterations && residual_ > 1e-7 && damping < 1e3; ++iteration) {
    A.noalias() = J * J.transpose();
    A.diagonal().array() += damping;
    const Eigen::VectorXd step = J.transpose() * A.ldlt().solve(e);
    q_before = q_leg_;
    for (int j = 0; j < n; ++j) {
      const Dof& dof = lm.dof(leg_dofs_[j]);
      double& q = q_leg_[leg_dofs_[j]];
      q += step[j];
      if (!dof.continuous) q = std::clamp(q, dof.lower, dof.upper);
    }
    const std::array<double, 3> misses_before = {residual_, position_miss_, angle_miss_};
    const double error_new = evaluate_legs(X_RE_target, J_new, e_new);
    if (error_new < error) {
      error = error_new;
      J = J_new;
      e = e_new;
      damping = std::max(0.5 * damping, 1e-8);
    } else {
      q_leg_ = q_before;
      residual_ = misses_before[0];
      position_miss_ = misses_before[1];
      angle_miss_ = misses_before[2];
      damping *= 4.0;
    }
  }
}

void LegPoser::pose(const Data& data, const DrawnFeet& feet) {
  const Model& lm = *leg_model_;
  for (int i = 0; i < lm.num_dofs(); ++i)
    if (dof_in_model_[i] >= 0) q_leg_[i] = data.q[dof_in_model_[i]];
  // Targets in the leg model's world: the same pose relative to the root link as the
  // model's root link has to the foot.
  const Transform X_WR = frame_pose(*model_, data, root_);
  std::array<Transform, 2> X_RE_target;
  for (int side = 0; side < 2; ++side)
    X_RE_target[side] = X_WR.inverse() * foot_frame(feet.pose[side], feet.lift[side]) * legs_[side].X_FE;

  solve_legs(X_RE_target);
  if (residual_ > 1e-3) {
    // Stuck (a knee straight at its limit, which a step from the singular straight leg
    // cannot bend): again from the seed, keeping the better.
    const Eigen::VectorXd q_kept = q_leg_;
    const std::array<double, 3> misses_kept = {residual_, position_miss_, angle_miss_};
    for (size_t j = 0; j < leg_dofs_.size(); ++j) q_leg_[leg_dofs_[j]] = seed_[j];
    solve_legs(X_RE_target);
    if (residual_ > misses_kept[0]) {
      q_leg_ = q_kept;
      residual_ = misses_kept[0];
      position_miss_ = misses_kept[1];
      angle_miss_ = misses_kept[2];
    }
  }
  forward_kinematics(lm, *leg_data_, q_leg_);  // the kept configuration's poses
  // Each leg frame's pose relative to the root link, from the posed leg model.
  const Data& ld = *leg_data_;
  const Transform X_W_leg = X_WR * frame_pose(lm, ld, leg_root_).inverse();
  for (int f = 0; f < model_->num_frames(); ++f)
    if (leg_frame_of_[f] >= 0) poses_[f] = X_W_leg * frame_pose(lm, ld, leg_frame_of_[f]);
}

std::optional<Transform> LegPoser::leg_frame_pose(int frame) const {
  if (!usable_ || leg_frame_of_[frame] < 0) return std::nullopt;
  return poses_[frame];
}

std::optional<Vector3> LegPoser::leg_frame_position(int frame) const {
  const std::optional<Transform> X_WF = leg_frame_pose(frame);
  if (!X_WF) return std::nullopt;
  return X_WF->p;
}

}  // namespace wbm
