#pragma once
/// @file
/// The immutable robot model: a tree of 1-dof joints in topological order.

#include <array>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "wbm/transform.hpp"

namespace wbm {

enum class JointType { kRevolute, kPrismatic };

/// What a dof stands for. The paper's virtual dofs (section II) carry their own role so
/// that balance and walking can find them in any model.
enum class DofRole { kJoint, kHeelX, kHeelY, kHeelYaw, kUpperBodyX, kUpperBodyY, kUpperBodyZ,
                     kUpperBodyRoll, kUpperBodyPitch, kUpperBodyYaw };

/// One independent degree of freedom, i.e. one entry of the state vector q (eq. 1).
struct Dof {
  std::string name;
  JointType type = JointType::kRevolute;
  DofRole role = DofRole::kJoint;
  bool continuous = false;  ///< No position limits (lower = -inf, upper = +inf).
  double lower = 0.0;       ///< Position limit [rad] or [m].
  double upper = 0.0;       ///< Position limit [rad] or [m].
  double max_speed = 0.0;   ///< Speed limit [rad/s] or [m/s], > 0.
  /// Work range [rad] or [m] used for the weighting matrix W (section IV.C) and to
  /// normalise the joint-limit criteria: upper - lower, 2*pi for continuous joints.
  double work_range = 0.0;
  /// Effort limit [N m] or [N], >= 0: the URDF's, kept only to be exported again (wbm
  /// controls velocities); 0 where none was given.
  double max_effort = 0.0;
  /// Centre of the work range (joint-limit criteria); 0 for continuous joints.
  double center() const { return continuous ? 0.0 : 0.5 * (lower + upper); }
};

/// Largest length a model accepts [m] (joint offsets, centres of mass, prismatic limits)
/// and largest body mass [kg]: beyond any robot, and small enough that no pose, Jacobian or
/// centre of mass computed from them overflows (a joint offset of 1e308 m made them NaN).
inline constexpr double kMaxLength = 1e6;
inline constexpr double kMaxMass = 1e6;

/// Mass properties of a body.
struct Inertial {
  double mass = 0.0;                  ///< [kg]
  Vector3 com = Vector3::Zero();      ///< Centre of mass in the body frame [m].
  Matrix3 inertia = Matrix3::Zero();  ///< Inertia about the com, body axes [kg m^2].
};

/// One rigid body and the joint that connects it to its parent.
/// Pose of the body: X_WB = X_WP * X_PJ * joint_motion(multiplier * q[dof] + offset).
struct Body {
  std::string name;
  int parent = -1;          ///< Parent body index, -1 for the world. Always < own index.
  Transform X_PJ;           ///< Joint frame in the parent frame (eq. 3's P r_PC and A_CP).
  JointType joint_type = JointType::kRevolute;
  Vector3 axis = Vector3::UnitZ();  ///< Unit joint axis, in the joint (= body) frame.
  int dof = -1;             ///< Driving dof; -1 for a body welded to its parent.
  double multiplier = 1.0;  ///< Mimic coupling: joint value = multiplier * q[dof] + offset.
  double offset = 0.0;
  Inertial inertial;
  /// Name of the joint that connects the body in the robot's description (the URDF's), kept
  /// for the export; empty if none (the export then names the joint after the dof or body).
  std::string joint_name{};
};

/// A named frame rigidly attached to a body: hand reference points, cameras, URDF links.
/// Its z-axis is the "axis" used by 2-dof axis tasks (grasp axis, view axis).
struct Frame {
  std::string name;
  int body = 0;
  Transform X_BF;
  /// The frame this one hangs from in the robot's description (a URDF link's parent link,
  /// after re-rooting), so that the links between welded frames can be drawn: a frame on
  /// the same body or, for a body's own frame, one on the parent body. -1 if not given:
  /// then the frame hangs from its body's origin, a body's own frame from the parent body's.
  int parent = -1;
  /// Name of the fixed joint that attaches the frame in the robot's description (a welded
  /// URDF link's joint, or a locked leg's), kept for the export; empty if none.
  std::string joint_name{};
};

/// Indices of the paper's virtual dofs in q (section II), -1 where a model has none.
struct VirtualDofs {
  int heel_x = -1, heel_y = -1, heel_yaw = -1;
  int ub_x = -1, ub_y = -1, ub_z = -1, ub_roll = -1, ub_pitch = -1, ub_yaw = -1;
  int heel_body = -1;        ///< Body whose frame is the heel frame.
  int upper_body = -1;       ///< Body whose frame is the upper-body (root) frame.
  /// The nine dof indices in the order heel x, y, yaw, upper body x, y, z, roll, pitch, yaw.
  std::array<int, 9> all() const { return {heel_x, heel_y, heel_yaw, ub_x, ub_y, ub_z, ub_roll, ub_pitch, ub_yaw}; }
};

/// Immutable robot model. Build it with ModelBuilder, the built-in paper model
/// (make_paper_model) or the URDF importer. One model serves many Data and controllers.
class Model {
 public:
  const std::string& name() const { return name_; }
  int num_dofs() const { return static_cast<int>(dofs_.size()); }
  int num_bodies() const { return static_cast<int>(bodies_.size()); }
  int num_frames() const { return static_cast<int>(frames_.size()); }
  const std::vector<Dof>& dofs() const { return dofs_; }
  const Dof& dof(int i) const { return dofs_.at(i); }
  const std::vector<Body>& bodies() const { return bodies_; }
  const Body& body(int i) const { return bodies_.at(i); }
  const std::vector<Frame>& frames() const { return frames_; }
  const Frame& frame(int i) const { return frames_.at(i); }
  /// True for a body's own frame (named as the body, at its origin), false for the other
  /// frames (welded URDF links, hand points, cameras). @pre 0 <= frame < num_frames().
  bool is_body_frame(int frame) const { return frames_[frame].name == bodies_[frames_[frame].body].name; }
  const VirtualDofs& virtual_dofs() const { return virtual_dofs_; }

  /// Total mass [kg].
  double total_mass() const { return total_mass_; }
  /// Mass of the subtree rooted at each body [kg].
  const std::vector<double>& subtree_mass() const { return subtree_mass_; }
  /// Home configuration: a relaxed pose inside all limits.
  const Eigen::VectorXd& home() const { return home_; }
  /// Lower / upper limits of all dofs as vectors (-inf/+inf for continuous joints).
  const Eigen::VectorXd& lower_limits() const { return lower_; }
  const Eigen::VectorXd& upper_limits() const { return upper_; }
  const Eigen::VectorXd& max_speeds() const { return max_speed_; }

  /// Precomputed for forward kinematics: +1..+3 / -1..-3 when a body's axis is +-x, +-y,
  /// +-z (a cheap column rotation), 0 for a general axis.
  const std::vector<int>& axis_codes() const { return axis_code_; }
  /// True where a body's joint offset X_PJ has no rotation.
  const std::vector<char>& offset_without_rotation() const { return offset_without_rotation_; }
  /// The bodies ordered by their depth in the tree (root first, parents before children,
  /// bodies of equal depth in index order).
  const std::vector<int>& depth_order() const { return depth_order_; }
  /// The bodies with a dof on the path from the root to `body`, `body` first (if it has a
  /// dof) and the root's side last: the joints that move it, i.e. the possibly non-zero
  /// columns of its Jacobians. Precomputed, so the Jacobians walk an array instead of
  /// chasing parent indices. @pre 0 <= body < num_bodies().
  std::span<const int> moving_bodies(int body) const {
    return {chain_bodies_.data() + chain_offset_[body], chain_bodies_.data() + chain_offset_[body + 1]};
  }

  /// @throws ModelError naming the dof if there is none with this name.
  int dof_index(const std::string& name) const;
  /// @throws ModelError naming the frame (and listing a few known ones) if unknown.
  int frame_index(const std::string& name) const;
  /// -1 if unknown.
  int find_frame(const std::string& name) const;
  int find_dof(const std::string& name) const;
  /// @throws ModelError if q has the wrong size, a NaN, or lies outside the limits.
  void check_configuration(const Eigen::VectorXd& q) const;

 private:
  friend class ModelBuilder;
  std::string name_;
  std::vector<Dof> dofs_;
  std::vector<Body> bodies_;
  std::vector<Frame> frames_;
  VirtualDofs virtual_dofs_;
  double total_mass_ = 0.0;
  std::vector<double> subtree_mass_;
  std::vector<int> axis_code_;
  std::vector<char> offset_without_rotation_;
  std::vector<int> depth_order_;
  std::vector<int> chain_offset_, chain_bodies_;  // moving_bodies(b) = chain_bodies_[offset[b], offset[b + 1])
  Eigen::VectorXd home_, lower_, upper_, max_speed_;
};

/// Assembles and validates a Model.
class ModelBuilder {
 public:
  explicit ModelBuilder(std::string name) { model_.name_ = std::move(name); }
  /// Adds a dof and returns its index.
  int add_dof(const Dof& dof);
  /// Adds a body (its parent must already exist) and returns its index.
  /// Also adds a frame with the body's name at the body origin.
  int add_body(const Body& body);
  /// Adds a named frame and returns its index.
  int add_frame(const Frame& frame);
  /// Sets Frame::parent of an added frame (e.g. of a body's own frame). Checked by build().
  /// @throws ModelError if `frame` is not the index of an added frame.
  void set_frame_parent(int frame, int parent);
  int num_frames() const { return static_cast<int>(model_.frames_.size()); }
  void set_virtual_dofs(const VirtualDofs& v) { model_.virtual_dofs_ = v; }
  /// Home configuration; defaults to the dof centres.
  void set_home(const Eigen::VectorXd& q) { home_ = q; }
  int num_bodies() const { return static_cast<int>(model_.bodies_.size()); }
  /// Validates everything and returns the model.
  /// @throws ModelError naming the element (duplicate names, bad axes, negative masses,
  ///   lower limit above upper, non-positive speed limits, a dof driving no body, an
  ///   infinite work range, lengths beyond kMaxLength or masses beyond kMaxMass, ...).
  Model build();

 private:
  Model model_;
  Eigen::VectorXd home_;
};

/// Default ranges and speed limits of the virtual heel and upper-body dofs, for a robot
/// whose upper-body origin stands `height` metres above the heel in the home pose
/// (0: on the ground, a fixed-base robot's base link): the heel's speed limit 0.5 m/s x
/// sqrt(height / 0.6 m) (0.5 m/s for heights up to 0.05 m), as walking's steps scale.
/// Documented in docs/model.md.
/// @pre height >= 0 and finite.
std::array<Dof, 9> default_virtual_dofs(double height);

/// Appends the nine virtual bodies (heel x, y, yaw; upper body x, y, z, roll, pitch, yaw)
/// and their dofs, and records them as the model's virtual dofs. Returns the index of the
/// last body (the upper body, named `upper_body_name`). The heel body is named "heel".
/// @param R_UR orientation of the upper body's own frame (a URDF root link) in the frame
///   the virtual dofs move (x forward, y left, z up); the upper-body yaw dof still turns
///   about the vertical. Identity unless the root link is turned (UrdfImportOptions::root_rpy).
int add_virtual_base(ModelBuilder& builder, double height, const std::string& upper_body_name,
                     const Inertial& heel, const Inertial& upper_body, const Matrix3& R_UR = Matrix3::Identity());

/// Same with the nine dofs given (e.g. default_virtual_dofs() with other upper-body ranges),
/// in the order heel x, y, yaw, upper body x, y, z, roll, pitch, yaw.
/// @param pivot_above_root [m] how far the upper body's pivot (where the virtual dofs end:
///   upper_body_z's height, the centre of the roll and pitch) lies above the root link's
///   origin, along the upper body's z axis: 0 unless the root link's origin lies at the
///   feet (UrdfImportOptions::upper_body_pivot). The yaw still turns about the vertical
///   through both. @throws ModelError unless finite and >= 0.
int add_virtual_base(ModelBuilder& builder, const std::array<Dof, 9>& dofs, const std::string& upper_body_name,
                     const Inertial& heel, const Inertial& upper_body, const Matrix3& R_UR = Matrix3::Identity(),
                     double pivot_above_root = 0.0);

/// The upper body's pivot above the root link's origin [m] (add_virtual_base's
/// pivot_above_root): 0 for a model without virtual dofs.
double upper_body_pivot_above_root(const Model& model);

/// `q` (nq) with the virtual dofs upright: the heel at the world origin facing along x, the
/// upper body straight above it at the top of its height range (the root height given to
/// the URDF import), neither shifted nor tilted; every other entry unchanged. This is the
/// pose of a robot on a fixed base (e.g. a dual-arm robot on a pedestal), whose nine
/// virtual dofs are then kept frozen (b_C = 0): its root link's origin at (0, 0, root
/// height) [m] with the world's axes (turned by UrdfImportOptions::root_rpy, if given).
/// Values outside a dof's range are clamped into it.
/// @throws ModelError if q.size() != num_dofs().
Eigen::VectorXd upright_base_configuration(const Model& model, const Eigen::VectorXd& q);

const char* to_string(JointType type);
const char* to_string(DofRole role);

}  // namespace wbm
