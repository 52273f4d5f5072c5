#pragma once
/// @file
/// The 3D view's legs: a URDF robot's locked legs drawn standing on the feet.

#include <array>
#include <memory>
#include <optional>
#include <vector>

#include "scenario.hpp"
#include "wbm/balance.hpp"
#include "wbm/kinematics.hpp"

namespace wbm {

struct ScenarioRun;

/// Index into `legs` (the first links of leg subtrees, UrdfImportOptions::legs) of the leg
/// the model's frame `f` lies in (`f`, or a frame it hangs from: its parent frame, its parent
/// body's or its body's, is named there), or -1.
int leg_of(const Model& model, int f, const std::vector<std::string>& legs);

/// Where the report draws the two feet at one instant: each foot's place on the floor and
/// how high it is lifted [m] (index 0 left, 1 right).
struct DrawnFeet {
  std::array<FootPose, 2> pose;
  std::array<double, 2> lift = {0.0, 0.0};
};

/// The feet at time `t` [s] as the report draws them (the footprints and the posed legs):
/// standing beside the heel of the first cycle, then each footstep landing at its time
/// after a swing of the walk's step_duration, moved along the floor by a smooth step
/// (3 s^2 - 2 s^3 of the swing's share s) and lifted by 0.2 max_step_length sin(pi s).
DrawnFeet drawn_feet(const ScenarioRun& run, double t);

/// The controller treats a URDF robot's locked legs as rigid: welded at joint value 0 to
/// the link they hang from (the root link, or a pelvis below the waist joints). The paper's
/// model has no legs; below the heel, the robot's own walking controller moves them. Drawn
/// so, they swing with the upper body's lean, shift and height, and slide over the floor
/// while the feet step. LegPoser poses them for the report instead: the same URDF imported
/// with the legs free, and for each drawn sample a Levenberg-Marquardt inverse kinematics of
/// the leg joints (within their position limits, starting from the previous sample's
/// solution) puts each leg's last link where it stands on its foot, relative to the foot as
/// in the upright pose with straight legs (upright_base_configuration). A foot out of reach
/// is missed as little as the legs allow (position_miss(), angle_miss()). Only the drawing
/// changes: the trajectory, the centre of mass and the controller keep the locked legs.
class LegPoser {
 public:
  /// Usable (usable()) when the scenario's robot is a URDF with exactly two locked legs,
  /// one on each side of the root, each with a joint; otherwise nothing is posed.
  /// @param model the scenario's model; @param spacing [m] the feet's spacing (FootGeometry).
  LegPoser(const Scenario& scenario, const Model& model, double spacing);
  ~LegPoser();

  bool usable() const { return usable_; }
  /// Poses the legs under the upper body of `data` (forward_kinematics() of the scenario's
  /// model) on `feet`.
  /// @pre usable()
  void pose(const Data& data, const DrawnFeet& feet);
  /// Pose of the model's frame `frame` in the world (X_WF, [m]) after pose(), if the frame
  /// is in a locked leg; else nullopt.
  std::optional<Transform> leg_frame_pose(int frame) const;
  /// Its position p_WF [m]: leg_frame_pose()'s translation, or nullopt.
  std::optional<Vector3> leg_frame_position(int frame) const;
  /// After the last pose(): the largest distance [m] of a leg's last link from its place on
  /// its foot, and the largest angle [rad] it is turned from the foot's orientation there.
  /// Where both are not about zero the foot was out of the legs' reach: beyond their
  /// length or joint limits, or (NAO's hip joints, one dof for both legs) a turn the coupled
  /// legs cannot take.
  double position_miss() const { return position_miss_; }
  double angle_miss() const { return angle_miss_; }

 private:
  struct Leg {
    int end_frame = -1;  ///< the leg's last moving link, in the leg model
    Transform X_FE;      ///< its pose in the foot frame, upright with straight legs
  };
  /// Forward kinematics of the leg model at q_leg_, its legs' errors towards the targets
  /// (12: per leg position [m], orientation [rad] times 0.5 m) and Jacobian (12 x leg
  /// dofs), residual_; returns the squared error.
  double evaluate_legs(const std::array<Transform, 2>& X_RE_target, Eigen::MatrixXd& J, Eigen::VectorXd& e);

  /// Levenberg-Marquardt from q_leg_ towards the targets (each leg's last link relative to
  /// the root link); leaves q_leg_, residual_ and the leg model's poses at the best found.
  void solve_legs(const std::array<Transform, 2>& X_RE_target);

  bool usable_ = false;
  const Model* model_ = nullptr;
  std::unique_ptr<Model> leg_model_;  ///< the same URDF with the legs free
  std::unique_ptr<Data> leg_data_;
  int root_ = -1, leg_root_ = -1;     ///< the root link's frame in the model and the leg model
  std::array<Leg, 2> legs_;
  std::vector<int> leg_dofs_;         ///< the leg model's dofs of the legs
  std::vector<int> dof_in_model_;     ///< per leg-model dof: the model's dof of the same name, or -1
  std::vector<int> leg_frame_of_;     ///< per model frame: the leg model's frame if in a leg, else -1
  Eigen::MatrixXd J6_;               ///< a frame Jacobian of the leg model (6 x its dofs)
  std::vector<double> seed_;          ///< per leg dof: where a solve starts afresh
  Eigen::VectorXd q_leg_;             ///< the leg model's configuration (kept between samples)
  std::vector<Transform> poses_;      ///< per model frame, after pose(): leg frames' poses X_WF
  double residual_ = 0.0;  ///< the larger of the misses, the angle times 0.5 m (the solve's stop test)
  double position_miss_ = 0.0, angle_miss_ = 0.0;
};

}  // namespace wbm
