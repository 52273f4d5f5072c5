#pragma once
/// @file
/// Balance coupling (section V): a separate, replaceable module that shifts the upper body
/// in x and y to keep the centre of mass over the support polygon. It talks to the
/// whole-body solver only through the constraints b_C (upper-body x/y frozen) and the
/// external velocity that becomes x_bal (eqs. 19-21).

#include <array>
#include <memory>
#include <span>

#include <Eigen/Core>

#include "wbm/controller.hpp"

namespace wbm {

using Vector2 = Eigen::Vector2d;

/// Foot size and placement relative to the heel frame (origin centred between the feet on
/// the heel edge, x forward, section II).
struct FootGeometry {
  double length = 0.22;   ///< [m]
  double width = 0.12;    ///< [m]
  double spacing = 0.18;  ///< distance between the foot centre lines [m]
};

/// A planar pose of a foot: position of its heel-edge centre and yaw, world frame.
struct FootPose {
  Vector2 position = Vector2::Zero();
  double yaw = 0.0;
};

/// Where a foot stands beside the heel: `spacing / 2` [m] to the left (or right) of it,
/// across the heel's yaw [rad], with that yaw. Balance, walking and reports use it.
FootPose standing_foot(bool left, const Vector2& heel, double heel_yaw, double spacing);

/// Convex support polygon in the world x-y plane. Its vertices are stored in the object (at
/// most kMaxVertices), so that building, copying and querying one never allocates: the
/// walking module builds one in a cycle where a foot lands, and planned_support() one in
/// every cycle of a walk.
class SupportPolygon {
 public:
  static constexpr int kMaxFeet = 4;  ///< from_feet's limit
  static constexpr int kMaxVertices = 4 * kMaxFeet;  ///< the hull of kMaxFeet rectangles

  SupportPolygon() = default;
  /// Convex hull of the foot rectangles. Never allocates.
  /// @throws ConfigError for more than kMaxFeet feet.
  static SupportPolygon from_feet(std::span<const FootPose> feet, const FootGeometry& geometry);
  /// Both feet side by side at a heel pose (x, y, yaw).
  static SupportPolygon standing(const Vector2& heel, double heel_yaw, const FootGeometry& geometry);
  /// Counter-clockwise vertices (none for an empty polygon).
  std::span<const Vector2> vertices() const { return {vertices_.data(), static_cast<size_t>(num_vertices_)}; }
  double area() const { return area_; }           ///< [m^2]
  Vector2 centroid() const { return centroid_; }  ///< [m], world x-y
  /// Distance from p to the boundary, positive inside [m].
  double signed_distance(const Vector2& p) const;

 private:
  std::array<Vector2, kMaxVertices> vertices_{};
  int num_vertices_ = 0;
  double area_ = 0.0;
  Vector2 centroid_ = Vector2::Zero();
};

/// Computes the upper-body shift velocity; implement this to replace the balance law.
class BalanceLaw {
 public:
  virtual ~BalanceLaw() = default;
  /// Upper-body shift velocity in the world x-y plane [m/s] for the current state.
  virtual Vector2 shift_velocity(const Vector2& com, const SupportPolygon& support, double dt) = 0;
};

/// The shipped law: v = gain * (c - com) towards the polygon's centroid c; with margin > 0
/// only when the com is closer than `margin` to the boundary (dead zone inside).
class CenterOfMassCentering : public BalanceLaw {
 public:
  /// @throws ConfigError for gain <= 0 or a negative margin.
  CenterOfMassCentering(double gain, double margin);
  Vector2 shift_velocity(const Vector2& com, const SupportPolygon& support, double dt) override;

 private:
  double gain_, margin_;
};

enum BalanceFlag : std::uint32_t {
  kBalanceOk = 0,
  kNoSupport = 1u << 0,        ///< Support polygon of (nearly) zero area: no shift.
  kInvalidLawOutput = 1u << 1, ///< The law returned NaN/inf: no shift this cycle.
  kComOutside = 1u << 2,       ///< The com projection is outside the support polygon.
  kShiftSaturated = 1u << 3,   ///< Speed limit of the upper-body dofs reached.
  /// The law drives an upper-body x/y dof that stands at its position limit further out: the
  /// shift cannot follow (the centre of mass stays off the law's target); the dof's range
  /// (UrdfImportOptions::upper_body_x_range, _y_range) is too small for these feet.
  kShiftAtLimit = 1u << 4,
};

/// Glues a BalanceLaw to a controller's command: freezes the upper-body x/y dofs and
/// drives them with the law's velocity (section V, Fig. 5).
class BalanceModule {
 public:
  /// @throws ConfigError if the model has no upper-body x/y dofs.
  BalanceModule(const Model& model, std::unique_ptr<BalanceLaw> law, const FootGeometry& feet = {});
  /// Writes b_C and the external velocity of the upper-body x/y dofs into the command.
  /// Never allocates (the command must be sized by Controller::make_command()).
  std::uint32_t update(const Data& data, const SupportPolygon& support, double dt, Command& command);
  /// Releases the upper-body dofs again and zeroes their external velocity.
  void disable(Command& command) const;
  const FootGeometry& feet() const { return feet_; }
  double last_margin() const { return last_margin_; }
  /// Per upper-body dof (x, then y): +1 where the last update drove it against its upper
  /// limit, -1 against its lower limit, else 0 (kShiftAtLimit).
  const std::array<int, 2>& last_shift_at_limit() const { return last_shift_at_limit_; }

 private:
  const Model& model_;
  std::unique_ptr<BalanceLaw> law_;
  FootGeometry feet_;
  int ub_x_, ub_y_, heel_body_;
  double last_margin_ = 0.0;
  std::array<int, 2> last_shift_at_limit_ = {0, 0};
};

}  // namespace wbm
