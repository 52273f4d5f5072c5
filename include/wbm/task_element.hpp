#pragma once
/// @file
/// The task element interface (section III): a value, Jacobian rows and an error.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "wbm/kinematics.hpp"
#include "wbm/model.hpp"

namespace wbm {

/// How a trajectory filter has to treat an element's target.
enum class TargetKind {
  kVector,     ///< Euclidean values (positions, angles, joint values).
  kDirection,  ///< A unit vector moved along great circles (2-dof axis tasks).
};

/// The unit of a task row's value and error, for decisions that compare errors of different
/// rows (walking's trigger tolerances: WalkingParameters::position_tolerance and
/// angle_tolerance).
enum class RowUnit {
  kLength,  ///< [m]: positions, the centre of mass, prismatic joints.
  kAngle,   ///< [rad]: axis and attitude angles, revolute joints.
};

/// One task element: a few rows of the task vector x (eq. 4).
///
/// Targets and their rates are given in the element's reference frame (the world, or a
/// frame of the model such as "heel"). The element returns its Jacobian rows J, its error
/// e to the target, and the feed-forward rate r, so that the commanded task velocity is
/// r + gain * e (closed-loop inverse kinematics; the paper's eq. 5 is the case gain = 0).
class TaskElement {
 public:
  /// @throws ConfigError if the gain is negative or not finite.
  /// @throws ConfigError if target_period is negative or not finite.
  TaskElement(std::string name, int dim, int target_dim, TargetKind kind, double target_period = 0.0);
  virtual ~TaskElement() = default;

  const std::string& name() const { return name_; }
  /// Number of rows (scalar task elements).
  int dim() const { return dim_; }
  /// Size of the target vector (3 for a 2-dof axis: a direction).
  int target_dim() const { return target_dim_; }
  TargetKind target_kind() const { return kind_; }
  /// Period of every target entry [rad]: 2 pi for angles (AttitudeTask), 0 for none. A
  /// target and the same target plus whole periods are the same: the controller moves a
  /// commanded target by whole periods to within half a period of its filter's output
  /// (the short way round) and takes value rates modulo the period.
  double target_period() const { return target_period_; }
  /// Unit of row `row`. Every row is a length unless the element says otherwise
  /// (set_row_unit): the shipped angle elements and JointTask's revolute rows do.
  /// @pre 0 <= row < dim().
  RowUnit row_unit(int row) const { return row_units_[static_cast<size_t>(row)]; }
  /// Error feedback gain [1/s].
  double gain() const { return gain_; }
  /// @throws ConfigError if gain < 0 or not finite.
  void set_gain(double gain);

  /// True while every row of the element is active: set by TaskStack::assemble before it
  /// calls evaluate() (true for an element evaluated on its own). An element whose rows
  /// interact (AttitudeTask) may compute its error differently when all are active.
  bool all_rows_active() const { return all_rows_active_; }
  /// True if the element reads the centre of mass (the controller then computes it).
  virtual bool needs_center_of_mass() const { return false; }

  /// Current value (target_dim entries) from the last forward_kinematics() (and
  /// center_of_mass() for centre-of-mass elements).
  virtual void value(const Model& model, const Data& data, Eigen::Ref<Eigen::VectorXd> x) = 0;

  /// Jacobian rows J (dim x nq), error e (dim) and feed-forward rate r (dim) for a target
  /// and its time derivative (target_dim each). Never allocates.
  virtual void evaluate(const Model& model, const Data& data, const Eigen::Ref<const Eigen::VectorXd>& target,
                        const Eigen::Ref<const Eigen::VectorXd>& target_rate, Eigen::Ref<Eigen::MatrixXd> J,
                        Eigen::Ref<Eigen::VectorXd> error, Eigen::Ref<Eigen::VectorXd> rate) = 0;

 protected:
  /// For the constructors of derived elements. @throws ConfigError if row is not in [0, dim()).
  void set_row_unit(int row, RowUnit unit);

 private:
  friend class TaskStack;  // sets all_rows_active_
  std::string name_;
  std::vector<RowUnit> row_units_;
  bool all_rows_active_ = true;
  double target_period_ = 0.0;
  int dim_;
  int target_dim_;
  TargetKind kind_;
  double gain_ = 10.0;
};

/// Turns J (3 x nq, in: the world velocity of point p_WQ) into the velocity of Q relative
/// to frame `reference`, expressed in it: R_WR^T (J - J_v,R + [p_WQ - p_WR]x J_w,R).
/// Never allocates.
void express_point_jacobian_in_frame(const Model& model, const Data& data, int reference, const Vector3& p_WQ,
                                     Eigen::Ref<Eigen::MatrixXd> J);

/// A frame point and the frame its task values are expressed in (world if reference < 0).
/// Computes the relative position, rotation and Jacobians (eq. 14 and its relative form).
class RelativeFrame {
 public:
  /// @throws ModelError naming an unknown frame. `reference` empty or "world": the world.
  RelativeFrame(const Model& model, const std::string& frame, const std::string& reference);
  int frame() const { return frame_; }
  int reference() const { return reference_; }
  /// Rotation R_WR of the reference frame (identity for the world).
  Matrix3 reference_rotation(const Model& model, const Data& data) const;
  /// Position p_RF and rotation R_RF of the frame in the reference frame.
  Transform pose(const Model& model, const Data& data) const;
  /// Position p_RF alone (pose().p without the rotation product).
  Vector3 position(const Model& model, const Data& data) const;
  /// z-axis of the frame in the reference, R_RF e_z (pose().R.col(2) without the full product).
  Vector3 z_axis(const Model& model, const Data& data) const;
  /// Translational Jacobian (3 x nq) of the frame origin relative to the reference,
  /// expressed in the reference: d/dt p_RF.
  void translational_jacobian(const Model& model, const Data& data, Eigen::Ref<Eigen::MatrixXd> J);
  /// Rotational Jacobian (3 x nq): the relative angular velocity, in the reference.
  void rotational_jacobian(const Model& model, const Data& data, Eigen::Ref<Eigen::MatrixXd> J);

 private:
  int frame_ = -1;
  int reference_ = -1;
};

}  // namespace wbm
