#pragma once
/// @file
/// Walking by a floating heel (section VI): a trigger decides when reaching needs walking;
/// then the heel dofs are released so the heel frame floats to the pose that is optimal for
/// the null-space criterion while the hands keep tracking, and a step generator walks the
/// feet to it. When the floating heel has converged and the feet are there, the heel is
/// frozen again. Like balance, it talks to the solver only through b_C.

#include <cstdint>

#include "wbm/balance.hpp"
#include "wbm/controller.hpp"

namespace wbm {

struct WalkingParameters {
  // Trigger (section VI: "the violation of a joint limit, reaching a threshold in the null
  // space cost function"); any of them, held for trigger_time, starts walking.
  bool trigger_on_joint_limit = true;   ///< a dof clamped or frozen at its limit
  double cost_threshold = 0.6;          ///< null-space cost H above this; <= 0: off
  double stall_time = 0.6;              ///< [s] task error not decreasing by 1 %; <= 0: off
  /// A walk starts only while some active row's error exceeds the tolerance of its unit
  /// (TaskElement::row_unit): metres and radians are never compared with each other.
  double position_tolerance = 0.005;    ///< [m] lengths: positions, centre of mass, prismatic joints; > 0
  double angle_tolerance = 0.005;       ///< [rad] axis and attitude angles, revolute joints; > 0
  double trigger_time = 0.05;           ///< [s]
  // Step generator: limits relative to the support foot and the step duration.
  double max_step_length = 0.25;  ///< [m] forward (backward: half of it)
  double max_step_width = 0.30;   ///< [m] lateral distance between the feet, at most
  double min_step_width = 0.14;   ///< [m] at least
  double max_step_turn = 0.35;    ///< [rad]
  double step_duration = 0.6;     ///< [s]
  // Convergence: heel dof speeds below this for converge_time, feet within the tolerance.
  double converged_speed = 0.01;    ///< [m/s] and [rad/s]
  double converge_time = 0.3;       ///< [s]
  double feet_tolerance = 0.02;     ///< [m]; angles: feet_tolerance [rad] * 2
  int max_steps = 60;               ///< per walk: no endless stepping
  int max_walks = 3;                ///< walks per target without progress before giving up
  /// [s] A walk that ends while the heel still moves (stalled, or max_steps) freezes the heel
  /// dofs in b_C and brakes them to rest through the command's external velocity, each at
  /// v_max / heel_stop_time (the heel's speed limits: at most this long from full speed),
  /// instead of stopping them within a cycle (0.5 m/s to 0 in 2 ms: 250 m/s^2). <= 0, or a
  /// command without external velocities: the heel stops at once.
  double heel_stop_time = 0.25;
  /// [max_step_length] How far the floating heel may run ahead of the real heel (between
  /// the feet); >= 1, or <= 0 for no bound (the paper's planner). Beyond it the heel dofs
  /// are held in b_C (braked as above) until landings bring the feet half a step nearer
  /// (kHeelHeld); while held, the feet face the way to the heel. The heel (up to 0.5 m/s
  /// per axis) can outrun the feet (at most max_step_length per step_duration forward,
  /// slower backward and sideways): unbounded, the paper model's body ran up to 0.81 m
  /// ahead of its feet on 4-5 m walks, 0.56 m with 2 and 0.44 m with 1.5 steps. The feet
  /// take full steps only while the heel is at least 1.5 steps ahead (docs/solver.md).
  double max_heel_lead = 2.0;
  /// A walk whose task error has not fallen by 1 % for stall_time stops: the heel is frozen
  /// where it is and the feet finish their steps to it. A walk that did not reduce the
  /// error to below 90 % of its value at the trigger counts as a walk without progress.
};

/// The height standing straight the WalkingParameters defaults are for [m]: the paper
/// model's upper body (upper_body_z's upper limit), as its foot spacing is FootGeometry's.
inline constexpr double kDefaultWalkingHeight = 0.6;

/// The defaults, which are the paper model's (upper body 0.6 m above the ground, feet 0.18 m
/// apart), scaled to a robot: the step widths by its feet's spacing (0.78 and 1.67 times it;
/// NAO's feet stand 0.10 m apart, H1's 0.41 m; the smaller at least 1.1 times the feet's
/// width, so that they do not land on each other, but not above the spacing),
/// max_step_length and position_tolerance by its upper body's height standing straight
/// (upper_body_z's upper limit: 0.25 m and 5 mm per 0.6 m of height; NAO 0.14 m and 2.8 mm,
/// H1 0.43 m and 8.7 mm; angle_tolerance stays) and step_duration by that
/// height's square root (equal Froude numbers, so that a robot walks as the paper model
/// would at its size: NAO 0.45 s, H1 0.79 s; the URDF import scales the heel's speed limit
/// alike). A height that is not above 0.05 m (a base on the ground), or a model without an
/// upper_body_z dof, keeps the default length, tolerance and duration.
WalkingParameters scaled_walking_parameters(const Model& model, const FootGeometry& feet);

enum WalkingFlag : std::uint32_t {
  kWalkStanding = 0,
  kWalkTriggered = 1u << 0,   ///< Walking started this cycle.
  kWalking = 1u << 1,         ///< Heel released, stepping.
  kWalkFinished = 1u << 2,    ///< Heel frozen again this cycle.
  kStepLimitReached = 1u << 3,///< Walk ended by max_steps.
  kWalkGivenUp = 1u << 4,     ///< max_walks walks without progress: no more walking until the command changes.
  kFootstepLanded = 1u << 5,  ///< A swing foot landed this cycle: last_footstep().
  kHeelHeld = 1u << 6,        ///< The floating heel is held: max_heel_lead ahead of the feet.
};

struct Footstep {
  double time = 0.0;  ///< landing time [s]
  bool left = true;
  FootPose pose;
};

class WalkingModule {
 public:
  /// @throws ConfigError if the model has no heel dofs or parameters are invalid.
  WalkingModule(const Model& model, const FootGeometry& feet, const WalkingParameters& parameters = {});

  /// Call once per cycle before Controller::update with the status of the previous cycle.
  /// Writes b_C of the heel dofs and, where the command has external velocities, theirs
  /// (zero, or the braking of a heel frozen while it moved). `time` is the simulation time [s].
  std::uint32_t update(const Controller& controller, const ControllerStatus& last, double time, double dt,
                       Command& command);
  /// The command's targets changed: walking may be triggered again.
  void target_changed();
  /// Stands both feet beside the heel of `q` (heel x, y, yaw), where a robot whose start is
  /// not the model's home pose (Controller::reset with the heel elsewhere) stands; the
  /// constructor stands them beside the home pose's heel. Not during a walk.
  /// @throws ConfigError if q.size() != num_dofs or a walk is under way.
  void stand_at(const Eigen::VectorXd& q);

  bool walking() const { return walking_; }
  /// The footstep of the last update that returned kFootstepLanded (a default Footstep
  /// before the first). The module keeps no log of them, so that no cycle allocates: collect
  /// them on kFootstepLanded where you need the whole walk (wbm run's footsteps.csv).
  const Footstep& last_footstep() const { return last_footstep_; }
  /// Footsteps landed since construction.
  int num_footsteps() const { return num_footsteps_; }
  FootPose left_foot() const { return left_; }
  FootPose right_foot() const { return right_; }
  /// The real heel: between the feet.
  FootPose real_heel() const;
  /// Support polygon of the feet (both feet; during a step the swing foot is on its way).
  /// Built when a foot lands, not on every call.
  const SupportPolygon& support() const { return support_; }
  /// Both feet standing beside the heel of configuration q (x, y, yaw of the heel dofs;
  /// during a walk the floating heel, where the plan puts the feet and the body goes): the
  /// support to balance the upper body over while walking(). Balancing over support(), the
  /// feet left behind, fights the floating heel: walks then stepped in place for as long
  /// as they ran (docs/solver.md, "Walking").
  /// Never allocates. @throws ConfigError if q does not have the model's num_dofs() entries.
  SupportPolygon planned_support(const Eigen::VectorXd& q) const;
  /// The support to balance over in this cycle: planned_support(q) while walking(), else
  /// support(). Never allocates. @throws ConfigError as planned_support.
  SupportPolygon balance_support(const Eigen::VectorXd& q) const { return walking_ ? planned_support(q) : support_; }

 private:
  FootPose stance_target(bool left, const Vector2& heel, double yaw) const;
  FootPose limited_step(bool left, const FootPose& support, const FootPose& target) const;
  void set_heel_free(Command& command, bool free) const;
  /// The walk's decisions for this cycle (update() without the heel's braking).
  std::uint32_t update_walk(const Controller& controller, const ControllerStatus& last, double time, double dt,
                            Command& command);
  /// External velocities of the heel dofs: zero while they are free; where they were frozen
  /// this cycle while moving, their last rates, falling to zero at v_max / heel_stop_time.
  void brake_heel(const Controller& controller, bool was_free, double dt, Command& command);
  bool feet_at(const Vector2& heel, double yaw) const;
  /// The support polygon of the feet as they stand now (after a landing).
  void update_support();

  FootGeometry feet_;
  WalkingParameters p_;
  int heel_dofs_[3];
  double heel_deceleration_[3] = {0.0, 0.0, 0.0};  // v_max / heel_stop_time [m/s^2, rad/s^2]
  double heel_brake_[3] = {0.0, 0.0, 0.0};         // the frozen heel's external rates while braking
  bool heel_free_ = false;                          // b_C of the heel in the last command
  int num_dofs_ = 0;
  bool walking_ = false;
  bool finishing_ = false;  // heel frozen again, feet still stepping to it
  bool holding_ = false;    // heel held: max_heel_lead ahead of the real heel
  double error_at_trigger_ = 0.0;
  bool given_up_ = false;
  int walks_without_progress_ = 0;
  int steps_this_walk_ = 0;
  // 1 / position_tolerance and 1 / angle_tolerance: each row's error in its tolerances.
  double per_length_tolerance_ = 0.0, per_angle_tolerance_ = 0.0;
  double trigger_timer_ = 0.0, converge_timer_ = 0.0, stall_timer_ = 0.0, best_error_ = 1e300;
  double step_timer_ = 0.0;
  bool next_left_ = true;
  FootPose left_, right_;
  SupportPolygon support_;  // of left_ and right_ (update_support)
  Footstep last_footstep_;
  int num_footsteps_ = 0;
};

}  // namespace wbm
