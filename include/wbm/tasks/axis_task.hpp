#pragma once
#include "wbm/task_element.hpp"

namespace wbm {

/// 2-dof axis task, eqs. (15)-(18): an axis of a frame (grasp axis of a hand, view axis of a
/// camera; by default the frame's z-axis) towards a target direction; rotation about the
/// axis stays free.
///
/// Target: a direction (3 values, any non-zero length) in the reference frame; its rate is
/// the time derivative of the unit target direction. Rows: the angular-velocity Jacobian
/// rotated into the sl-frame (z = current axis a_g, y = a_g x a_t / |a_g x a_t|), rows x
/// and y (eq. 18). Error: (0, phi) with phi the angle of eq. (15), computed as
/// atan2(|a_g x a_t|, a_g . a_t) (accurate near 0 and pi).
///
/// Degenerate cases (|a_g x a_t| < 1e-12): the sl-frame's y-axis is taken as the frame's
/// own y-axis (perpendicular to a_g; for another axis a, the y-axis made perpendicular to a,
/// or the z-axis if a is along y). Axes coinciding: phi = 0, the error is zero and the
/// solution does not depend on the choice of y (the two rows span the same plane), so the
/// result is continuous. Axes opposite: phi = pi and the axis turns about the frame's
/// y-axis, a deterministic choice on a set where no continuous choice exists.
class AxisTask : public TaskElement {
 public:
  /// @param axis the axis in the frame's coordinates (any non-zero length; normalised):
  ///   e.g. (1, 0, 0) for a camera link that looks along x (REP 103), the default z for
  ///   an optical frame or the paper model's hand and camera frames.
  /// @throws ModelError if a frame is unknown; ConfigError if the axis is zero or not finite.
  AxisTask(const Model& model, std::string name, const std::string& frame, const std::string& reference = "",
           const Vector3& axis = Vector3::UnitZ());
  void value(const Model& model, const Data& data, Eigen::Ref<Eigen::VectorXd> x) override;
  void evaluate(const Model& model, const Data& data, const Eigen::Ref<const Eigen::VectorXd>& target,
                const Eigen::Ref<const Eigen::VectorXd>& target_rate, Eigen::Ref<Eigen::MatrixXd> J,
                Eigen::Ref<Eigen::VectorXd> error, Eigen::Ref<Eigen::VectorXd> rate) override;
  /// The sl-frame rotation R_Rsl (columns x, y, z in the reference frame) and phi.
  static Matrix3 sl_frame(const Vector3& a_g, const Vector3& a_t, const Vector3& fallback_y, double* phi);

 private:
  RelativeFrame frame_;
  bool z_axis_ = true;                  // the default: the frame's columns, without products
  Vector3 a_F_ = Vector3::UnitZ();      // the axis in the frame
  Vector3 y_F_ = Vector3::UnitY();      // perpendicular to it: the sl-frame's fallback y
};

}  // namespace wbm
